#include "query/resolved_frame.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "mocap/common/body/body.hpp"
#include "mocap/common/body/retarget.hpp"
#include "mocap/common/dynamics/index_frames.hpp"
#include "mocap/common/io/asf_amc.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/input_limits.hpp"
#include "mocap/common/util/xxh64.hpp"
#include "mocap/search/query_validation.hpp"

namespace mocap {

namespace {

constexpr std::size_t kBvhCacheEntries = 256;
// Verified texts of indexed files kept (QueryBvhCache::get_frames): a
// set-2 clip's text is about 100 KB.
constexpr std::size_t kVerifiedTexts = 16;
// Distinct hierarchies kept (QueryBvhCache::hierarchy_of): set 2 has 3.
constexpr std::size_t kHierarchies = 8;

std::string field(std::size_t i) {
  return fmt::format("frames[{}]", i);
}

[[noreturn]] void fail(const Query& q, const std::string& path, const std::string& what) {
  throw InputError("query " + q.id, 0, path + ": " + what);
}

std::string valid_joint_names(const Skeleton& skel) {
  std::string out;
  for (const auto& n : skel.names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

int resolve_joint(const Query& q, const std::string& path, const Skeleton& skel,
                  const std::string& name) {
  const int j = find_joint_by_alias(skel, name);
  if (j < 0)
    fail(q, path,
         fmt::format("unknown joint \"{}\" ({}valid: {}; canonical names such as RightUpperArm, "
                     "LeftForeArm, Hips also work)",
                     name, joint_did_you_mean(skel, name), valid_joint_names(skel)));
  return j;
}

// Index-skeleton joint -> file joint of the same rig (retarget.hpp same_rig:
// the same joint names and parents), by name.
std::vector<int> map_joints(const Skeleton& skel, const Skeleton& file_skel) {
  std::vector<int> map(skel.joint_count(), -1);
  for (std::size_t j = 0; j < skel.joint_count(); ++j) map[j] = file_skel.find(skel.names[j]);
  return map;
}

// The retargeting of a file skeleton onto index skeleton `skel` when they
// are different rigs (retarget.hpp), null for the same rig.
std::unique_ptr<const RetargetMap> cross_rig_map(const Query& q, const std::string& path,
                                                 const Skeleton& file_skel, const Skeleton& skel,
                                                 const TypicalPoseFn& typical_pose) {
  if (same_rig(file_skel, skel)) return nullptr;
  const std::vector<Eigen::Quaterniond>* typical = typical_pose ? typical_pose() : nullptr;
  try {
    return std::make_unique<const RetargetMap>(
        make_retarget_map(file_skel, skel, typical ? *typical : std::vector<Eigen::Quaterniond>{}));
  } catch (const InputError& e) {
    fail(q, path + ".bvh", e.detail());
  }
}

}  // namespace

std::shared_ptr<const QueryBvhFile> QueryBvhCache::store(const std::string& key,
                                                         std::shared_ptr<QueryBvhFile> entry) {
  std::lock_guard lock(mutex_);
  if (entries_.size() >= kBvhCacheEntries) entries_.clear();
  entries_[key] = entry;
  return entry;
}

namespace {

// The whole file from its parsed text, as get() builds it: Y up as the
// indexer makes it (a Z-up clip, detected over the whole clip, is rotated),
// then in metres.
std::shared_ptr<QueryBvhFile> whole_file_scaled(RawClip raw, std::optional<double> metres) {
  normalise_up_axis(raw, std::nullopt);
  auto loaded = std::make_shared<QueryBvhFile>();
  loaded->motion = clip_locals_from_raw(raw, metres ? *metres : unit_scale_m(detect_unit(raw)));
  loaded->file_frame_count = loaded->motion.frame_count;
  return loaded;
}

std::shared_ptr<QueryBvhFile> whole_file(RawClip raw, const std::string& unit_option) {
  std::optional<double> metres;
  if (unit_option != "auto" && !unit_option.empty())
    if (const auto unit = parse_unit(unit_option)) metres = unit_scale_m(*unit);
  return whole_file_scaled(std::move(raw), metres);
}

FileStat stat_or_throw(const std::filesystem::path& path, const char* kind = "BVH") {
  try {
    return check_input_file(path, input_limits().bvh_bytes);
  } catch (const InputError& e) {
    throw InputError(path.string(), 0,
                     std::string("cannot read the ") + kind + " file: " + e.detail());
  }
}

// The segment of joint j for a direction: its only child, else the child
// on the trunk chain (an ancestor of the neck), else -1 (ambiguous or none).
int segment_end(const Skeleton& skel, int j) {
  const std::vector<int> kids = skel.children(j);
  if (kids.size() == 1) return kids[0];
  const int neck = find_joint_by_alias(skel, "Neck");
  for (int k : kids)
    for (int a = neck; a >= 0; a = skel.parents[static_cast<std::size_t>(a)])
      if (a == k) return k;
  return -1;
}

int body_part(const Query& q, const std::string& path, const Skeleton& skel,
              const std::string& part, const std::string& what) {
  const int j = find_joint_by_alias(skel, part);
  if (j < 0) fail(q, path, fmt::format("this skeleton has no {} ({}) for {}", part, part, what));
  return j;
}

// The given local rotations as constraints: named by the query's entry
// (hand-written frames), unnamed for a BVH frame's "only".
std::vector<PoseConstraint> rotation_constraints(const QueryFrameSpec& spec, const Skeleton& skel,
                                                 const PartialPoseSpec& given) {
  std::vector<PoseConstraint> cs;
  for (const auto& [j, rot] : given.joint_rotations) {
    PoseConstraint c;
    c.kind = PoseConstraintKind::local_rotation;
    c.joint = j;
    c.local = rot;
    for (const JointRotationSpec& jr : spec.joints)
      if (!jr.direction && find_joint_by_alias(skel, jr.name) == j) {
        c.name = jr.name;
        c.weight = jr.weight.value_or(1.0);
      }
    cs.push_back(c);
  }
  return cs;
}

// A joint entry's direction (at: its field path) as a body-frame constraint.
PoseConstraint direction_constraint(const Query& q, const std::string& at,
                                    const JointRotationSpec& jr, const Skeleton& skel, int root) {
  PoseConstraint c;
  c.kind = PoseConstraintKind::direction;
  c.name = jr.name;
  c.joint = resolve_joint(q, at, skel, jr.name);
  if (c.joint == root)
    fail(q, at,
         "the root's direction would turn the body frame itself: give root_heading_deg, or "
         "the direction of a joint below it");
  c.end = segment_end(skel, c.joint);
  if (c.end < 0)
    fail(q, at,
         fmt::format("{} has {} child joints: a direction needs one segment (give a joint "
                     "with one child, e.g. Spine, RightUpperArm, RightForeArm, RightUpLeg)",
                     skel.names[static_cast<std::size_t>(c.joint)], skel.children(c.joint).size()));
  c.target = *jr.direction;
  c.tolerance = jr.tolerance_deg * std::numbers::pi / 180.0;
  c.weight = jr.weight.value_or(1.0);
  return c;
}

// An angle entry (at: its field path) as a body-frame constraint: trunk or
// hip flexion, knee or elbow flexion, else shoulder elevation.
PoseConstraint angle_constraint(const Query& q, const std::string& at, const AngleSpec& a,
                                const Skeleton& skel, const DynamicsModel& model) {
  const int root = model.root();
  PoseConstraint c;
  c.name = a.name;
  c.angle_rad = a.deg * std::numbers::pi / 180.0;
  c.tolerance = a.tolerance_deg * std::numbers::pi / 180.0;
  c.weight = a.weight.value_or(1.0);
  const bool left = a.name.rfind("left_", 0) == 0;
  const std::string side = left ? "Left" : "Right";
  if (a.name == "trunk_flexion") {
    c.kind = PoseConstraintKind::sagittal_flexion;
    c.end = find_joint_by_alias(skel, "Neck");
    if (c.end < 0) c.end = body_part(q, at, skel, "Head", a.name);
    int base = c.end;
    while (base >= 0 && model.parents[static_cast<std::size_t>(base)] != root)
      base = model.parents[static_cast<std::size_t>(base)];
    if (base < 0 || base == c.end)
      fail(q, at, "no spine between the root and the neck on this skeleton");
    c.joint = base;
  } else if (a.name.ends_with("hip_flexion")) {
    c.kind = PoseConstraintKind::sagittal_flexion;
    c.from_down = true;
    c.joint = body_part(q, at, skel, side + "UpLeg", a.name);
    c.end = body_part(q, at, skel, side + "Leg", a.name);
  } else if (a.name.ends_with("knee_flexion") || a.name.ends_with("elbow_flexion")) {
    const bool knee = a.name.ends_with("knee_flexion");
    c.kind = PoseConstraintKind::hinge_flexion;
    c.middle = body_part(q, at, skel, side + (knee ? "UpLeg" : "UpperArm"), a.name);
    c.joint = body_part(q, at, skel, side + (knee ? "Leg" : "ForeArm"), a.name);
    c.end = body_part(q, at, skel, side + (knee ? "Foot" : "Hand"), a.name);
    c.bend_hint = Eigen::Vector3d(0.0, 0.0, knee ? -1.0 : 1.0);
  } else {  // shoulder elevation
    c.kind = PoseConstraintKind::elevation;
    c.joint = body_part(q, at, skel, side + "UpperArm", a.name);
    c.end = body_part(q, at, skel, side + "ForeArm", a.name);
    c.bend_hint = Eigen::Vector3d(left ? 1.0 : -1.0, 0.0, 0.0);
  }
  return c;
}

// An effector entry (at: its field path) as a two-bone chain constraint.
PoseConstraint effector_constraint(const Query& q, const std::string& at, const EffectorSpec& e,
                                   const Skeleton& skel, const DynamicsModel& model) {
  const int root = model.root();
  PoseConstraint c;
  c.kind = PoseConstraintKind::effector;
  c.name = e.name;
  c.end = resolve_joint(q, at, skel, e.name);
  c.middle = model.parents[static_cast<std::size_t>(c.end)];
  c.joint = c.middle >= 0 ? model.parents[static_cast<std::size_t>(c.middle)] : -1;
  if (c.middle < 0 || c.joint < 0 || c.middle == root || c.joint == root)
    fail(q, at,
         fmt::format("{} is not at the end of a two-bone chain below the root (e.g. a hand: "
                     "upper arm, forearm; a foot: thigh, shank)",
                     skel.names[static_cast<std::size_t>(c.end)]));
  c.target = e.position_m;
  c.tolerance = e.tolerance_m;
  c.weight = e.weight.value_or(1.0);
  const int lf = find_joint_by_alias(skel, "LeftFoot"), rf = find_joint_by_alias(skel, "RightFoot");
  c.bend_hint = Eigen::Vector3d(0.0, 0.0, (c.end == lf || c.end == rf) ? -1.0 : 1.0);
  return c;
}

// Each joint driven by one entry only (path: the frame's field path).
void check_single_drivers(const Query& q, const std::string& path, const Skeleton& skel,
                          const std::vector<PoseConstraint>& cs) {
  std::vector<const PoseConstraint*> driver(skel.joint_count(), nullptr);
  auto describe = [&](const PoseConstraint& c) {
    return c.name.empty() ? std::string("\"only\"") : "\"" + c.name + "\"";
  };
  for (const PoseConstraint& c : cs)
    for (int j : {c.joint, c.kind == PoseConstraintKind::effector ? c.middle : -1}) {
      if (j < 0) continue;
      const PoseConstraint*& d = driver[static_cast<std::size_t>(j)];
      if (d != nullptr)
        fail(q, path,
             fmt::format("{} and {} both move {}: give one of them", describe(*d), describe(c),
                         skel.names[static_cast<std::size_t>(j)]));
      d = &c;
    }
}

// A constrained frame: the driven joints as its given rotations (solved
// later), which joints keep F's rates, and the joints' weights.
void drive_constrained_joints(const DynamicsModel& model, std::size_t nj, ResolvedQueryPose& out) {
  PartialPoseSpec& given = out.given;
  const std::vector<int> driven = driven_joints(out.constraints, nj);
  std::vector<std::pair<int, Eigen::Quaterniond>> rotations;
  for (int j : driven) rotations.emplace_back(j, Eigen::Quaterniond::Identity());
  given.joint_rotations = std::move(rotations);
  // Per joint, the constraint driving it or its nearest driven ancestor.
  // Joints under a body-frame constraint keep F's rates (a constraint gives
  // a pose); under a given local rotation, root position or heading they are
  // static, as in any partial frame. A joint's terms take that constraint's
  // weight.
  std::vector<const PoseConstraint*> nearest(nj, nullptr);
  for (const PoseConstraint& c : out.constraints) {
    nearest[static_cast<std::size_t>(c.joint)] = &c;
    if (c.kind == PoseConstraintKind::effector) nearest[static_cast<std::size_t>(c.middle)] = &c;
  }
  for (std::size_t j = 0; j < nj; ++j) {
    const int p = model.parents[j];
    if (nearest[j] == nullptr && p >= 0) nearest[j] = nearest[static_cast<std::size_t>(p)];
  }
  const bool whole = given.root_heading_rad || given.root_position_m[0] ||
                     given.root_position_m[1] || given.root_position_m[2];
  out.keep_rates.assign(nj, 0);
  bool weighted = false;
  for (std::size_t j = 0; j < nj; ++j) {
    out.keep_rates[j] =
        !whole && nearest[j] != nullptr && nearest[j]->kind != PoseConstraintKind::local_rotation;
    weighted = weighted || (nearest[j] != nullptr && nearest[j]->weight != 1.0);
  }
  if (!weighted) return;
  out.joint_weights.assign(nj, 1.0);
  for (std::size_t j = 0; j < nj; ++j)
    if (nearest[j] != nullptr) out.joint_weights[j] = nearest[j]->weight;
}

// Query frame i's joint entries, angles and effectors as body-frame
// constraints (ResolvedQueryPose::constraints), its weights, and for a
// constrained frame the driven joints in `given`.
void add_constraints(const Query& q, std::size_t i, const Skeleton& skel,
                     const DynamicsModel& model, ResolvedQueryPose& out) {
  const QueryFrameSpec& spec = q.frames[i];
  const std::string path = field(i);
  out.weight = spec.weight;
  std::vector<PoseConstraint> cs = rotation_constraints(spec, skel, out.given);
  for (const JointRotationSpec& jr : spec.joints)
    if (jr.direction)
      cs.push_back(direction_constraint(q, path + ".joints." + jr.name, jr, skel, model.root()));
  for (const AngleSpec& a : spec.angles)
    cs.push_back(angle_constraint(q, path + ".angles." + a.name, a, skel, model));
  for (const EffectorSpec& e : spec.effectors)
    cs.push_back(effector_constraint(q, path + ".effectors." + e.name, e, skel, model));
  if (cs.empty()) return;
  check_single_drivers(q, path, skel, cs);
  sort_constraints(cs);
  out.constraints = std::move(cs);
  out.solve = spec.constrained();
  if (!out.solve) return;
  drive_constrained_joints(model, skel.joint_count(), out);
}

}  // namespace

std::shared_ptr<const QueryBvhFile> QueryBvhCache::get(const std::filesystem::path& path,
                                                       const std::string& unit_option) {
  const FileStat st = stat_or_throw(path);
  const std::string key = unit_option + "|" + path.string();
  {
    std::lock_guard lock(mutex_);
    auto it = entries_.find(key);
    if (it != entries_.end() && it->second->stat == st) return it->second;
  }
  auto loaded = whole_file(read_bvh_file(path), unit_option);
  loaded->stat = st;
  return store(key, std::move(loaded));
}

std::shared_ptr<const QueryBvhFile> QueryBvhCache::get_amc(const std::filesystem::path& amc,
                                                           const std::filesystem::path& asf,
                                                           double frame_time_s) {
  const FileStat st = stat_or_throw(amc, "AMC"), skeleton_st = stat_or_throw(asf, "ASF");
  const std::string key = fmt::format("amc {}|{}|{}|{}|{}", frame_time_s, asf.string(),
                                      skeleton_st.size, skeleton_st.mtime_ns, amc.string());
  {
    std::lock_guard lock(mutex_);
    auto it = entries_.find(key);
    if (it != entries_.end() && it->second->stat == st) return it->second;
  }
  const AsfSkeleton skeleton = read_asf_file(asf);
  RawClip raw = asf_amc_to_raw_clip(skeleton, read_amc_file(amc, skeleton), frame_time_s);
  auto loaded = whole_file_scaled(std::move(raw), skeleton.metres_per_unit());
  loaded->stat = st;
  return store(key, std::move(loaded));
}

std::shared_ptr<const BvhHierarchy> QueryBvhCache::hierarchy_of(std::string_view text) {
  std::lock_guard lock(mutex_);
  for (const auto& h : hierarchies_)
    if (h->heads(text)) return h;
  return nullptr;
}

void QueryBvhCache::use_index(const Index& index) {
  std::lock_guard lock(mutex_);
  known_.clear();
  known_unit_option_ = index.info().unit_option;
  for (const IndexClip& c : index.clips())
    known_[c.path] = {c.size_bytes, c.content_hash, c.unit_scale_m};
}

std::shared_ptr<const QueryBvhFile> QueryBvhCache::get_frames(const std::filesystem::path& path,
                                                              const std::string& unit_option,
                                                              std::size_t frame,
                                                              std::size_t radius) {
  if (known_.empty() || unit_option != known_unit_option_) return get(path, unit_option);
  // The index's paths are absolute and lexically normal: a path given that
  // way is found as it is, any other after normalising it.
  auto it_known = known_.find(path.string());
  if (it_known == known_.end())
    it_known = known_.find(std::filesystem::absolute(path).lexically_normal().string());
  if (it_known == known_.end()) return get(path, unit_option);
  const FileStat st = stat_or_throw(path);
  if (st.size != it_known->second.size) return get(path, unit_option);
  const std::string key = unit_option + "|" + path.string();
  const std::string window_key = fmt::format("{}@{}/{}", key, frame, radius);
  std::shared_ptr<const FileBytes> verified;
  {
    std::lock_guard lock(mutex_);
    for (const std::string* k : {&key, &window_key}) {
      auto it = entries_.find(*k);
      if (it != entries_.end() && it->second->stat == st) return it->second;
    }
    auto it = verified_.find(key);
    if (it != verified_.end() && it->second.stat == st) verified = it->second.text;
  }
  std::shared_ptr<const FileBytes> read;
  if (!verified) {
    read = std::make_shared<const FileBytes>(read_file_bytes(path, st.size));
    if (xxh64(read->view().data(), read->size()) == it_known->second.hash) {
      verified = read;
      std::lock_guard lock(mutex_);
      if (verified_.size() >= kVerifiedTexts) verified_.clear();
      verified_[key] = {st, verified};
    }
  }
  if (verified) {
    const std::string_view text = verified->view();
    // The indexer parsed these bytes: the window's lines are all that is
    // needed, and the hierarchy when no earlier file began with it.
    const std::size_t first = frame >= radius ? frame - radius : 0;
    const std::size_t count = frame - first + radius + 1;
    BvhWindow w;
    if (const auto known = hierarchy_of(text)) {
      w = parse_bvh_window(text, path.string(), *known, first, count);
    } else {
      auto parsed = std::make_shared<BvhHierarchy>();
      w = parse_bvh_window(text, path.string(), first, count, parsed.get());
      std::lock_guard lock(mutex_);
      if (hierarchies_.size() >= kHierarchies) hierarchies_.clear();
      hierarchies_.push_back(std::move(parsed));
    }
    // A window that looks Z up is read as the whole file below instead, so
    // that the up axis is decided over the whole clip, as the indexer
    // decided it (a lying pose can look Z up over a few frames).
    if (detect_up_axis(w.clip) == UpAxis::y) {
      auto loaded = std::make_shared<QueryBvhFile>();
      loaded->motion = clip_locals_from_raw(w.clip, it_known->second.unit_scale_m);
      loaded->first_frame = w.first_frame;
      loaded->file_frame_count = w.file_frame_count;
      loaded->stat = st;
      return store(window_key, std::move(loaded));
    }
  }
  const FileBytes& bytes = verified ? *verified : *read;
  auto loaded = whole_file(parse_bvh(bytes.view(), path.string()), unit_option);
  loaded->stat = st;
  return store(key, std::move(loaded));
}

namespace {

// Query frame i's file (a BVH file's window around the frame, or a whole
// AMC file): `file`'s when it holds one, else read and kept there.
std::shared_ptr<const QueryBvhFile> query_frame_file(const Query& q, std::size_t i,
                                                     QueryBvhCache& cache,
                                                     const std::string& unit_option,
                                                     std::shared_ptr<const QueryBvhFile>* file) {
  const QueryFrameSpec& spec = q.frames[i];
  std::shared_ptr<const QueryBvhFile> bvh = file != nullptr ? *file : nullptr;
  if (bvh) return bvh;
  try {
    // A window of +-2 frames (or the context frames) is all that is read of the file.
    const std::size_t radius = std::max<std::size_t>({2, spec.context_before, spec.context_after});
    bvh = spec.asf ? cache.get_amc(*spec.bvh, *spec.asf, 1.0 / spec.amc_fps)
                   : cache.get_frames(*spec.bvh, unit_option, spec.bvh_frame, radius);
  } catch (const InputError& e) {
    fail(q, field(i) + (spec.asf ? ".amc" : ".bvh"), e.what());
  }
  if (file != nullptr) *file = bvh;
  return bvh;
}

// The buffers of a file frame's window, kept by the thread across calls (a
// query resolves each frame on every skeleton of the index).
struct WindowBuffers {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Quaterniond> rotations;
  std::vector<Eigen::Quaterniond> locals;  // local rotations, frame by frame
  LocalPose local;
  WorldPose world;
};

WindowBuffers& window_buffers() {
  thread_local WindowBuffers buffers;
  return buffers;
}

// Row `row` of `m` on the index skeleton, same rig: the file's local
// rotations (identity for unmapped joints), the index skeleton's offsets,
// the file's translations where both joints have position channels.
void copy_file_frame(const Skeleton& skel, const ClipMotion& m, const std::vector<int>& map,
                     std::size_t row, LocalPose& local) {
  const std::size_t fj = m.joint_count();
  for (std::size_t j = 0; j < skel.joint_count(); ++j) {
    const int fjnt = map[j];
    const double scale = skel.translation_scales.empty() ? 1.0 : skel.translation_scales[j];
    local.rotations[j] = fjnt >= 0 ? m.local_rotations[row * fj + static_cast<std::size_t>(fjnt)]
                                   : Eigen::Quaterniond::Identity();
    const bool file_pos =
        fjnt >= 0 && m.skeleton.channels[static_cast<std::size_t>(fjnt)].has_position();
    local.translations_m[j] =
        (file_pos && skel.channels[j].has_position())
            ? Eigen::Vector3d(m.local_translations_m[row * fj + static_cast<std::size_t>(fjnt)] *
                              scale)
            : Eigen::Vector3d(skel.offsets_m[j] * scale);
  }
}

// World poses of the file's frames f0..f1 on the index skeleton into
// `b.positions` and `b.rotations`, local rotations into `b.locals` (frame by
// frame); across rigs the retargeted pose. Returns the local rotations at
// frame `at`.
std::vector<Eigen::Quaterniond> pose_file_window(const Skeleton& skel, const QueryBvhFile& bvh,
                                                 const RetargetMap* rig,
                                                 const std::vector<int>& map, std::size_t f0,
                                                 std::size_t f1, std::size_t at, WindowBuffers& b) {
  const ClipMotion& m = bvh.motion;
  const std::size_t nj = skel.joint_count();
  // Frame f of the file is row f - base of `m` (a window or the whole file).
  const std::size_t base = bvh.first_frame;
  const std::size_t n = f1 - f0 + 1;
  b.positions.resize(n * nj);
  b.rotations.resize(n * nj);
  b.locals.resize(n * nj);
  std::vector<Eigen::Quaterniond> locals_at_frame(nj);
  b.local.translations_m.resize(nj);
  b.local.rotations.resize(nj);
  for (std::size_t f = f0; f <= f1; ++f) {
    if (rig) {
      retarget_clip_frame(*rig, m, f - base, skel, b.local, b.world);
    } else {
      copy_file_frame(skel, m, map, f - base, b.local);
      forward_kinematics(skel, b.local, b.world);
    }
    if (f == at) locals_at_frame = b.local.rotations;
    std::copy(b.world.positions_m.begin(), b.world.positions_m.end(),
              b.positions.begin() + static_cast<std::ptrdiff_t>((f - f0) * nj));
    std::copy(b.world.rotations.begin(), b.world.rotations.end(),
              b.rotations.begin() + static_cast<std::ptrdiff_t>((f - f0) * nj));
    std::copy(b.local.rotations.begin(), b.local.rotations.end(),
              b.locals.begin() + static_cast<std::ptrdiff_t>((f - f0) * nj));
  }
  return locals_at_frame;
}

// A whole file frame: its world state, root position and mapped joints' rotations.
void set_full_pose(const StateView& v, std::size_t nj, std::size_t r, const std::vector<int>& map,
                   const std::vector<Eigen::Quaterniond>& locals_at_frame, ResolvedQueryPose& out) {
  PartialPoseSpec& partial = out.given;
  out.full = true;
  out.state.resize(nj);
  for (std::size_t j = 0; j < nj; ++j) {
    out.state.joint_positions_m[j] = v.joint_positions_m[j];
    out.state.rotations[j] = v.rotations[j];
    out.state.coms_m[j] = v.coms_m[j];
    out.state.com_velocities_mps[j] = v.com_velocities_mps[j];
    out.state.com_accelerations_mps2[j] = v.com_accelerations_mps2[j];
    out.state.angular_velocities_radps[j] = v.angular_velocities_radps[j];
    out.state.angular_accelerations_radps2[j] = v.angular_accelerations_radps2[j];
  }
  for (int a = 0; a < 3; ++a)
    partial.root_position_m[static_cast<std::size_t>(a)] = v.joint_positions_m[r][a];
  for (std::size_t j = 0; j < nj; ++j)
    if (map[j] >= 0) partial.joint_rotations.emplace_back(static_cast<int>(j), locals_at_frame[j]);
}

// The DOFs a file frame's "only" names, given from the frame.
void set_only_dofs(const Query& q, std::size_t i, const StateView& v, std::size_t r,
                   const Skeleton& file_skel, const Skeleton& skel, const std::vector<int>& map,
                   const std::vector<Eigen::Quaterniond>& locals_at_frame,
                   PartialPoseSpec& partial) {
  const QueryFrameSpec& spec = q.frames[i];
  for (std::size_t k = 0; k < spec.only.size(); ++k) {
    const std::string& dof = spec.only[k];
    if (dof == "root_position") {
      for (int a = 0; a < 3; ++a)
        partial.root_position_m[static_cast<std::size_t>(a)] = v.joint_positions_m[r][a];
    } else if (dof == "root_position_xz") {
      partial.root_position_m[0] = v.joint_positions_m[r][0];
      partial.root_position_m[2] = v.joint_positions_m[r][2];
    } else if (dof == "root_heading") {
      partial.root_heading_rad = heading_rad(v.rotations[r]);
    } else {
      // The name is read on the file's skeleton; the rotation is the
      // frame's on the index skeleton (retargeted across rigs).
      const int j = resolve_only_joint(q, i, k, file_skel, skel, map);
      partial.joint_rotations.emplace_back(j, locals_at_frame[static_cast<std::size_t>(j)]);
    }
  }
}

// Rows of body-frame segment COM velocities of the file's frames [f0, f1]
// (posed on the index skeleton): row j the difference between frames
// `from(j)` and `from(j) + 1` over the frame time, turned by -heading.
void context_rows(const Skeleton& skel, const DynamicsModel& model, const QueryBvhFile& bvh,
                  const RetargetMap* rig, const std::vector<int>& map, std::size_t f0,
                  std::size_t f1, std::size_t rows, bool before, double heading,
                  std::vector<Eigen::Vector3d>& out) {
  WindowBuffers& b = window_buffers();
  (void)pose_file_window(skel, bvh, rig, map, f0, f1, f0, b);
  const std::size_t nj = skel.joint_count();
  const double dt = bvh.motion.frame_time_s;
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(-heading, Eigen::Vector3d::UnitY()).matrix();
  auto com = [&](std::size_t f, int j) {
    const std::size_t at = (f - f0) * nj + static_cast<std::size_t>(j);
    return Eigen::Vector3d(b.positions[at] +
                           b.rotations[at] * model.coms_local_m[static_cast<std::size_t>(j)]);
  };
  out.clear();
  for (std::size_t row = 0; row < rows; ++row) {
    // Before: the difference ending at a - row; after: the one starting at b + row.
    const std::size_t lo = before ? f1 - row - 1 : f0 + row;
    for (const int j : model.segments) out.push_back(turn * (com(lo + 1, j) - com(lo, j)) / dt);
  }
}

// The context velocities of query frame i (a whole file frame), if asked.
void set_context(const Query& q, std::size_t i, const Skeleton& skel, const DynamicsModel& model,
                 const QueryBvhFile& bvh, const RetargetMap* rig, const std::vector<int>& map,
                 double heading, ResolvedQueryPose& out) {
  const QueryFrameSpec& spec = q.frames[i];
  const std::size_t a = spec.bvh_frame, count = bvh.file_frame_count;
  const std::string path = field(i) + ".context";
  out.context_frame_time_s = bvh.motion.frame_time_s;
  if (spec.context_before > 0) {
    if (a < spec.context_before)
      fail(q, path + ".before",
           fmt::format("{} frames before frame {} of {}: the file has {} before it (0-based)",
                       spec.context_before, a, spec.bvh->string(), a));
    context_rows(skel, model, bvh, rig, map, a - spec.context_before, a, spec.context_before, true,
                 heading, out.context_before_mps);
  }
  if (spec.context_after > 0) {
    if (a + spec.context_after >= count)
      fail(q, path + ".after",
           fmt::format("{} frames after frame {} of {}: the file has {} after it (0-based)",
                       spec.context_after, a, spec.bvh->string(), count - 1 - a));
    context_rows(skel, model, bvh, rig, map, a, a + spec.context_after, spec.context_after, false,
                 heading, out.context_after_mps);
  }
}

// Query frame i given by a BVH or AMC file frame. Returns true for a whole
// frame (`out` complete: no constraints), false when "only" picks DOFs.
bool resolve_file_frame(const Query& q, std::size_t i, const IndexSkeleton& sk,
                        const DynamicsModel& model, QueryBvhCache& cache,
                        const std::string& unit_option, std::shared_ptr<const QueryBvhFile>* file,
                        const TypicalPoseFn& typical_pose, ResolvedQueryPose& out) {
  const QueryFrameSpec& spec = q.frames[i];
  const std::string path = field(i);
  const Skeleton& skel = sk.skeleton;
  out.from_bvh = true;
  const std::shared_ptr<const QueryBvhFile> bvh = query_frame_file(q, i, cache, unit_option, file);
  const ClipMotion& m = bvh->motion;
  if (spec.bvh_frame >= bvh->file_frame_count)
    fail(q, path + ".frame",
         fmt::format("frame {} out of range: {} has {} frames (0-based)", spec.bvh_frame,
                     spec.bvh->string(), bvh->file_frame_count));
  // A file of another rig is retargeted (retarget.hpp); else its local
  // rotations are copied.
  const std::unique_ptr<const RetargetMap> rig =
      cross_rig_map(q, path, m.skeleton, skel, typical_pose);
  const std::vector<int> map = rig ? rig->source_joint : map_joints(skel, m.skeleton);
  // Pose of the file's frames around bvh_frame on the index skeleton. The
  // +-2 frame window gives exactly the clip's finite-difference rates at the
  // frame (dynamics.hpp), and as the index stores and derives them
  // (index_frames.hpp): the frame's own index row has h = 0.
  const std::size_t f0 = spec.bvh_frame >= 2 ? spec.bvh_frame - 2 : 0;
  const std::size_t f1 = std::min(bvh->file_frame_count - 1, spec.bvh_frame + 2);
  WindowBuffers& buffers = window_buffers();
  const std::vector<Eigen::Quaterniond> locals_at_frame =
      pose_file_window(skel, *bvh, rig.get(), map, f0, f1, spec.bvh_frame, buffers);
  const ClipDynamics dyn = clip_dynamics_as_stored(model, f1 - f0 + 1, m.frame_time_s,
                                                   buffers.locals, buffers.positions);
  const StateView v = dyn.state(spec.bvh_frame - f0);
  const std::size_t r = static_cast<std::size_t>(model.root());
  out.local_rotations = locals_at_frame;
  out.file_joints = map;
  out.file_pose = ground_pose_of(v.joint_positions_m[r], v.rotations[r]);
  if (rig) {
    out.cross_rig = true;
    out.compared_joints = rig->compared;
    out.compared_classes = rig->compared_classes;
  }
  if (spec.only.empty()) {
    set_full_pose(v, skel.joint_count(), r, map, locals_at_frame, out);
    set_context(q, i, skel, model, *bvh, rig.get(), map, heading_rad(v.rotations[r]), out);
    return true;
  }
  set_only_dofs(q, i, v, r, m.skeleton, skel, map, locals_at_frame, out.given);
  return false;
}

// Query frame i written by hand: its root values and joint rotations (a
// direction is a body-frame constraint, add_constraints).
void resolve_written_frame(const Query& q, std::size_t i, const Skeleton& skel,
                           PartialPoseSpec& partial) {
  const QueryFrameSpec& spec = q.frames[i];
  const std::string path = field(i);
  partial.root_position_m = spec.root_position_m;
  if (spec.root_heading_deg)
    partial.root_heading_rad = *spec.root_heading_deg * std::numbers::pi / 180.0;
  for (const auto& jr : spec.joints) {
    const int j = resolve_joint(q, path + ".joints." + jr.name, skel, jr.name);
    if (jr.direction) continue;  // a body-frame constraint (add_constraints)
    partial.joint_rotations.emplace_back(j, jr.rotation);
  }
  // Every joint name is known (effectors' too): now the joint value
  // parse_query deferred.
  if (spec.joint_value_error) {
    for (const EffectorSpec& e : spec.effectors)
      (void)resolve_joint(q, path + ".effectors." + e.name, skel, e.name);
    throw *spec.joint_value_error;
  }
}

// Joints named twice through different aliases: the last wins.
void deduplicate_joint_rotations(PartialPoseSpec& partial) {
  std::vector<std::pair<int, Eigen::Quaterniond>> unique;
  for (const auto& jr : partial.joint_rotations) {
    bool replaced = false;
    for (auto& u : unique)
      if (u.first == jr.first) {
        u.second = jr.second;
        replaced = true;
      }
    if (!replaced) unique.push_back(jr);
  }
  partial.joint_rotations = std::move(unique);
}

}  // namespace

ResolvedQueryPose resolve_query_pose(const Query& q, std::size_t i, const IndexSkeleton& sk,
                                     const DynamicsModel& model, QueryBvhCache& cache,
                                     const std::string& unit_option,
                                     std::shared_ptr<const QueryBvhFile>* file,
                                     const TypicalPoseFn& typical_pose) {
  ResolvedQueryPose out;
  if (q.frames[i].bvh) {
    if (resolve_file_frame(q, i, sk, model, cache, unit_option, file, typical_pose, out))
      return out;
  } else {
    resolve_written_frame(q, i, sk.skeleton, out.given);
  }
  deduplicate_joint_rotations(out.given);
  add_constraints(q, i, sk.skeleton, model, out);
  return out;
}

void solve_given(const ResolvedQueryPose& pose, const DynamicsModel& model,
                 const Eigen::Vector3d* pos, const Eigen::Quaterniond* rot,
                 PoseConstraintScratch& scratch, std::vector<Eigen::Quaterniond>& locals,
                 PartialPoseSpec& spec, std::vector<std::uint8_t>* keep_rates) {
  if (!pose.solve) return;
  locals.resize(spec.joint_rotations.size());
  solve_pose_constraints(model.parents, model.root(), pose.constraints, pos, rot, scratch,
                         locals.data());
  for (std::size_t k = 0; k < locals.size(); ++k) spec.joint_rotations[k].second = locals[k];
  if (keep_rates == nullptr) return;
  keep_rates->resize(pose.keep_rates.size());
  for (std::size_t j = 0; j < pose.keep_rates.size(); ++j)
    (*keep_rates)[j] = pose.keep_rates[j] && !scratch.turned[j];
}

namespace search_detail {

namespace {

// One side's FrameContext of a whole file frame, or null when not asked.
std::shared_ptr<const FrameContext> frame_context(const QueryFrameSpec& spec,
                                                  const DynamicsModel& model,
                                                  const std::vector<std::uint8_t>& compared,
                                                  const ResolvedQueryPose& pose, bool before) {
  const std::vector<Eigen::Vector3d>& rows =
      before ? pose.context_before_mps : pose.context_after_mps;
  if (rows.empty()) return nullptr;
  auto c = std::make_shared<FrameContext>();
  c->rows = rows;
  c->steps = before ? spec.context_before : spec.context_after;
  c->frame_time_s = pose.context_frame_time_s;
  c->before = before;
  c->weight = spec.context_weight;
  for (const int b : model.segments) {
    const auto j = static_cast<std::size_t>(b);
    c->masses_kg.push_back(compared.empty() || compared[j] ? model.masses_kg[j] : 0.0);
  }
  return c;
}

}  // namespace

ResolvedFrame resolve_frame(const Query& q, std::size_t i, const IndexSkeleton& sk,
                            const DynamicsModel& model, double transition_time_s,
                            double index_transition_time_s, BvhCache& cache,
                            const std::string& unit_option,
                            std::shared_ptr<const QueryBvhFile>* file,
                            const TypicalPoseFn& typical_pose) {
  ResolvedQueryPose pose =
      resolve_query_pose(q, i, sk, model, cache, unit_option, file, typical_pose);
  ResolvedFrame out;
  out.root = frame_root(pose);
  out.constraints = pose.constraints;
  out.solve = pose.solve;
  out.joint_weights = pose.joint_weights;
  out.weight = pose.weight;
  if (pose.solve) out.pose = std::make_shared<const ResolvedQueryPose>(pose);
  if (pose.full) {
    out.kind = FrameKind::full;
    out.state = std::move(pose.state);
    out.compared = std::move(pose.compared_joints);
    out.scan = make_h_scan_query(model, out.state.view(), transition_time_s, out.compared);
    for (int b : model.segments) {
      const std::size_t bb = static_cast<std::size_t>(b);
      out.segment_ke_J.push_back(0.5 * model.masses_kg[bb] *
                                 out.state.com_velocities_mps[bb].squaredNorm());
    }
    out.kd.resize(kd_feature_dimension(model));
    kd_feature(model, out.state.view(), index_transition_time_s, out.kd.data());
    out.root_m = out.state.joint_positions_m[static_cast<std::size_t>(model.root())];
    out.given = {true, true, true};
    out.context_before = frame_context(q.frames[i], model, out.compared, pose, true);
    out.context_after = frame_context(q.frames[i], model, out.compared, pose, false);
    return out;
  }
  PartialPoseSpec& partial = pose.given;
  for (std::size_t a = 0; a < 3; ++a) {
    out.given[a] = partial.root_position_m[a].has_value();
    if (out.given[a]) out.root_m[static_cast<Eigen::Index>(a)] = *partial.root_position_m[a];
  }
  const bool root_only = !partial.root_heading_rad && partial.joint_rotations.empty();
  if (root_only) {
    out.kind = FrameKind::root_only;
    out.root_scan = make_h_scan_root_query(model, partial.root_position_m, transition_time_s);
  } else {
    out.kind = FrameKind::partial;
  }
  try {
    out.partial = prepare_partial_query(model, std::move(partial));
    out.partial.keep_rates = pose.keep_rates;
  } catch (const InputError& e) {
    fail(q, field(i), e.detail());
  }
  return out;
}

}  // namespace search_detail
}  // namespace mocap
