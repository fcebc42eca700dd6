// Energy-model benchmarks on real Bandai Namco clips (docs/performance.md):
//  - h over precomputed float arrays (scan_approximate_energy), full-body static query;
//  - Newton-Euler g for one step (two inverse dynamics + the step);
//  - per-frame dynamics precomputation (compute_clip_dynamics from world poses);
// plus the double-precision reference h, partial queries and the root-only scan.
// All single-threaded; items/s = frames (or steps) per second per core.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "mocap/common/body/body.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/energy.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/units.hpp"

namespace {

using namespace mocap;

std::filesystem::path data_dir() {
  if (const char* e = std::getenv("MOCAP_DATA_DIR"); e && *e) return e;
  return MOCAP_DEFAULT_DATA_DIR;
}

struct Data {
  bool ok = false;
  DynamicsModel model;
  std::vector<ClipMotion> motions;
  std::vector<ClipDynamics> clips;
  std::size_t frames = 0;
};

// Up to 40 clips of Bandai Namco set 1 (about 9,000 frames), all on the first
// clip's character model (same joint names).
const Data& data() {
  static const Data d = [] {
    Data x;
    const auto dir = data_dir() / "bandai-namco-1" / "data";
    if (!std::filesystem::is_directory(dir)) return x;
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(dir))
      if (e.path().extension() == ".bvh") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (std::size_t i = 0; i < files.size() && x.clips.size() < 40; i += 4) {
      const RawClip raw = read_bvh_file(files[i]);
      ClipMotion m = clip_motion_from_raw(raw, unit_scale_m(detect_unit(raw)));
      if (x.clips.empty())
        x.model = build_dynamics_model(m.skeleton, build_body(m.skeleton, Character{}));
      if (m.joint_count() != x.model.joint_count()) continue;
      x.clips.push_back(compute_clip_dynamics(x.model, m));
      x.frames += m.frame_count;
      x.motions.push_back(std::move(m));
    }
    x.ok = !x.clips.empty();
    return x;
  }();
  return d;
}

// A table of at least `frames` frames (clips repeated).
HScanTable table_of(std::size_t frames) {
  const Data& d = data();
  HScanTable t;
  init_h_scan_table(d.model, frames, t);
  std::size_t f = 0;
  while (f < frames)
    for (const ClipDynamics& c : d.clips)
      for (std::size_t i = 0; i < c.frame_count && f < frames; ++i)
        set_h_scan_frame(d.model, c.state(i), f++, t);
  return t;
}

BodyState static_query() {
  const Data& d = data();
  BodyState s;
  const StateView v = d.clips[0].state(d.clips[0].frame_count / 2);
  static_state(d.model, PoseView{v.joint_positions_m, v.rotations}, s);
  return s;
}

void BM_HScan(benchmark::State& st) {
  if (!data().ok) return st.SkipWithError("no Bandai Namco data");
  const auto frames = static_cast<std::size_t>(st.range(0));
  const HScanTable table = table_of(frames);
  const BodyState q = static_query();
  const HScanQuery hq = make_h_scan_query(data().model, q.view(), 0.5);
  std::vector<float> out(frames);
  for (auto _ : st) {
    scan_approximate_energy(table, hq, 0, frames, out.data());
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations()) *
                       static_cast<std::int64_t>(frames));
  st.counters["segments"] = static_cast<double>(table.segment_count);
  st.counters["table_MB"] = static_cast<double>(table.values.size() * sizeof(float)) / 1e6;
}
// 4,096 frames (~3 MB, cache-resident) and 262,144 frames (~190 MB, streamed from memory).
BENCHMARK(BM_HScan)->Arg(4096)->Arg(262144)->Unit(benchmark::kMicrosecond);

void BM_HRootTranslationScan(benchmark::State& st) {
  if (!data().ok) return st.SkipWithError("no Bandai Namco data");
  const std::size_t frames = 262144;
  const HScanTable table = table_of(frames);
  const HScanRootQuery q = make_h_scan_root_query(data().model, {0.0, std::nullopt, 3.0}, 0.5);
  std::vector<float> out(frames);
  for (auto _ : st) {
    scan_root_translation_energy(table, q, 0, frames, out.data());
    benchmark::DoNotOptimize(out.data());
  }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations()) *
                       static_cast<std::int64_t>(frames));
}
BENCHMARK(BM_HRootTranslationScan)->Unit(benchmark::kMicrosecond);

void BM_HReference(benchmark::State& st) {
  if (!data().ok) return st.SkipWithError("no Bandai Namco data");
  const Data& d = data();
  const BodyState q = static_query();
  std::size_t c = 0, f = 0;
  for (auto _ : st) {
    benchmark::DoNotOptimize(approximate_energy(d.model, q.view(), d.clips[c].state(f), 0.5));
    if (++f == d.clips[c].frame_count) {
      f = 0;
      c = (c + 1) % d.clips.size();
    }
  }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations()));
}
BENCHMARK(BM_HReference);

void BM_HPartialOneArm(benchmark::State& st) {
  if (!data().ok) return st.SkipWithError("no Bandai Namco data");
  const Data& d = data();
  PartialPoseSpec spec;
  spec.joint_rotations = {
      {d.model.segments[7], Eigen::Quaterniond(Eigen::AngleAxisd(0.8, Eigen::Vector3d::UnitZ()))}};
  const PartialQuery q = prepare_partial_query(d.model, spec);
  BodyState scratch;
  std::size_t c = 0, f = 0;
  for (auto _ : st) {
    const std::size_t n = d.motions[c].joint_count();
    const FrameRef fr{d.clips[c].state(f), &d.motions[c].local_translations_m[f * n],
                      &d.motions[c].local_rotations[f * n]};
    benchmark::DoNotOptimize(partial_approximate_energy(d.model, q, fr, 0.5, scratch));
    if (++f == d.clips[c].frame_count) {
      f = 0;
      c = (c + 1) % d.clips.size();
    }
  }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations()));
  st.counters["affected_joints"] = static_cast<double>(q.affected_joints.size());
}
BENCHMARK(BM_HPartialOneArm);

void BM_NewtonEulerStep(benchmark::State& st) {
  if (!data().ok) return st.SkipWithError("no Bandai Namco data");
  const Data& d = data();
  NewtonEulerWorkspace ws;
  std::size_t c = 0, f = 0;
  for (auto _ : st) {
    const ClipDynamics& clip = d.clips[c];
    benchmark::DoNotOptimize(
        full_energy(d.model, clip.state(f), clip.state(f + 1), clip.frame_time_s, ws));
    if (++f + 1 >= clip.frame_count) {
      f = 0;
      c = (c + 1) % d.clips.size();
    }
  }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations()));
}
BENCHMARK(BM_NewtonEulerStep);

void BM_InverseDynamics(benchmark::State& st) {
  if (!data().ok) return st.SkipWithError("no Bandai Namco data");
  const Data& d = data();
  NewtonEulerData id;
  std::size_t c = 0, f = 0;
  for (auto _ : st) {
    inverse_dynamics(d.model, d.clips[c].state(f), id);
    benchmark::DoNotOptimize(id.residual_force_N.data());
    if (++f == d.clips[c].frame_count) {
      f = 0;
      c = (c + 1) % d.clips.size();
    }
  }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations()));
}
BENCHMARK(BM_InverseDynamics);

void BM_ClipStepEnergies(benchmark::State& st) {
  if (!data().ok) return st.SkipWithError("no Bandai Namco data");
  const Data& d = data();
  std::size_t steps = 0;
  for (auto _ : st)
    for (const ClipDynamics& c : d.clips) {
      const auto s = clip_step_energies(d.model, c);
      benchmark::DoNotOptimize(s.data());
      steps += s.size();
    }
  st.SetItemsProcessed(static_cast<std::int64_t>(steps));
}
BENCHMARK(BM_ClipStepEnergies)->Unit(benchmark::kMillisecond);

void BM_ClipDynamics(benchmark::State& st) {
  if (!data().ok) return st.SkipWithError("no Bandai Namco data");
  const Data& d = data();
  ClipDynamics out;
  for (auto _ : st)
    for (const ClipMotion& m : d.motions) {
      compute_clip_dynamics(d.model, m.frame_count, m.frame_time_s, m.world_positions_m.data(),
                            m.world_rotations.data(), out);
      benchmark::DoNotOptimize(out.com_velocities_mps.data());
    }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations()) *
                       static_cast<std::int64_t>(d.frames));
  st.counters["joints"] = static_cast<double>(d.model.joint_count());
}
BENCHMARK(BM_ClipDynamics)->Unit(benchmark::kMillisecond);

}  // namespace
