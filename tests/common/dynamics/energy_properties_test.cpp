// The energy model's properties (docs/energy.md, "Properties") on real clips
// from the data folder
// (Bandai Namco set 1 and CMU subject 131): g >= h >= 0 on random state pairs
// (frames, static queries, partial-query completions, sequence steps), zero for
// identical states, invariance, body sensitivity, units, the vectorised scan
// and the kd-tree bound. Skipped when the data is absent.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <random>

#include "mocap/common/body/body.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/energy.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/units.hpp"
#include "raw_clip_builder.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

// A clip prepared for a character.
struct Clip {
  std::string name;
  RawClip raw;
  ClipMotion motion;
  Skeleton skeleton;
  DynamicsModel model;
  ClipDynamics dyn;

  FrameRef frame(std::size_t f) const {
    const std::size_t n = motion.joint_count();
    return {dyn.state(f), &motion.local_translations_m[f * n], &motion.local_rotations[f * n]};
  }
};

Clip prepare(const RawClip& raw, double scale_m, const Character& ch, const std::string& name) {
  Clip c;
  c.name = name;
  c.raw = raw;
  c.motion = clip_motion_from_raw(raw, scale_m);
  c.skeleton = c.motion.skeleton;
  c.model = build_dynamics_model(c.skeleton, build_body(c.skeleton, ch));
  c.dyn = compute_clip_dynamics(c.model, c.motion);
  return c;
}

Clip load(const std::filesystem::path& path, const Character& ch = {}) {
  const RawClip raw = read_bvh_file(path);
  return prepare(raw, unit_scale_m(detect_unit(raw)), ch, path.filename().string());
}

std::filesystem::path bn1(const std::string& stem) {
  return test::data_dir() / "bandai-namco-1" / "data" / ("dataset-1_" + stem + ".bvh");
}

// Clips shared by the tests (loaded once).
const std::vector<Clip>& bn_clips() {
  static const std::vector<Clip> clips = [] {
    std::vector<Clip> v;
    for (const char* s : {"walk_normal_001", "run_normal_001", "bow_active_001", "kick_normal_001",
                          "byebye_normal_001", "dash_normal_001", "walk-back_normal_001"})
      v.push_back(load(bn1(s)));
    return v;
  }();
  return clips;
}
const Clip& cmu_clip() {
  static const Clip c = load(test::data_dir() / "cmu" / "131_01.bvh");
  return c;
}

// A state with storage copied from a view.
BodyState copy_state(const StateView& s) {
  BodyState o;
  o.resize(s.joint_count);
  for (std::size_t j = 0; j < s.joint_count; ++j) {
    o.joint_positions_m[j] = s.joint_positions_m[j];
    o.rotations[j] = s.rotations[j];
    o.coms_m[j] = s.coms_m[j];
    o.com_velocities_mps[j] = s.com_velocities_mps[j];
    o.com_accelerations_mps2[j] = s.com_accelerations_mps2[j];
    o.angular_velocities_radps[j] = s.angular_velocities_radps[j];
    o.angular_accelerations_radps2[j] = s.angular_accelerations_radps2[j];
  }
  return o;
}

// A random partial query on a clip's skeleton.
PartialPoseSpec random_partial(const Clip& c, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  PartialPoseSpec s;
  const int kind = static_cast<int>(rng() % 4);
  if (kind == 0 || kind == 3) s.root_position_m = {2.0 * u(rng), std::nullopt, 2.0 * u(rng)};
  if (kind == 1) s.root_position_m = {u(rng), 0.9 + 0.1 * u(rng), u(rng)};
  if (kind == 2 || kind == 3) s.root_heading_rad = 3.0 * u(rng);
  const int joints = static_cast<int>(rng() % 3);
  std::vector<int> used;
  for (int k = 0; k < joints; ++k) {
    const int j = c.model.segments[rng() % c.model.segments.size()];
    if (std::find(used.begin(), used.end(), j) != used.end()) continue;
    used.push_back(j);
    const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    s.joint_rotations.emplace_back(j, Eigen::Quaterniond(Eigen::AngleAxisd(1.5 * u(rng), axis)));
  }
  return s;
}

// ------------------------------------------------------------ 1. g >= h >= 0

TEST(EnergyProperties, FullAtLeastApproximateAtLeastZeroOnRandomRealPairs) {
  MOCAP_REQUIRE_DATA();
  const auto& clips = bn_clips();
  std::mt19937 rng(2024);
  NewtonEulerWorkspace ws;
  BodyState completed;
  const double times[] = {1.0 / 30.0, 0.1, 0.25, 0.5, 1.0};
  std::map<std::string, int> kinds;
  int pairs = 0;
  auto check = [&](const DynamicsModel& m, const StateView& a, const StateView& b, double t,
                   const char* kind) {
    const double h = approximate_energy(m, a, b, t);
    const double g = full_energy(m, a, b, t, ws);
    ASSERT_TRUE(std::isfinite(h) && std::isfinite(g)) << kind;
    ASSERT_GE(h, 0.0) << kind;
    ASSERT_GE(g, h) << kind << " h=" << h << " g=" << g;
    ++pairs;
    ++kinds[kind];
  };
  for (int i = 0; i < 2600; ++i) {
    const Clip& ca = clips[rng() % clips.size()];
    const Clip& cb = clips[rng() % clips.size()];
    const std::size_t fa = rng() % ca.dyn.frame_count, fb = rng() % cb.dyn.frame_count;
    const double t = times[rng() % 5];
    const StateView a = ca.dyn.state(fa), b = cb.dyn.state(fb);
    check(ca.model, a, b, t, "frame->frame");
    // Static query (hand-written pose) -> frame and frame -> static query.
    BodyState sa = copy_state(a);
    sa.set_rates_zero();
    check(ca.model, sa.view(), b, t, "static->frame");
    check(ca.model, b, sa.view(), t, "frame->static");
    // Partial query completed with the frame: Q_F -> F and F -> Q_F.
    const PartialQuery q = prepare_partial_query(cb.model, random_partial(cb, rng));
    complete_partial_query(cb.model, q, cb.frame(fb), completed);
    check(cb.model, completed.view(), b, t, "partial->frame");
    check(cb.model, b, completed.view(), t, "frame->partial");
  }
  // Steps inside a sequence (kinematics from the neighbours).
  for (int i = 0; i < 500; ++i) {
    const Clip& c = clips[rng() % clips.size()];
    const std::size_t f = rng() % (c.dyn.frame_count - 1);
    check(c.model, c.dyn.state(f), c.dyn.state(f + 1), c.dyn.frame_time_s, "sequence step");
  }
  // CMU (another skeleton, 120 fps).
  const Clip& cmu = cmu_clip();
  for (int i = 0; i < 500; ++i) {
    const std::size_t fa = rng() % cmu.dyn.frame_count, fb = rng() % cmu.dyn.frame_count;
    check(cmu.model, cmu.dyn.state(fa), cmu.dyn.state(fb), times[rng() % 5], "cmu frame->frame");
  }
  EXPECT_GE(pairs, 10000);
  for (const auto& [k, n] : kinds) std::printf("  %-18s %d pairs\n", k.c_str(), n);
}

// ------------------------------------------------------------ 2. zero for identical states

TEST(EnergyProperties, SameStateCostsNothing) {
  MOCAP_REQUIRE_DATA();
  NewtonEulerWorkspace ws;
  for (const Clip& c : bn_clips())
    for (std::size_t f = 0; f < c.dyn.frame_count; f += 3) {
      ASSERT_EQ(approximate_energy(c.model, c.dyn.state(f), c.dyn.state(f), 0.5), 0.0)
          << c.name << " " << f;
      FullEnergyTerms terms;
      ASSERT_GE(full_energy(c.model, c.dyn.state(f), c.dyn.state(f), 0.5, ws, &terms), 0.0);
      // g's own h part (kinetic energies from the inverse dynamics) is exactly 0 too.
      ASSERT_EQ(terms.h.total(), 0.0) << c.name << " " << f;
    }
  // A static, supported pose: the first frame of a bow, standing.
  const Clip& bow = bn_clips()[2];
  BodyState s = copy_state(bow.dyn.state(0));
  s.set_rates_zero();
  NewtonEulerData id;
  inverse_dynamics(bow.model, s.view(), id);
  EXPECT_GE(id.contact_count, 2u);
  EXPECT_LT(id.residual_force_N.norm(), 1e-9 * bow.model.total_mass_kg);
  EXPECT_LT(id.residual_torque_Nm.norm(), 1e-9 * bow.model.total_mass_kg);
  EXPECT_EQ(approximate_energy(bow.model, s.view(), s.view(), 0.5), 0.0);
  EXPECT_LT(full_energy(bow.model, s.view(), s.view(), 0.5, ws), 1e-12);
  // The same pose lifted 1 m is unsupported and pays for its residual.
  for (auto& x : s.joint_positions_m) x.y() += 1.0;
  for (auto& x : s.coms_m) x.y() += 1.0;
  EXPECT_GT(full_energy(bow.model, s.view(), s.view(), 0.5, ws), 100.0);
}

// ------------------------------------------------------------ 3. invariance

Clip transformed(const Clip& c, const Eigen::Quaterniond& rot, const Eigen::Vector3d& shift) {
  Clip o = c;
  for (std::size_t i = 0; i < o.motion.world_positions_m.size(); ++i) {
    o.motion.world_positions_m[i] = rot * c.motion.world_positions_m[i] + shift;
    o.motion.world_rotations[i] = rot * c.motion.world_rotations[i];
  }
  o.dyn = compute_clip_dynamics(o.model, o.motion);
  return o;
}

TEST(EnergyProperties, InvariantUnderHorizontalTranslationAndVerticalRotation) {
  MOCAP_REQUIRE_DATA();
  const Clip& a = bn_clips()[0];
  const Clip& b = bn_clips()[4];
  const Eigen::Quaterniond yaw(Eigen::AngleAxisd(2.1, Eigen::Vector3d::UnitY()));
  const Eigen::Vector3d shift(13.0, 0.0, -7.5);
  const Clip ta = transformed(a, yaw, shift), tb = transformed(b, yaw, shift);
  std::mt19937 rng(5);
  NewtonEulerWorkspace ws;
  for (int i = 0; i < 300; ++i) {
    const std::size_t fa = rng() % a.dyn.frame_count, fb = rng() % b.dyn.frame_count;
    const double t = i % 2 ? 0.5 : a.dyn.frame_time_s;
    const double h = approximate_energy(a.model, a.dyn.state(fa), b.dyn.state(fb), t);
    const double g = full_energy(a.model, a.dyn.state(fa), b.dyn.state(fb), t, ws);
    EXPECT_NEAR(approximate_energy(a.model, ta.dyn.state(fa), tb.dyn.state(fb), t), h,
                1e-9 * (1.0 + h));
    EXPECT_NEAR(full_energy(a.model, ta.dyn.state(fa), tb.dyn.state(fb), t, ws), g,
                1e-8 * (1.0 + g));
  }
  // Sequence steps of the whole clip.
  const auto steps = clip_step_energies(a.model, a.dyn),
             tsteps = clip_step_energies(a.model, ta.dyn);
  for (std::size_t i = 0; i < steps.size(); ++i)
    EXPECT_NEAR(tsteps[i], steps[i], 1e-8 * (1.0 + steps[i]));
}

// ------------------------------------------------------------ 4. body sensitivity

TEST(EnergyProperties, HeavierArmCostsMoreForArmMotionOnly) {
  MOCAP_REQUIRE_DATA();
  const Clip& wave = bn_clips()[4];  // byebye: waving
  Character heavy;
  const double k = 2.0;
  heavy.class_mass_scale[SegmentClass::upper_arm] = k;
  heavy.class_mass_scale[SegmentClass::forearm] = k;
  heavy.class_mass_scale[SegmentClass::hand] = k;
  const Body base_body = build_body(wave.skeleton, Character{});
  const Body heavy_body = build_body(wave.skeleton, heavy);
  auto is_arm = [&](std::size_t j) {
    const SegmentClass c = base_body.segments[j].cls;
    return c == SegmentClass::upper_arm || c == SegmentClass::forearm || c == SegmentClass::hand;
  };
  // Premise: the character file scaled exactly the arm segments.
  for (std::size_t j = 0; j < base_body.segments.size(); ++j)
    ASSERT_NEAR(heavy_body.segments[j].mass_kg,
                (is_arm(j) ? k : 1.0) * base_body.segments[j].mass_kg, 1e-12);
  const DynamicsModel hm = build_dynamics_model(wave.skeleton, heavy_body);
  const ClipDynamics hd = compute_clip_dynamics(hm, wave.motion);
  std::mt19937 rng(6);
  EnergyTerms tb, th;
  double arm_base = 0.0, arm_heavy = 0.0;
  for (int i = 0; i < 200; ++i) {
    const std::size_t fa = rng() % wave.dyn.frame_count, fb = rng() % wave.dyn.frame_count;
    approximate_energy(wave.model, wave.dyn.state(fa), wave.dyn.state(fb), 0.5, &tb);
    approximate_energy(hm, hd.state(fa), hd.state(fb), 0.5, &th);
    for (std::size_t j = 0; j < wave.model.joint_count(); ++j) {
      const double f = is_arm(j) ? k : 1.0;
      ASSERT_NEAR(th.segment_J[j], f * tb.segment_J[j], 1e-9 * (1.0 + th.segment_J[j])) << j;
      ASSERT_NEAR(th.joint_J[j], f * tb.joint_J[j], 1e-9 * (1.0 + th.joint_J[j])) << j;
      if (is_arm(j)) {
        arm_base += tb.segment_J[j] + tb.joint_J[j];
        arm_heavy += th.segment_J[j] + th.joint_J[j];
      }
    }
  }
  EXPECT_GT(arm_base, 0.0);
  EXPECT_NEAR(arm_heavy, k * arm_base, 1e-9 * arm_heavy);
  // g of the waving clip's own steps rises with the heavier arms.
  const auto gb = clip_step_energies(wave.model, wave.dyn), gh = clip_step_energies(hm, hd);
  EXPECT_GT(std::accumulate(gh.begin(), gh.end(), 0.0), std::accumulate(gb.begin(), gb.end(), 0.0));
}

// ------------------------------------------------------------ 5. units

TEST(EnergyProperties, CentimetreAndMetreFilesGiveTheSameEnergies) {
  MOCAP_REQUIRE_DATA();
  const Clip& cm = bn_clips()[0];
  ASSERT_EQ(detect_unit(cm.raw), LengthUnit::cm);
  const auto dir = test::temp_dir("energy-units");
  const auto path = dir / "walk_m.bvh";
  write_bvh_file(test::in_metres(cm.raw), path);
  const RawClip back = read_bvh_file(path);
  ASSERT_EQ(detect_unit(back), LengthUnit::m);
  const Clip m = prepare(back, 1.0, Character{}, "walk_m");
  std::mt19937 rng(7);
  NewtonEulerWorkspace ws;
  for (int i = 0; i < 200; ++i) {
    const std::size_t fa = rng() % cm.dyn.frame_count, fb = rng() % cm.dyn.frame_count;
    const double t = i % 2 ? 0.5 : cm.dyn.frame_time_s;
    const double h = approximate_energy(cm.model, cm.dyn.state(fa), cm.dyn.state(fb), t);
    const double g = full_energy(cm.model, cm.dyn.state(fa), cm.dyn.state(fb), t, ws);
    EXPECT_NEAR(approximate_energy(m.model, m.dyn.state(fa), m.dyn.state(fb), t), h,
                1e-6 * (1.0 + h));
    EXPECT_NEAR(full_energy(m.model, m.dyn.state(fa), m.dyn.state(fb), t, ws), g, 1e-6 * (1.0 + g));
  }
  EXPECT_NEAR(cm.model.total_mass_kg, m.model.total_mass_kg, 1e-9);
}

// ------------------------------------------------------------ SoA scan on real data

HScanTable table_of(const DynamicsModel& model, const std::vector<const Clip*>& clips) {
  std::size_t frames = 0;
  for (const Clip* c : clips) frames += c->dyn.frame_count;
  HScanTable t;
  init_h_scan_table(model, frames, t);
  std::size_t f = 0;
  for (const Clip* c : clips)
    for (std::size_t i = 0; i < c->dyn.frame_count; ++i)
      set_h_scan_frame(model, c->dyn.state(i), f++, t);
  return t;
}

TEST(EnergyProperties, VectorisedScanAgreesWithReference) {
  MOCAP_REQUIRE_DATA();
  const auto& clips = bn_clips();
  std::vector<const Clip*> db;
  std::vector<std::pair<const Clip*, std::size_t>> frames;
  for (std::size_t i = 1; i < clips.size(); ++i) {
    db.push_back(&clips[i]);
    for (std::size_t f = 0; f < clips[i].dyn.frame_count; ++f) frames.emplace_back(&clips[i], f);
  }
  const DynamicsModel& model = clips[0].model;
  const HScanTable table = table_of(model, db);
  std::vector<float> out(table.frame_count);
  std::mt19937 rng(8);
  for (int q = 0; q < 8; ++q) {
    BodyState s = copy_state(clips[0].dyn.state(rng() % clips[0].dyn.frame_count));
    if (q % 2 == 0) s.set_rates_zero();
    scan_approximate_energy(table, make_h_scan_query(model, s.view(), 0.5), 0, table.frame_count,
                            out.data());
    for (std::size_t f = 0; f < table.frame_count; f += 5) {
      const double ref =
          approximate_energy(model, s.view(), frames[f].first->dyn.state(frames[f].second), 0.5);
      ASSERT_NEAR(double(out[f]), ref, 1e-4 * ref + 1e-4) << q << " " << f;
    }
  }
}

// The four-lane paths (common/src/dynamics/lanes.hpp) against their scalar references,
// on real clips and on steps large enough to leave the series (rotation_vector
// through atan2): the clip kernel's rates against sequence_state, full_energy's
// rotation steps against rotation_step, its h part against approximate_energy.
TEST(EnergyProperties, LaneWisePathsAgreeWithScalarReferences) {
  MOCAP_REQUIRE_DATA();
  std::mt19937 rng(21);
  for (const Clip& c : bn_clips()) {
    const std::size_t n = c.motion.joint_count();
    for (std::size_t f = 1; f + 1 < c.dyn.frame_count; f += 7) {
      const PoseView prev{&c.motion.world_positions_m[(f - 1) * n],
                          &c.motion.world_rotations[(f - 1) * n]};
      const PoseView cur{&c.motion.world_positions_m[f * n], &c.motion.world_rotations[f * n]};
      const PoseView next{&c.motion.world_positions_m[(f + 1) * n],
                          &c.motion.world_rotations[(f + 1) * n]};
      BodyState s;
      sequence_state(c.model, &prev, cur, &next, c.motion.frame_time_s, s);
      const StateView d = c.dyn.state(f);
      for (std::size_t j = 0; j < n; ++j) {
        const double v = 1.0 + s.angular_velocities_radps[j].norm();
        ASSERT_LT((s.com_velocities_mps[j] - d.com_velocities_mps[j]).norm(), 1e-9) << c.name;
        ASSERT_LT((s.angular_velocities_radps[j] - d.angular_velocities_radps[j]).norm(), 1e-12 * v)
            << c.name << " frame " << f << " joint " << j;
        ASSERT_LT((s.angular_accelerations_radps2[j] - d.angular_accelerations_radps2[j]).norm(),
                  1e-9 * (1.0 + s.angular_accelerations_radps2[j].norm()))
            << c.name;
      }
    }
    // Steps of every size: random frame pairs (most leave the series), and equal states.
    NewtonEulerWorkspace ws;
    FullEnergyTerms terms;
    for (int k = 0; k < 40; ++k) {
      const StateView a = c.dyn.state(rng() % c.dyn.frame_count);
      const StateView b = k % 8 == 0 ? a : c.dyn.state(rng() % c.dyn.frame_count);
      full_energy(c.model, a, b, 0.2, ws, &terms);
      for (std::size_t j = 0; j < n; ++j) {
        const Eigen::Vector3d ref = rotation_step(a.rotations[j], b.rotations[j]);
        if (k % 8 == 0) {
          ASSERT_EQ(ws.rotation_steps[j], Eigen::Vector3d::Zero());
        }
        ASSERT_LT((ws.rotation_steps[j] - ref).norm(), 1e-13 * (1.0 + ref.norm())) << c.name;
      }
      const double h = approximate_energy(c.model, a, b, 0.2);
      ASSERT_NEAR(terms.h.total(), h, 1e-12 * (1.0 + h)) << c.name;
    }
  }
}

// ------------------------------------------------------------ 7. kd-tree bound

TEST(EnergyProperties, KdFeatureBoundNeverPrunesATopFrame) {
  MOCAP_REQUIRE_DATA();
  const auto& clips = bn_clips();
  const DynamicsModel& model = clips[0].model;
  const double t = 0.5;
  const std::size_t dim = kd_feature_dimension(model);
  // Database: every frame of clips 1.. as float features (as the index stores them).
  std::vector<float> feats;
  std::vector<std::pair<const Clip*, std::size_t>> frames;
  for (std::size_t i = 1; i < clips.size(); ++i)
    for (std::size_t f = 0; f < clips[i].dyn.frame_count; ++f) {
      frames.emplace_back(&clips[i], f);
      feats.resize(feats.size() + dim);
      kd_feature(model, clips[i].dyn.state(f), t, &feats[feats.size() - dim]);
    }
  std::mt19937 rng(9);
  std::vector<float> qf(dim);
  const std::size_t r = 5;
  int checked = 0;
  for (int q = 0; q < 100; ++q) {
    // Static query: a frame of the walk clip, made static.
    BodyState s = copy_state(clips[0].dyn.state(rng() % clips[0].dyn.frame_count));
    s.set_rates_zero();
    kd_feature(model, s.view(), t, qf.data());
    std::vector<double> h(frames.size()), d2(frames.size());
    for (std::size_t i = 0; i < frames.size(); ++i) {
      h[i] = approximate_energy(model, s.view(), frames[i].first->dyn.state(frames[i].second), t);
      double d = 0.0;
      for (std::size_t k = 0; k < dim; ++k) {
        const double e = double(qf[k]) - double(feats[i * dim + k]);
        d += e * e;
      }
      d2[i] = d;
      // The bound itself (float features: relative slack 1e-5).
      ASSERT_LE(d2[i], h[i] * (1.0 + 1e-5) + 1e-6) << q << " " << i;
      ++checked;
    }
    // Brute-force top r vs the pruned search: visit frames by increasing d2,
    // stop when d2 exceeds the current r-th best h.
    std::vector<std::size_t> order(frames.size());
    std::iota(order.begin(), order.end(), 0);
    std::vector<std::size_t> brute = order;
    std::partial_sort(brute.begin(), brute.begin() + static_cast<std::ptrdiff_t>(r), brute.end(),
                      [&](std::size_t a, std::size_t b) { return h[a] < h[b]; });
    brute.resize(r);
    std::sort(order.begin(), order.end(),
              [&](std::size_t a, std::size_t b) { return d2[a] < d2[b]; });
    std::vector<std::size_t> best;
    std::size_t visited = 0;
    for (std::size_t i : order) {
      if (best.size() == r && d2[i] > h[best.back()] * (1.0 + 1e-5) + 1e-6) break;
      ++visited;
      best.push_back(i);
      std::sort(best.begin(), best.end(),
                [&](std::size_t a, std::size_t b) { return h[a] < h[b]; });
      if (best.size() > r) best.pop_back();
    }
    for (std::size_t k = 0; k < r; ++k) EXPECT_DOUBLE_EQ(h[best[k]], h[brute[k]]) << q << " " << k;
    EXPECT_LT(visited, frames.size());  // the bound prunes something
  }
  EXPECT_GT(checked, 50000);
}

// ------------------------------------------------------------ clip per-step energies

TEST(EnergyProperties, ClipStepEnergiesAndPrefixSums) {
  MOCAP_REQUIRE_DATA();
  for (const Clip& c : bn_clips()) {
    const auto steps = clip_step_energies(c.model, c.dyn);
    ASSERT_EQ(steps.size(), c.dyn.frame_count - 1);
    const auto p = energy_prefix_sums(steps);
    for (std::size_t i = 0; i < steps.size(); ++i) {
      ASSERT_GE(steps[i], approximate_energy(c.model, c.dyn.state(i), c.dyn.state(i + 1),
                                             c.dyn.frame_time_s));
      ASSERT_NEAR(p[i + 1] - p[i], steps[i], 1e-9 * (1.0 + steps[i]));
    }
    // Walking costs more per second than bowing.
    if (c.name.find("bow") != std::string::npos) {
      const auto walk = clip_step_energies(bn_clips()[0].model, bn_clips()[0].dyn);
      const double walk_rate =
          std::accumulate(walk.begin(), walk.end(), 0.0) / static_cast<double>(walk.size());
      EXPECT_LT(p.back() / static_cast<double>(steps.size()), walk_rate);
    }
  }
}

}  // namespace
}  // namespace mocap
