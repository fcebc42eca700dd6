// The search engine (search.hpp; algorithm and proofs: docs/search.md).
#include "mocap/search.hpp"

#include <fmt/format.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <numbers>
#include <numeric>
#include <set>
#include <sstream>

#include "flann_knn.hpp"
#include "mocap/body.hpp"
#include "mocap/energy.hpp"
#include "mocap/error.hpp"
#include "resolve.hpp"

namespace mocap {

using search_detail::BvhCache;
using search_detail::FrameKind;
using search_detail::ResolvedFrame;

const char* search_mode_name(SearchMode m) {
  switch (m) {
    case SearchMode::exact: return "exact";
    case SearchMode::approx: return "approx";
    case SearchMode::brute: return "brute";
  }
  return "?";
}

std::optional<SearchMode> parse_search_mode(const std::string& s) {
  if (s == "exact") return SearchMode::exact;
  if (s == "approx") return SearchMode::approx;
  if (s == "brute") return SearchMode::brute;
  return std::nullopt;
}

// ---------------------------------------------------------------------------
// Running minimum

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

// (score, e, s) lexicographic: true when the candidate beats the incumbent.
bool better(double score, std::size_t e, std::size_t s, const ClipBest& best, bool have) {
  if (!have) return true;
  if (score != best.score) return score < best.score;
  if (e != best.e) return e < best.e;
  return s < best.s;
}
}  // namespace

bool best_partial_motion(const double* a, const double* b, const double* prefix, std::size_t k,
                         double lambda, ClipBest& out) {
  bool have = false;
  double run_min = kInf;  // min_{s<e} (a(s) - lambda P[s])
  std::size_t run_s = 0;
  for (std::size_t e = 1; e < k; ++e) {
    const std::size_t s = e - 1;
    if (std::isfinite(a[s])) {
      const double v = a[s] - lambda * prefix[s];
      if (v < run_min) {  // strict: the earliest s wins ties
        run_min = v;
        run_s = s;
      }
    }
    if (!std::isfinite(b[e]) || !std::isfinite(run_min)) continue;
    const double score = (b[e] + lambda * prefix[e]) + run_min;
    if (score < out.score || !have) {  // strict: the earliest e wins ties
      out = {score, run_s, e};
      have = true;
    }
  }
  return have;
}

bool best_partial_motion_quadratic(const double* a, const double* b, const double* prefix,
                                   std::size_t k, double lambda, ClipBest& out) {
  bool have = false;
  for (std::size_t e = 1; e < k; ++e) {
    if (!std::isfinite(b[e])) continue;
    for (std::size_t s = 0; s < e; ++s) {
      if (!std::isfinite(a[s])) continue;
      const double score = (b[e] + lambda * prefix[e]) + (a[s] - lambda * prefix[s]);
      if (better(score, e, s, out, have)) {
        out = {score, s, e};
        have = true;
      }
    }
  }
  return have;
}

// ---------------------------------------------------------------------------
// Engine tables

namespace {

struct ClipInfo {
  std::size_t clip = 0;         // global clip index
  std::size_t frame_start = 0;  // skeleton row of frame 0
  std::size_t frame_count = 0;
  std::size_t block_start = 0;  // blocks16 row of block 0
  std::size_t row = 0;          // clip_bounds row
};

struct SkelData {
  std::uint32_t k = 0;
  const IndexSkeleton* sk = nullptr;
  DynamicsModel model;
  HScanTable table;
  std::size_t segments = 0;
  std::vector<double> masses;  // per segment
  double segment_mass = 0.0;
  std::vector<double> lambda_min;     // per segment: smallest principal moment (kg m^2)
  std::vector<int> segment_of_joint;  // joint -> segment index, -1 if massless
  std::vector<ClipInfo> clips;             // by row
  std::vector<std::uint32_t> frame_row;    // skeleton frame -> clip row
  // Bounds in metres: [row][S][3] COM boxes, [row][3] root boxes.
  std::vector<float> clip_com_min, clip_com_max, clip_root_min, clip_root_max;
  std::vector<float> block_com_min, block_com_max, block_root_min, block_root_max;
  const float* kd = nullptr;  // [N][S*3]
  mutable std::once_flag flann_once;
  mutable std::unique_ptr<search_detail::KnnIndex> flann;
};

// kd bounds (sqrt(m/2)/T_index c) -> COM bounds in metres.
void kd_to_com(const IndexArray& kd, const std::vector<double>& masses, double t_index,
               std::vector<float>& out) {
  const std::size_t s = masses.size();
  out.resize(kd.f32.size());
  for (std::size_t r = 0; r < kd.rows; ++r)
    for (std::size_t b = 0; b < s; ++b) {
      const double inv = t_index / std::sqrt(masses[b] / 2.0);
      for (std::size_t a = 0; a < 3; ++a) {
        const std::size_t i = (r * s + b) * 3 + a;
        out[i] = static_cast<float>(static_cast<double>(kd.f32[i]) * inv);
      }
    }
}

// Lower bound of h(Q -> F) over frames F whose segment COMs lie in the boxes
// (full queries) or whose root lies in the box (root-only): docs/search.md.
double box_lower_bound(const ResolvedFrame& q, const SkelData& sd, double t, const float* com_min,
                       const float* com_max, const float* root_min, const float* root_max) {
  const double g = sd.model.params.gravity_mps2;
  if (q.kind == FrameKind::full) {
    double lb = 0.0;
    for (std::size_t b = 0; b < sd.segments; ++b) {
      const Eigen::Vector3d& c = q.state.coms_m[static_cast<std::size_t>(sd.model.segments[b])];
      double d2 = 0.0, dy = 0.0;
      for (int a = 0; a < 3; ++a) {
        const double lo = com_min[b * 3 + static_cast<std::size_t>(a)], hi = com_max[b * 3 + static_cast<std::size_t>(a)];
        const double d = c[a] < lo ? lo - c[a] : (c[a] > hi ? c[a] - hi : 0.0);
        d2 += d * d;
        if (a == 1) dy = d;
      }
      const double m = sd.masses[b];
      lb += m * g * dy + std::max(0.0, m * d2 / (2.0 * t * t) - q.segment_ke_J[b]);
    }
    return lb;
  }
  if (q.kind == FrameKind::root_only) {
    double d2 = 0.0, dy = 0.0;
    for (int a = 0; a < 3; ++a) {
      if (!q.given[static_cast<std::size_t>(a)]) continue;
      const double lo = root_min[a], hi = root_max[a], p = q.root_m[a];
      const double d = p < lo ? lo - p : (p > hi ? p - hi : 0.0);
      d2 += d * d;
      if (a == 1) dy = d;
    }
    return sd.segment_mass * (g * dy + d2 / (2.0 * t * t));
  }
  return 0.0;
}

// A bound computed in float/double from float32 data is compared with scores
// computed by the float32 scan: the slack covers both roundings.
double safe(double lb) { return lb * (1.0 - 1e-4) - 1e-3; }

}  // namespace

struct SearchEngine::Impl {
  const Index* index = nullptr;
  double t_index = 0.5;
  std::vector<std::unique_ptr<SkelData>> skels;
  int content_key = -1, style_key = -1;
  mutable BvhCache bvh_cache;
  std::optional<Character> character;
};

SearchEngine::SearchEngine(const Index& index) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.index = &index;
  m.t_index = index.info().transition_time_s;
  for (std::size_t i = 0; i < index.label_keys().size(); ++i) {
    if (index.label_keys()[i] == "content") m.content_key = static_cast<int>(i);
    if (index.label_keys()[i] == "style") m.style_key = static_cast<int>(i);
  }
  try {
    m.character = parse_character_json(index.info().character_json, index.path().string());
  } catch (const InputError&) {
    m.character.reset();
  }
  const auto& clips = index.clips();
  for (std::uint32_t k = 0; k < index.skeletons().size(); ++k) {
    auto sd = std::make_unique<SkelData>();
    sd->k = k;
    sd->sk = &index.skeletons()[k];
    sd->model = index.dynamics_model(k);
    sd->segments = sd->model.segments.size();
    sd->segment_of_joint.assign(sd->model.joint_count(), -1);
    for (int b : sd->model.segments) {
      const auto j = static_cast<std::size_t>(b);
      sd->masses.push_back(sd->model.masses_kg[j]);
      sd->segment_mass += sd->masses.back();
      // Smallest eigenvalue of the (symmetric) local inertia: w^T R I R^T w >= lambda_min |w|^2.
      const Eigen::Vector3d d = sd->model.principal_moments_kgm2[j];
      sd->lambda_min.push_back(std::max(0.0, std::min({d[0], d[1], d[2]})));
      sd->segment_of_joint[j] = static_cast<int>(sd->masses.size() - 1);
    }
    const std::size_t n = sd->sk->frame_count, s = sd->segments;
    // h_scan [N][S][9] (one row per frame) -> field-major HScanTable.
    const IndexArray& hs = index.array(k, "frames", "h_scan");
    init_h_scan_table(sd->model, n, sd->table);
    const std::size_t stride = sd->table.stride;
    for (std::size_t f = 0; f < n; ++f) {
      const float* row = hs.f32.data() + f * s * 9;
      for (std::size_t b = 0; b < s; ++b)
        for (std::size_t q = 0; q < 9; ++q) sd->table.values[(b * 9 + q) * stride + f] = row[b * 9 + q];
    }
    const IndexArray& rp = index.array(k, "frames", "root_position_m");
    for (std::size_t f = 0; f < n; ++f)
      for (std::size_t a = 0; a < 3; ++a) sd->table.root_positions[a * stride + f] = rp.f32[f * 3 + a];
    sd->kd = index.array(k, "frames", "kd_features").f32.data();
    for (std::size_t row = 0; row < sd->sk->clips.size(); ++row) {
      const IndexClip& c = clips[sd->sk->clips[row]];
      sd->clips.push_back({sd->sk->clips[row], c.frame_start, c.frame_count, c.block16_start, c.row});
    }
    sd->frame_row.assign(n, 0);
    for (std::size_t row = 0; row < sd->clips.size(); ++row)
      for (std::size_t f = 0; f < sd->clips[row].frame_count; ++f)
        sd->frame_row[sd->clips[row].frame_start + f] = static_cast<std::uint32_t>(row);
    kd_to_com(index.array(k, "clip_bounds", "kd_min"), sd->masses, m.t_index, sd->clip_com_min);
    kd_to_com(index.array(k, "clip_bounds", "kd_max"), sd->masses, m.t_index, sd->clip_com_max);
    kd_to_com(index.array(k, "blocks16", "kd_min"), sd->masses, m.t_index, sd->block_com_min);
    kd_to_com(index.array(k, "blocks16", "kd_max"), sd->masses, m.t_index, sd->block_com_max);
    sd->clip_root_min = index.array(k, "clip_bounds", "root_min_m").f32;
    sd->clip_root_max = index.array(k, "clip_bounds", "root_max_m").f32;
    sd->block_root_min = index.array(k, "blocks16", "root_min_m").f32;
    sd->block_root_max = index.array(k, "blocks16", "root_max_m").f32;
    m.skels.push_back(std::move(sd));
  }
}

SearchEngine::SearchEngine(SearchEngine&&) noexcept = default;
SearchEngine::~SearchEngine() = default;
const Index& SearchEngine::index() const { return *impl_->index; }

// ---------------------------------------------------------------------------
// Evaluation

namespace {

// Per-thread scratch.
struct Scratch {
  std::vector<float> fbuf;
  std::vector<double> a, b, la, lb;
  std::vector<std::uint8_t> skip_a, skip_b;
  std::vector<Eigen::Quaterniond> mq, mf;  // partial bound: composite rotations
  // Database frames converted for partial_approximate_energy.
  std::vector<Eigen::Vector3d> pos, com, vel, angvel, zero, ltrans;
  std::vector<Eigen::Quaterniond> rot, lrot;
  BodyState state;
  HScanQuery shifted_scan;
  HScanRootQuery shifted_root;
  PartialQuery shifted_partial;
};

struct FrameArrays {
  const float *pos, *rot, *com, *vel, *angvel, *lrot;
};

FrameArrays frame_arrays(const Index& index, std::uint32_t k) {
  return {index.array(k, "frames", "joint_positions_m").f32.data(),
          index.array(k, "frames", "world_rotations").f32.data(),
          index.array(k, "frames", "segment_com_m").f32.data(),
          index.array(k, "frames", "segment_com_velocity_mps").f32.data(),
          index.array(k, "frames", "segment_angular_velocity_radps").f32.data(),
          index.array(k, "frames", "local_rotations").f32.data()};
}

// Converts skeleton frame g into scratch (double) and returns its FrameRef.
// Only the joints in `need` are converted (all when it is empty); the local
// translations only for `local` (all when `need` is empty). The caller passes
// the joints partial_approximate_energy reads for its query
// (partial_needed_joints); the other entries are never read.
FrameRef frame_ref(const SkelData& sd, const FrameArrays& fa, std::size_t g, Scratch& sc,
                   const std::vector<int>& need, const std::vector<int>& local) {
  const std::size_t nj = sd.model.joint_count();
  if (sc.pos.size() != nj) {
    sc.pos.assign(nj, Eigen::Vector3d::Zero());
    sc.com.assign(nj, Eigen::Vector3d::Zero());
    sc.vel.assign(nj, Eigen::Vector3d::Zero());
    sc.angvel.assign(nj, Eigen::Vector3d::Zero());
    sc.zero.assign(nj, Eigen::Vector3d::Zero());
    sc.ltrans.assign(nj, Eigen::Vector3d::Zero());
    sc.rot.assign(nj, Eigen::Quaterniond::Identity());
    sc.lrot.assign(nj, Eigen::Quaterniond::Identity());
  }
  auto v3 = [](const float* p) { return Eigen::Vector3d(p[0], p[1], p[2]); };
  auto q4 = [](const float* p) { return Eigen::Quaterniond(p[0], p[1], p[2], p[3]).normalized(); };
  auto convert = [&](std::size_t j) {
    const std::size_t i = g * nj + j;
    sc.pos[j] = v3(fa.pos + i * 3);
    sc.com[j] = v3(fa.com + i * 3);
    sc.vel[j] = v3(fa.vel + i * 3);
    sc.angvel[j] = v3(fa.angvel + i * 3);
    sc.rot[j] = q4(fa.rot + i * 4);
    sc.lrot[j] = q4(fa.lrot + i * 4);
  };
  auto local_translation = [&](std::size_t j) {
    const int p = sd.model.parents[j];
    sc.ltrans[j] = p < 0 ? sc.pos[j]
                         : Eigen::Vector3d(sc.rot[static_cast<std::size_t>(p)].conjugate() *
                                           (sc.pos[j] - sc.pos[static_cast<std::size_t>(p)]));
  };
  if (need.empty()) {
    for (std::size_t j = 0; j < nj; ++j) convert(j);
    for (std::size_t j = 0; j < nj; ++j) local_translation(j);
  } else {
    for (int j : need) convert(static_cast<std::size_t>(j));
    for (int j : local) local_translation(static_cast<std::size_t>(j));
  }
  FrameRef r;
  r.state.joint_count = nj;
  r.state.joint_positions_m = sc.pos.data();
  r.state.rotations = sc.rot.data();
  r.state.coms_m = sc.com.data();
  r.state.com_velocities_mps = sc.vel.data();
  r.state.com_accelerations_mps2 = sc.zero.data();
  r.state.angular_velocities_radps = sc.angvel.data();
  r.state.angular_accelerations_radps2 = sc.zero.data();
  r.local_translations_m = sc.ltrans.data();
  r.local_rotations = sc.lrot.data();
  return r;
}

// h(Q -> F) for skeleton frames [g0, g1) into out. With `shift` (relative
// mode) the query's given x/z root components are placed at shift (world).
void evaluate(const ResolvedFrame& q, const SkelData& sd, const Index& index, double t,
              std::size_t g0, std::size_t g1, double* out, Scratch& sc,
              const std::optional<Eigen::Vector2d>& xz = std::nullopt,
              const std::uint8_t* skip = nullptr) {
  const std::size_t n = g1 - g0;
  if (n == 0) return;
  if (q.kind == FrameKind::full || q.kind == FrameKind::root_only) {
    sc.fbuf.resize(n);
    if (q.kind == FrameKind::full) {
      const HScanQuery* sq = &q.scan;
      if (xz) {
        sc.shifted_scan = q.scan;
        const double dx = (*xz)[0] - q.root_m[0], dz = (*xz)[1] - q.root_m[2];
        for (std::size_t b = 0; b < sc.shifted_scan.segment_count; ++b) {
          sc.shifted_scan.constants[b * HScanQuery::kConstants + 0] = static_cast<float>(q.state.coms_m[static_cast<std::size_t>(sd.model.segments[b])][0] + dx);
          sc.shifted_scan.constants[b * HScanQuery::kConstants + 2] = static_cast<float>(q.state.coms_m[static_cast<std::size_t>(sd.model.segments[b])][2] + dz);
        }
        sq = &sc.shifted_scan;
      }
      scan_approximate_energy(sd.table, *sq, g0, g1, sc.fbuf.data());
    } else {
      const HScanRootQuery* rq = &q.root_scan;
      if (xz) {
        sc.shifted_root = q.root_scan;
        if (q.given[0]) sc.shifted_root.position[0] = static_cast<float>((*xz)[0]);
        if (q.given[2]) sc.shifted_root.position[2] = static_cast<float>((*xz)[1]);
        rq = &sc.shifted_root;
      }
      scan_root_translation_energy(sd.table, *rq, g0, g1, sc.fbuf.data());
    }
    for (std::size_t i = 0; i < n; ++i) out[i] = sc.fbuf[i];
    return;
  }
  const PartialQuery* pq = &q.partial;
  if (xz && (q.given[0] || q.given[2])) {
    sc.shifted_partial = q.partial;
    if (q.given[0]) sc.shifted_partial.spec.root_position_m[0] = (*xz)[0];
    if (q.given[2]) sc.shifted_partial.spec.root_position_m[2] = (*xz)[1];
    pq = &sc.shifted_partial;
  }
  const FrameArrays fa = frame_arrays(index, sd.k);
  for (std::size_t i = 0; i < n; ++i) {
    if (skip != nullptr && skip[i]) continue;
    const FrameRef r = frame_ref(sd, fa, g0 + i, sc, q.need_joints, q.local_joints);
    out[i] = partial_approximate_energy(sd.model, *pq, r, t, sc.state);
  }
}

// ---------------------------------------------------------------------------
// Per-frame lower bound of h(Q_F -> F) for partial query frames (heading or
// joint rotations); docs/search.md "Partial queries" proves it.

struct PartialBoundPlan {
  bool whole = false;                // root position / heading given: every segment is static in Q_F
  std::vector<std::size_t> segs;     // affected segments (model.segments index)
  std::vector<double> rot_coef;      // per listed segment: 1/2 lambda_min / T^2 (slightly reduced)
  std::vector<std::uint8_t> turns;   // per listed segment: rotated by the heading turn
  std::vector<int> sub_slot;         // per listed segment: slot in sub_joints whose angle applies, -1
  bool heading = false;
  double psi_q = 0.0;
  // Joint-rotation subtrees (not whole-body): composite rotations per slot.
  std::vector<int> sub_joints, sub_parent_slot;
  std::vector<const Eigen::Quaterniond*> sub_given;  // the query's local rotation, null if F's
  // Whole-body COM term (no joint rotations): root position components.
  bool com_term = false;
  std::array<bool, 3> given{false, false, false};
  Eigen::Vector3d root_q = Eigen::Vector3d::Zero();
  double mass = 0.0, gravity = 0.0, half_inv_t2 = 0.0;
};

PartialBoundPlan make_partial_bound_plan(const ResolvedFrame& q, const SkelData& sd, double t) {
  PartialBoundPlan p;
  const PartialQuery& pq = q.partial;
  const DynamicsModel& model = sd.model;
  const std::size_t nj = model.joint_count();
  const auto root = static_cast<std::size_t>(model.root());
  p.whole = pq.moves_whole_body;
  p.half_inv_t2 = 0.5 / (t * t);
  p.mass = sd.segment_mass;
  p.gravity = model.params.gravity_mps2;
  p.heading = pq.spec.root_heading_rad.has_value() && pq.in_subtree[root] == 0;
  if (p.heading) p.psi_q = *pq.spec.root_heading_rad;
  std::vector<int> slot(nj, -1);
  if (!p.whole) {
    for (int jj : pq.subtree_joints) {
      const auto j = static_cast<std::size_t>(jj);
      slot[j] = static_cast<int>(p.sub_joints.size());
      p.sub_joints.push_back(jj);
      const int par = model.parents[j];
      p.sub_parent_slot.push_back(par >= 0 ? slot[static_cast<std::size_t>(par)] : -1);
      const int gi = pq.given_rotation[j];
      p.sub_given.push_back(gi >= 0 ? &pq.spec.joint_rotations[static_cast<std::size_t>(gi)].second : nullptr);
    }
  }
  for (std::size_t s = 0; s < sd.segments; ++s) {
    const auto j = static_cast<std::size_t>(model.segments[s]);
    if (!pq.affected[j]) continue;
    p.segs.push_back(s);
    // lambda_min from an eigen-solver: shave a relative 1e-6 off for its rounding.
    p.rot_coef.push_back(sd.lambda_min[s] * (1.0 - 1e-6) * p.half_inv_t2);
    p.turns.push_back(p.whole && p.heading && pq.in_subtree[j] == 0);
    p.sub_slot.push_back(p.whole ? -1 : slot[j]);
  }
  p.com_term = p.whole && pq.subtree_joints.empty();
  for (std::size_t a = 0; a < 3; ++a) {
    p.given[a] = pq.spec.root_position_m[a].has_value();
    if (p.given[a]) p.root_q[static_cast<Eigen::Index>(a)] = *pq.spec.root_position_m[a];
  }
  return p;
}

// A lower bound of the rotation angle (in [0, pi]) between the rotations of
// two non-zero quaternions: with d = |<x, y>| / (|x| |y|) = cos(theta / 2),
// cos t >= 1 - t^2 / 2 gives theta >= 2 sqrt(2 (1 - d)) (no acos per frame).
double quat_angle_lower(const Eigen::Quaterniond& x, const Eigen::Quaterniond& y) {
  const double d = std::abs(x.coeffs().dot(y.coeffs())) / std::sqrt(x.coeffs().squaredNorm() * y.coeffs().squaredNorm());
  return 2.0 * std::sqrt(2.0 * std::max(0.0, 1.0 - d));
}

// Lower bound of h(Q_F -> F) for skeleton frames [g0, g1) into out.
void partial_frame_bounds(const PartialBoundPlan& p, const SkelData& sd, const FrameArrays& fa,
                          std::size_t g0, std::size_t g1, double* out, Scratch& sc) {
  constexpr double kAngleSlack = 1e-4;  // rad: float32 storage and FK rounding of the angles
  const HScanTable& tb = sd.table;
  const std::size_t nj = sd.model.joint_count();
  const auto root = static_cast<std::size_t>(sd.model.root());
  sc.mq.resize(p.sub_joints.size());
  sc.mf.resize(p.sub_joints.size());
  for (std::size_t g = g0; g < g1; ++g) {
    for (std::size_t t = 0; t < p.sub_joints.size(); ++t) {
      const float* l = fa.lrot + (g * nj + static_cast<std::size_t>(p.sub_joints[t])) * 4;
      // Not normalised: quat_angle_lower divides by the norms (which multiply).
      const Eigen::Quaterniond lf(static_cast<double>(l[0]), static_cast<double>(l[1]), static_cast<double>(l[2]),
                                  static_cast<double>(l[3]));
      const Eigen::Quaterniond& lq = p.sub_given[t] ? *p.sub_given[t] : lf;
      const int ps = p.sub_parent_slot[t];
      if (ps < 0) {
        sc.mq[t] = lq;
        sc.mf[t] = lf;
      } else {
        sc.mq[t] = sc.mq[static_cast<std::size_t>(ps)] * lq;
        sc.mf[t] = sc.mf[static_cast<std::size_t>(ps)] * lf;
      }
    }
    double turn = 0.0;
    if (p.heading) {
      const float* r = fa.rot + (g * nj + root) * 4;
      const Eigen::Quaterniond rr = Eigen::Quaterniond(r[0], r[1], r[2], r[3]).normalized();
      turn = std::fmod(std::abs(p.psi_q - heading_rad(rr)), 2.0 * std::numbers::pi);
      if (turn > std::numbers::pi) turn = 2.0 * std::numbers::pi - turn;
    }
    double kt = 0.0, rot = 0.0;
    for (std::size_t i = 0; i < p.segs.size(); ++i) {
      const std::size_t s = p.segs[i];
      kt += static_cast<double>(tb.field(s, 3)[g]);
      const double kr = tb.field(s, 8)[g];
      double theta = 0.0;
      if (p.turns[i]) theta = turn;
      else if (p.sub_slot[i] >= 0) {
        const auto t = static_cast<std::size_t>(p.sub_slot[i]);
        theta = quat_angle_lower(sc.mq[t], sc.mf[t]);
      }
      theta = std::max(0.0, theta - kAngleSlack);
      const double ku = p.rot_coef[i] * theta * theta;
      rot += std::max(kr, 2.0 * ku - kr);
    }
    double trans = kt;
    if (p.com_term) {
      // Whole-body COM c (segments): Q_F is F turned about the vertical
      // through the root, then shifted on the given axes.
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (std::size_t s = 0; s < sd.segments; ++s)
        for (std::size_t a = 0; a < 3; ++a) c[static_cast<Eigen::Index>(a)] += sd.masses[s] * static_cast<double>(tb.field(s, a)[g]);
      c /= p.mass;
      const Eigen::Vector3d root_f(tb.root_positions[g], tb.root_positions[tb.stride + g],
                                   tb.root_positions[2 * tb.stride + g]);
      Eigen::Vector3d v = c - root_f;
      if (p.heading) {
        const float* r = fa.rot + (g * nj + root) * 4;
        const Eigen::Quaterniond rr = Eigen::Quaterniond(r[0], r[1], r[2], r[3]).normalized();
        v = Eigen::AngleAxisd(p.psi_q - heading_rad(rr), Eigen::Vector3d::UnitY()) * v;
      }
      Eigen::Vector3d cq = root_f + v;
      for (std::size_t a = 0; a < 3; ++a)
        if (p.given[a]) cq[static_cast<Eigen::Index>(a)] += p.root_q[static_cast<Eigen::Index>(a)] - root_f[static_cast<Eigen::Index>(a)];
      const Eigen::Vector3d d = cq - c;
      trans = std::max(kt, p.mass * d.squaredNorm() * p.half_inv_t2) + p.mass * p.gravity * std::abs(d.y());
    }
    out[g - g0] = trans + rot;
  }
}

// The joints partial_approximate_energy reads of a database frame (frame_ref).
void set_needed_joints(ResolvedFrame& q, const DynamicsModel& model) {
  q.need_joints.clear();
  q.local_joints.clear();
  if (q.kind != FrameKind::partial || q.partial.moves_whole_body) return;
  std::vector<std::uint8_t> need(model.joint_count(), 0);
  for (int j : q.partial.affected_joints) need[static_cast<std::size_t>(j)] = 1;
  for (int j : q.partial.subtree_joints) {
    const int p = model.parents[static_cast<std::size_t>(j)];
    if (p >= 0) need[static_cast<std::size_t>(p)] = 1;
  }
  for (std::size_t j = 0; j < need.size(); ++j)
    if (need[j]) q.need_joints.push_back(static_cast<int>(j));
  q.local_joints = q.partial.subtree_joints;
  if (q.need_joints.empty()) q.need_joints.push_back(model.root());  // never empty: empty means all
}

struct Entry {
  double score;
  std::size_t clip, s, e;
  double a, b, cost;
};
bool entry_less(const Entry& x, const Entry& y) {
  if (x.score != y.score) return x.score < y.score;
  if (x.clip != y.clip) return x.clip < y.clip;
  if (x.e != y.e) return x.e < y.e;
  return x.s < y.s;
}

// The shared top-r list of one pair; tau is the r-th best score (inf until full).
class TopR {
 public:
  explicit TopR(std::size_t r) : r_(r) {}
  double tau() const { return tau_.load(std::memory_order_acquire); }
  void insert(const Entry& e) {
    std::lock_guard lock(mutex_);
    auto it = std::lower_bound(entries_.begin(), entries_.end(), e, entry_less);
    entries_.insert(it, e);
    if (entries_.size() > r_) entries_.pop_back();
    if (entries_.size() == r_) tau_.store(entries_.back().score, std::memory_order_release);
  }
  std::vector<Entry> take() { return std::move(entries_); }

 private:
  std::size_t r_;
  std::mutex mutex_;
  std::vector<Entry> entries_;
  std::atomic<double> tau_{kInf};
};

struct PairContext {
  const SearchEngine::Impl* eng;
  const SkelData* sd;
  const ResolvedFrame* qa;
  const ResolvedFrame* qb;
  double t, lambda;
  bool relative;
  Eigen::Vector2d offset_a, offset_b;  // relative mode x/z offsets
  SearchMode mode;
  double max_length_s;
  // Per skeleton frame lower bounds of a / b for partial query frames (world mode), or null.
  const double* frame_lb_a = nullptr;
  const double* frame_lb_b = nullptr;
};

struct ClipCounters {
  std::uint64_t evaluated = 0, pruned = 0;
  bool clip_pruned = false;
};

// World mode: per-frame lower bounds (block boxes, partial-frame bounds),
// a(s) and b(e) where they can matter, then the running minimum.
bool eval_clip_world(const PairContext& c, const ClipInfo& ci, double tau, Scratch& sc,
                     ClipCounters& cnt, Entry& out) {
  const SkelData& sd = *c.sd;
  const std::size_t k = ci.frame_count;
  const std::size_t nb = (k + 15) / 16;
  sc.a.assign(k, kInf);
  sc.b.assign(k, kInf);
  sc.skip_a.assign(k, 0);
  sc.skip_b.assign(k, 0);
  const bool prune = c.mode != SearchMode::brute;
  if (prune) {
    sc.la.resize(k);
    sc.lb.resize(k);
    const std::size_t s3 = sd.segments * 3;
    const bool box_a = c.qa->kind != FrameKind::partial, box_b = c.qb->kind != FrameKind::partial;
    for (std::size_t bl = 0; bl < nb; ++bl) {
      const std::size_t row = ci.block_start + bl;
      const float* cmin = sd.block_com_min.data() + row * s3;
      const float* cmax = sd.block_com_max.data() + row * s3;
      const float* rmin = sd.block_root_min.data() + row * 3;
      const float* rmax = sd.block_root_max.data() + row * 3;
      const double xa = box_a ? box_lower_bound(*c.qa, sd, c.t, cmin, cmax, rmin, rmax) : 0.0;
      const double xb = box_b ? box_lower_bound(*c.qb, sd, c.t, cmin, cmax, rmin, rmax) : 0.0;
      const std::size_t f1 = std::min(k, bl * 16 + 16);
      for (std::size_t f = bl * 16; f < f1; ++f) {
        sc.la[f] = xa;
        sc.lb[f] = xb;
      }
    }
    if (c.frame_lb_a != nullptr)
      for (std::size_t f = 0; f < k; ++f) sc.la[f] = std::max(sc.la[f], c.frame_lb_a[ci.frame_start + f]);
    if (c.frame_lb_b != nullptr)
      for (std::size_t f = 0; f < k; ++f) sc.lb[f] = std::max(sc.lb[f], c.frame_lb_b[ci.frame_start + f]);
    // s is needed only if la(s) + min_{e>s} lb(e) can reach tau; e only if
    // lb(e) + min_{s<e} la(s) can.
    double clip_lb = kInf, suffix = kInf;
    for (std::size_t f = k; f-- > 0;) {
      const double x = sc.la[f] + suffix;
      clip_lb = std::min(clip_lb, x);
      sc.skip_a[f] = safe(x) > tau;
      suffix = std::min(suffix, sc.lb[f]);
    }
    if (safe(clip_lb) > tau) {
      cnt.clip_pruned = true;
      cnt.pruned += 2 * k;
      return false;
    }
    double prefix_min = kInf;
    for (std::size_t f = 0; f < k; ++f) {
      sc.skip_b[f] = safe(sc.lb[f] + prefix_min) > tau;
      prefix_min = std::min(prefix_min, sc.la[f]);
    }
  }
  // Full and root-only query frames are scanned in whole 16-frame chunks
  // (the same chunks in every mode: bit-identical values); partial ones per frame.
  auto side = [&](const ResolvedFrame& q, std::vector<std::uint8_t>& skip, double* dst) {
    for (std::size_t bl = 0; bl < nb; ++bl) {
      const std::size_t f0 = bl * 16, f1 = std::min(k, f0 + 16);
      std::size_t need = 0;
      for (std::size_t f = f0; f < f1; ++f) need += skip[f] == 0;
      if (need == 0) {
        cnt.pruned += f1 - f0;
        continue;
      }
      if (q.kind == FrameKind::partial) {
        evaluate(q, sd, *c.eng->index, c.t, ci.frame_start + f0, ci.frame_start + f1, dst + f0, sc,
                 std::nullopt, skip.data() + f0);
        cnt.evaluated += need;
        cnt.pruned += (f1 - f0) - need;
      } else {
        evaluate(q, sd, *c.eng->index, c.t, ci.frame_start + f0, ci.frame_start + f1, dst + f0, sc);
        cnt.evaluated += f1 - f0;
      }
    }
  };
  side(*c.qa, sc.skip_a, sc.a.data());
  side(*c.qb, sc.skip_b, sc.b.data());
  const std::span<const double> prefix = c.eng->index->clip_energy_prefix(ci.clip);
  ClipBest best;
  if (!best_partial_motion(sc.a.data(), sc.b.data(), prefix.data(), k, c.lambda, best)) return false;
  out = {best.score, ci.clip, best.s, best.e, sc.a[best.s], sc.b[best.e], prefix[best.e] - prefix[best.s]};
  return true;
}

// Relative mode: a(s) with Q^h placed on F^s, b(s, e) with Q^h+1 placed
// relative to F^s; O(K L).
bool eval_clip_relative(const PairContext& c, const ClipInfo& ci, double tau, Scratch& sc,
                        ClipCounters& cnt, Entry& out) {
  const SkelData& sd = *c.sd;
  const std::size_t k = ci.frame_count;
  if (k < 2) return false;
  const double dt = c.eng->index->clips()[ci.clip].frame_time_s;
  const std::size_t l = std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(c.max_length_s / dt)));
  const bool prune = c.mode != SearchMode::brute;
  const float* root = sd.table.root_positions.data();
  const std::size_t stride = sd.table.stride;
  auto anchor = [&](std::size_t f, const Eigen::Vector2d& off) {
    const std::size_t g = ci.frame_start + f;
    return Eigen::Vector2d(static_cast<double>(root[g]) + off[0], static_cast<double>(root[2 * stride + g]) + off[1]);
  };
  std::uint64_t total = 0;
  for (std::size_t s = 0; s + 1 < k; ++s) total += 1 + std::min(l, k - 1 - s);
  sc.a.assign(k, kInf);
  double min_a = kInf;
  for (std::size_t s = 0; s + 1 < k; ++s) {
    evaluate(*c.qa, sd, *c.eng->index, c.t, ci.frame_start + s, ci.frame_start + s + 1, sc.a.data() + s, sc,
             anchor(s, c.offset_a));
    min_a = std::min(min_a, sc.a[s]);
  }
  cnt.evaluated += k - 1;
  if (prune && safe(min_a) > tau) {
    cnt.clip_pruned = true;
    cnt.pruned += total - (k - 1);
    return false;
  }
  const std::span<const double> prefix = c.eng->index->clip_energy_prefix(ci.clip);
  ClipBest best;
  bool have = false;
  sc.b.resize(l);
  for (std::size_t s = 0; s + 1 < k; ++s) {
    const std::size_t e1 = std::min(k - 1, s + l);
    if (prune && safe(sc.a[s]) > tau) {
      cnt.pruned += e1 - s;
      continue;
    }
    evaluate(*c.qb, sd, *c.eng->index, c.t, ci.frame_start + s + 1, ci.frame_start + e1 + 1, sc.b.data(), sc,
             anchor(s, c.offset_b));
    cnt.evaluated += e1 - s;
    for (std::size_t e = s + 1; e <= e1; ++e) {
      const double score = (sc.b[e - s - 1] + c.lambda * prefix[e]) + (sc.a[s] - c.lambda * prefix[s]);
      if (better(score, e, s, best, have)) {
        best = {score, s, e};
        out.b = sc.b[e - s - 1];
        have = true;
      }
    }
  }
  if (!have) return false;
  out = {best.score, ci.clip, best.s, best.e, sc.a[best.s], out.b, prefix[best.e] - prefix[best.s]};
  return true;
}

}  // namespace

// ---------------------------------------------------------------------------
// A query

namespace {

bool same_character(const Character& x, const Character& y) {
  return x.total_mass_kg == y.total_mass_kg && x.sex == y.sex && x.class_mass_kg == y.class_mass_kg &&
         x.class_mass_scale == y.class_mass_scale && x.joint_mass_kg == y.joint_mass_kg &&
         x.class_length_scale == y.class_length_scale && x.joint_length_scale == y.joint_length_scale;
}

struct PairRun {
  std::vector<Entry> top;
  SearchStats stats;
};

}  // namespace

struct QueryRunner {
  const SearchEngine::Impl& eng;
  const Query& q;
  const SearchOptions& opt;
  // resolved[k][i]: query frame i on skeleton k.
  std::vector<std::vector<ResolvedFrame>> resolved;
  tbb::enumerable_thread_specific<Scratch> scratch;
  // frame_lb[k][i]: per skeleton frame lower bound of h(query frame i -> F)
  // for partial query frames (exact mode, world), computed once per query
  // frame and shared by its two pairs; empty otherwise.
  std::vector<std::vector<std::vector<double>>> frame_lb;

  void compute_frame_bounds() {
    frame_lb.assign(eng.skels.size(), std::vector<std::vector<double>>(q.frames.size()));
    for (std::size_t k = 0; k < eng.skels.size(); ++k) {
      const SkelData& sd = *eng.skels[k];
      const std::size_t n = sd.sk->frame_count;
      for (std::size_t i = 0; i < q.frames.size(); ++i) {
        if (resolved[k][i].kind != FrameKind::partial || n == 0) continue;
        const PartialBoundPlan plan = make_partial_bound_plan(resolved[k][i], sd, q.transition_time_s);
        const FrameArrays fa = frame_arrays(*eng.index, sd.k);
        std::vector<double>& out = frame_lb[k][i];
        out.resize(n);
        auto chunk = [&](std::size_t g0, std::size_t g1) {
          partial_frame_bounds(plan, sd, fa, g0, g1, out.data() + g0, scratch.local());
        };
        if (opt.parallel_clips)
          tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096),
                            [&](const tbb::blocked_range<std::size_t>& rg) { chunk(rg.begin(), rg.end()); });
        else
          chunk(0, n);
      }
    }
  }

  const double* frame_bounds_of(std::size_t k, std::size_t i) const {
    if (frame_lb.empty() || frame_lb[k][i].empty()) return nullptr;
    return frame_lb[k][i].data();
  }

  bool passes(std::size_t clip) const {
    if (q.filter.empty()) return true;
    const IndexClip& c = eng.index->clips()[clip];
    const std::string name = std::filesystem::path(c.path).filename().string();
    const std::string content = eng.content_key >= 0 ? c.labels[static_cast<std::size_t>(eng.content_key)] : "";
    const std::string style = eng.style_key >= 0 ? c.labels[static_cast<std::size_t>(eng.style_key)] : "";
    return q.filter.accepts(name, content, style);
  }

  PairContext context(std::size_t k, std::size_t h, SearchMode mode) const {
    PairContext c{&eng, eng.skels[k].get(), &resolved[k][h], &resolved[k][h + 1], q.transition_time_s,
                  q.path_weight, q.relative, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), mode,
                  opt.max_length_s, nullptr, nullptr};
    if (mode == SearchMode::exact && !q.relative) {
      c.frame_lb_a = frame_bounds_of(k, h);
      c.frame_lb_b = frame_bounds_of(k, h + 1);
    }
    if (q.relative) {
      // Hand-written frames: given x/z are the offsets. BVH frames: offsets
      // from the pair's first query frame when it is a BVH frame, else 0.
      auto offset = [&](const ResolvedFrame& f) {
        if (!f.from_bvh) return Eigen::Vector2d(f.given[0] ? f.root_m[0] : 0.0, f.given[2] ? f.root_m[2] : 0.0);
        const ResolvedFrame& first = *c.qa;
        if (!first.from_bvh) return Eigen::Vector2d::Zero().eval();
        return Eigen::Vector2d(f.root_m[0] - first.root_m[0], f.root_m[2] - first.root_m[2]);
      };
      c.offset_a = offset(*c.qa);
      c.offset_b = offset(*c.qb);
    }
    return c;
  }

  // Candidate clips (skeleton, row) of pair h for approx mode; nullopt = all.
  std::optional<std::vector<std::pair<std::size_t, std::size_t>>> approx_candidates(std::size_t h) const {
    std::vector<std::pair<std::size_t, std::size_t>> out;
    for (std::size_t k = 0; k < eng.skels.size(); ++k) {
      const ResolvedFrame& qa = resolved[k][h];
      const ResolvedFrame& qb = resolved[k][h + 1];
      if (qa.kind != FrameKind::full || qb.kind != FrameKind::full || q.relative) return std::nullopt;
    }
    for (std::size_t k = 0; k < eng.skels.size(); ++k) {
      const SkelData& sd = *eng.skels[k];
      const std::size_t n = sd.sk->frame_count, dim = sd.segments * 3;
      if (n == 0) continue;
      std::call_once(sd.flann_once, [&] {
        sd.flann = std::make_unique<search_detail::KnnIndex>(sd.kd, n, dim, opt.approx_trees);
      });
      const std::size_t knn = std::min<std::size_t>(n, static_cast<std::size_t>(opt.approx_neighbours_per_result) * q.top);
      std::set<std::size_t> rows;
      std::vector<std::size_t> idx;
      for (const ResolvedFrame* f : {&resolved[k][h], &resolved[k][h + 1]}) {
        sd.flann->knn(f->kd.data(), knn, opt.approx_checks, idx);
        for (std::size_t i : idx) rows.insert(sd.frame_row[i]);
      }
      for (std::size_t r : rows) out.emplace_back(k, r);
    }
    return out;
  }

  PairRun run_pair(std::size_t h, SearchMode mode) {
    PairRun pr;
    std::vector<std::pair<std::size_t, std::size_t>> cands;
    std::optional<std::vector<std::pair<std::size_t, std::size_t>>> approx;
    if (mode == SearchMode::approx) approx = approx_candidates(h);
    const SearchMode eval_mode = mode == SearchMode::approx ? SearchMode::exact : mode;
    if (approx) {
      for (auto [k, r] : *approx)
        if (passes(eng.skels[k]->clips[r].clip)) cands.emplace_back(k, r);
      for (std::size_t k = 0; k < eng.skels.size(); ++k)
        for (const ClipInfo& ci : eng.skels[k]->clips)
          if (passes(ci.clip)) ++pr.stats.clips;
      pr.stats.clips_pruned += pr.stats.clips - cands.size();
    } else {
      for (std::size_t k = 0; k < eng.skels.size(); ++k)
        for (std::size_t r = 0; r < eng.skels[k]->clips.size(); ++r)
          if (passes(eng.skels[k]->clips[r].clip)) cands.emplace_back(k, r);
      pr.stats.clips = cands.size();
    }
    // Clip-level bounds order the work: likely winners first lower tau early.
    std::vector<double> lb(cands.size(), 0.0);
    if (eval_mode == SearchMode::exact && !q.relative) {
      for (std::size_t i = 0; i < cands.size(); ++i) {
        const auto [k, r] = cands[i];
        const SkelData& sd = *eng.skels[k];
        const std::size_t s3 = sd.segments * 3;
        const float* cmin = sd.clip_com_min.data() + r * s3;
        const float* cmax = sd.clip_com_max.data() + r * s3;
        const float* rmin = sd.clip_root_min.data() + r * 3;
        const float* rmax = sd.clip_root_max.data() + r * 3;
        const double xa = box_lower_bound(resolved[k][h], sd, q.transition_time_s, cmin, cmax, rmin, rmax);
        const double xb = box_lower_bound(resolved[k][h + 1], sd, q.transition_time_s, cmin, cmax, rmin, rmax);
        lb[i] = xa + xb;
        const double* fa = frame_bounds_of(k, h);
        const double* fb = frame_bounds_of(k, h + 1);
        if (fa == nullptr && fb == nullptr) continue;
        // min over s < e of (max(xa, fa[s]) + max(xb, fb[e])).
        const ClipInfo& ci = sd.clips[r];
        double best = kInf, suffix = kInf;
        for (std::size_t f = ci.frame_count; f-- > 0;) {
          const std::size_t g = ci.frame_start + f;
          best = std::min(best, (fa ? std::max(xa, fa[g]) : xa) + suffix);
          suffix = std::min(suffix, fb ? std::max(xb, fb[g]) : xb);
        }
        lb[i] = std::max(lb[i], best);
      }
    }
    std::vector<std::size_t> order(cands.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
      if (lb[x] != lb[y]) return lb[x] < lb[y];
      return eng.skels[cands[x].first]->clips[cands[x].second].clip <
             eng.skels[cands[y].first]->clips[cands[y].second].clip;
    });
    TopR top(q.top);
    std::atomic<std::uint64_t> evaluated{0}, pruned{0}, clips_pruned{0};
    std::vector<PairContext> contexts;
    for (std::size_t k = 0; k < eng.skels.size(); ++k) contexts.push_back(context(k, h, eval_mode));
    auto body = [&](std::size_t i) {
      const auto [k, r] = cands[order[i]];
      const ClipInfo& ci = eng.skels[k]->clips[r];
      const double tau = top.tau();
      ClipCounters cnt;
      if (eval_mode == SearchMode::exact && safe(lb[order[i]]) > tau) {
        cnt.clip_pruned = true;
        cnt.pruned = q.relative ? 0 : 2 * ci.frame_count;
      } else {
        Entry e{};
        Scratch& sc = scratch.local();
        const bool ok = q.relative ? eval_clip_relative(contexts[k], ci, tau, sc, cnt, e)
                                   : eval_clip_world(contexts[k], ci, tau, sc, cnt, e);
        if (ok) top.insert(e);
      }
      evaluated += cnt.evaluated;
      pruned += cnt.pruned;
      if (cnt.clip_pruned) ++clips_pruned;
    };
    if (opt.parallel_clips)
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, order.size(), 8),
                        [&](const tbb::blocked_range<std::size_t>& rg) {
                          for (std::size_t i = rg.begin(); i != rg.end(); ++i) body(i);
                        });
    else
      for (std::size_t i = 0; i < order.size(); ++i) body(i);
    pr.top = top.take();
    pr.stats.frames_evaluated = evaluated;
    pr.stats.frames_pruned += pruned;
    pr.stats.clips_pruned += clips_pruned;
    return pr;
  }
};

QueryOutcome SearchEngine::run(const Query& q, const SearchOptions& opt) const {
  const auto t0 = std::chrono::steady_clock::now();
  const Impl& m = *impl_;
  if (q.frames.size() < 2) throw InputError("query " + q.id, 0, "frames: at least 2 query frames are needed");
  if (!(opt.max_length_s > 0.0)) throw std::invalid_argument("SearchOptions::max_length_s must be > 0");
  if (q.character) {
    const Character ch = read_character_file(*q.character);
    if (!m.character || !same_character(ch, *m.character))
      throw InputError("query " + q.id, 0,
                       fmt::format("character: {} differs from the index's character \"{}\"; this "
                                   "build searches only with the index's character (rebuild the "
                                   "index with mocap-index build --character)",
                                   q.character->string(), m.index->info().character_name));
  }
  QueryRunner run{m, q, opt, {}, {}, {}};
  run.resolved.resize(m.skels.size());
  for (std::size_t k = 0; k < m.skels.size(); ++k)
    for (std::size_t i = 0; i < q.frames.size(); ++i)
      run.resolved[k].push_back(search_detail::resolve_frame(q, i, *m.skels[k]->sk, m.skels[k]->model,
                                                             q.transition_time_s, m.t_index, m.bvh_cache,
                                                             m.index->info().unit_option));
  for (std::size_t k = 0; k < m.skels.size(); ++k)
    for (ResolvedFrame& f : run.resolved[k]) set_needed_joints(f, m.skels[k]->model);
  if ((opt.mode == SearchMode::exact || opt.mode == SearchMode::approx) && !q.relative) run.compute_frame_bounds();
  QueryOutcome out;
  out.id = q.id;
  double recall_sum = 0.0;
  for (std::size_t h = 0; h + 1 < q.frames.size(); ++h) {
    PairRun pr = run.run_pair(h, opt.mode);
    if (opt.mode == SearchMode::approx && opt.compute_recall) {
      const PairRun ex = run.run_pair(h, SearchMode::exact);
      std::set<std::size_t> exact_clips;
      for (const Entry& e : ex.top) exact_clips.insert(e.clip);
      std::size_t hit = 0;
      for (const Entry& e : pr.top) hit += exact_clips.count(e.clip);
      recall_sum += exact_clips.empty() ? 1.0 : static_cast<double>(hit) / static_cast<double>(exact_clips.size());
    }
    PairResults res;
    res.from = h;
    res.to = h + 1;
    for (std::size_t i = 0; i < pr.top.size(); ++i) {
      const Entry& e = pr.top[i];
      SearchResult r;
      r.rank = i + 1;
      r.clip_index = e.clip;
      const IndexClip& c = m.index->clips()[e.clip];
      r.clip = c.path;
      for (std::size_t key = 0; key < m.index->label_keys().size(); ++key)
        if (!c.labels[key].empty()) r.labels.emplace_back(m.index->label_keys()[key], c.labels[key]);
      r.start_frame = e.s;
      r.end_frame = e.e;
      r.score_J = e.score;
      r.h_in_J = e.a;
      r.h_out_J = e.b;
      r.path_cost_J = e.cost;
      res.results.push_back(std::move(r));
    }
    out.pairs.push_back(std::move(res));
    out.stats.clips += pr.stats.clips;
    out.stats.clips_pruned += pr.stats.clips_pruned;
    out.stats.frames_evaluated += pr.stats.frames_evaluated;
    out.stats.frames_pruned += pr.stats.frames_pruned;
  }
  if (opt.mode == SearchMode::approx && opt.compute_recall)
    out.stats.recall = recall_sum / static_cast<double>(q.frames.size() - 1);
  out.stats.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

void SearchEngine::frame_bounds(const Query& q, std::size_t i, std::size_t k, std::vector<double>& lower,
                                std::vector<double>& h) const {
  const Impl& m = *impl_;
  if (k >= m.skels.size() || i >= q.frames.size()) throw std::invalid_argument("frame_bounds: no such skeleton or frame");
  const SkelData& sd = *m.skels[k];
  ResolvedFrame f = search_detail::resolve_frame(q, i, *sd.sk, sd.model, q.transition_time_s, m.t_index,
                                                 m.bvh_cache, m.index->info().unit_option);
  set_needed_joints(f, sd.model);
  const std::size_t n = sd.sk->frame_count, s3 = sd.segments * 3;
  lower.assign(n, 0.0);
  h.assign(n, kInf);
  Scratch sc;
  if (f.kind == FrameKind::partial) {
    const PartialBoundPlan plan = make_partial_bound_plan(f, sd, q.transition_time_s);
    partial_frame_bounds(plan, sd, frame_arrays(*m.index, sd.k), 0, n, lower.data(), sc);
  }
  for (const ClipInfo& ci : sd.clips)
    for (std::size_t bl = 0; bl * 16 < ci.frame_count; ++bl) {
      const std::size_t row = ci.block_start + bl;
      const double x = f.kind == FrameKind::partial
                           ? 0.0
                           : box_lower_bound(f, sd, q.transition_time_s, sd.block_com_min.data() + row * s3,
                                             sd.block_com_max.data() + row * s3, sd.block_root_min.data() + row * 3,
                                             sd.block_root_max.data() + row * 3);
      const std::size_t g0 = ci.frame_start + bl * 16, g1 = ci.frame_start + std::min(ci.frame_count, bl * 16 + 16);
      for (std::size_t g = g0; g < g1; ++g) lower[g] = std::max(lower[g], x);
      evaluate(f, sd, *m.index, q.transition_time_s, g0, g1, h.data() + g0, sc);
    }
}

// ---------------------------------------------------------------------------
// Batches and output

std::vector<BatchEntry> read_query_batch(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string(), 0, "cannot open the query file");
  std::vector<BatchEntry> out;
  std::string line;
  std::size_t n = 0;
  const std::filesystem::path base = path.parent_path();
  while (std::getline(in, line)) {
    ++n;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    BatchEntry e;
    e.id = fmt::format("line {}", n);
    try {
      e.query = parse_query_text(line, path.string(), n, base, e.id);
      e.id = e.query->id;
    } catch (const InputError& err) {
      // Keep the id when the line is valid JSON with one.
      try {
        const auto j = nlohmann::json::parse(line);
        if (j.is_object() && j.contains("id") && j["id"].is_string()) e.id = j["id"].get<std::string>();
        if (j.is_object() && j.contains("id") && j["id"].is_number_integer()) e.id = std::to_string(j["id"].get<long long>());
      } catch (const nlohmann::json::exception&) {
      }
      e.error = err.what();
    }
    out.push_back(std::move(e));
  }
  return out;
}

std::vector<BatchEntry> read_single_query(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string(), 0, "cannot open the query file");
  std::stringstream ss;
  ss << in.rdbuf();
  BatchEntry e;
  e.id = path.stem().string();
  try {
    e.query = parse_query_text(ss.str(), path.string(), 0, path.parent_path(), e.id);
    e.id = e.query->id;
  } catch (const InputError& err) {
    e.error = err.what();
  }
  return {std::move(e)};
}

std::vector<QueryOutcome> run_query_batch(const SearchEngine& engine, const std::vector<BatchEntry>& batch,
                                          const SearchOptions& options,
                                          const std::function<void(std::size_t, std::size_t)>& progress) {
  std::vector<QueryOutcome> out(batch.size());
  std::mutex progress_mutex;
  std::size_t done = 0;
  tbb::parallel_for(std::size_t{0}, batch.size(), [&](std::size_t i) {
    const BatchEntry& e = batch[i];
    if (!e.query) {
      out[i].id = e.id;
      out[i].error = e.error;
    } else {
      try {
        out[i] = engine.run(*e.query, options);
      } catch (const std::exception& err) {
        out[i] = QueryOutcome{};
        out[i].id = e.id;
        out[i].error = err.what();
      }
    }
    if (progress) {
      std::lock_guard lock(progress_mutex);
      progress(++done, batch.size());
    }
  });
  return out;
}

std::string query_outcome_json(const QueryOutcome& o) {
  nlohmann::ordered_json j;
  j["id"] = o.id;
  if (o.error) {
    j["error"] = *o.error;
    return j.dump();
  }
  j["pairs"] = nlohmann::ordered_json::array();
  for (const PairResults& p : o.pairs) {
    nlohmann::ordered_json pj;
    pj["from"] = p.from;
    pj["to"] = p.to;
    pj["results"] = nlohmann::ordered_json::array();
    for (const SearchResult& r : p.results) {
      nlohmann::ordered_json rj;
      rj["rank"] = r.rank;
      rj["clip"] = r.clip;
      rj["clip_index"] = r.clip_index;
      nlohmann::ordered_json labels = nlohmann::ordered_json::object();
      for (const auto& [k, v] : r.labels) labels[k] = v;
      rj["labels"] = labels;
      rj["start_frame"] = r.start_frame;
      rj["end_frame"] = r.end_frame;
      rj["score_J"] = r.score_J;
      rj["h_in_J"] = r.h_in_J;
      rj["h_out_J"] = r.h_out_J;
      rj["path_cost_J"] = r.path_cost_J;
      pj["results"].push_back(std::move(rj));
    }
    j["pairs"].push_back(std::move(pj));
  }
  nlohmann::ordered_json s;
  s["clips"] = o.stats.clips;
  s["clips_pruned"] = o.stats.clips_pruned;
  s["frames_evaluated"] = o.stats.frames_evaluated;
  s["frames_pruned"] = o.stats.frames_pruned;
  s["time_ms"] = o.stats.time_ms;
  if (o.stats.recall) s["recall"] = *o.stats.recall;
  j["stats"] = s;
  return j.dump();
}

}  // namespace mocap
