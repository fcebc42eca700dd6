#include "resolve.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numbers>

#include "mocap/common/asf_amc.hpp"
#include "mocap/common/body.hpp"
#include "mocap/common/bvh.hpp"
#include "mocap/common/error.hpp"
#include "mocap/common/input_limits.hpp"
#include "mocap/common/retarget.hpp"
#include "mocap/common/units.hpp"
#include "mocap/common/xxh64.hpp"

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
         fmt::format("unknown joint \"{}\" (valid: {}; canonical names such as RightUpperArm, "
                     "LeftForeArm, Hips also work)",
                     name, valid_joint_names(skel)));
  return j;
}

// Index-skeleton joint -> file joint: same name, else the same body part by alias.
std::vector<int> map_joints(const Query& q, const std::string& path, const IndexSkeleton& sk,
                            const DynamicsModel& model, const Skeleton& file_skel,
                            const std::filesystem::path& file) {
  const Skeleton& s = sk.skeleton;
  std::vector<int> map(s.joint_count(), -1);
  for (std::size_t j = 0; j < s.joint_count(); ++j) {
    int f = file_skel.find(s.names[j]);
    if (f < 0) f = find_joint_by_alias(file_skel, s.names[j]);
    map[j] = f;
  }
  std::string missing;
  for (int j : model.segments)
    if (map[static_cast<std::size_t>(j)] < 0)
      missing += (missing.empty() ? "" : ", ") + s.names[static_cast<std::size_t>(j)];
  if (map[static_cast<std::size_t>(sk.root_joint)] < 0 &&
      missing.find(s.names[static_cast<std::size_t>(sk.root_joint)]) == std::string::npos)
    missing += (missing.empty() ? "" : ", ") + s.names[static_cast<std::size_t>(sk.root_joint)];
  if (!missing.empty())
    fail(q, path + ".bvh",
         fmt::format("{} does not map onto the index skeleton: no joint for {} (by name or "
                     "canonical body part)",
                     file.string(), missing));
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

ResolvedQueryPose resolve_query_pose(const Query& q, std::size_t i, const IndexSkeleton& sk,
                                     const DynamicsModel& model, QueryBvhCache& cache,
                                     const std::string& unit_option,
                                     std::shared_ptr<const QueryBvhFile>* file,
                                     const TypicalPoseFn& typical_pose) {
  const QueryFrameSpec& spec = q.frames[i];
  const std::string path = field(i);
  const Skeleton& skel = sk.skeleton;
  const std::size_t nj = skel.joint_count();
  const int root = model.root();
  ResolvedQueryPose out;
  PartialPoseSpec& partial = out.given;
  if (spec.bvh) {
    out.from_bvh = true;
    std::shared_ptr<const QueryBvhFile> bvh = file != nullptr ? *file : nullptr;
    if (!bvh) {
      try {
        // The +-2 frame window below is all that is read of the file.
        bvh = spec.asf ? cache.get_amc(*spec.bvh, *spec.asf, 1.0 / spec.amc_fps)
                       : cache.get_frames(*spec.bvh, unit_option, spec.bvh_frame, 2);
      } catch (const InputError& e) {
        fail(q, path + (spec.asf ? ".amc" : ".bvh"), e.what());
      }
      if (file != nullptr) *file = bvh;
    }
    const ClipMotion& m = bvh->motion;
    if (spec.bvh_frame >= bvh->file_frame_count)
      fail(q, path + ".frame",
           fmt::format("frame {} out of range: {} has {} frames (0-based)", spec.bvh_frame,
                       spec.bvh->string(), bvh->file_frame_count));
    // A file of another rig is retargeted (retarget.hpp); else its local
    // rotations are copied.
    const std::unique_ptr<const RetargetMap> rig =
        cross_rig_map(q, path, m.skeleton, skel, typical_pose);
    const std::vector<int> map =
        rig ? rig->source_joint : map_joints(q, path, sk, model, m.skeleton, *spec.bvh);
    // Pose of the file's frames around bvh_frame on the index skeleton: the
    // file's local rotations (identity for unmapped joints), the index
    // skeleton's offsets, the file's translations where both joints have
    // position channels; across rigs, the retargeted pose. The +-2 frame
    // window gives exactly the clip's finite-difference rates at the frame
    // (dynamics.hpp).
    const std::size_t f0 = spec.bvh_frame >= 2 ? spec.bvh_frame - 2 : 0;
    const std::size_t f1 = std::min(bvh->file_frame_count - 1, spec.bvh_frame + 2);
    // Frame f of the file is row f - base of `m` (a window or the whole file).
    const std::size_t base = bvh->first_frame;
    const std::size_t n = f1 - f0 + 1;
    const std::size_t fj = m.joint_count();
    // The window's buffers, kept by the thread across calls (a query
    // resolves each frame on every skeleton of the index).
    thread_local struct {
      std::vector<Eigen::Vector3d> positions;
      std::vector<Eigen::Quaterniond> rotations;
      LocalPose local;
      WorldPose world;
      ClipDynamics dyn;
    } buffers;
    std::vector<Eigen::Vector3d>& positions = buffers.positions;
    std::vector<Eigen::Quaterniond>& rotations = buffers.rotations;
    LocalPose& local = buffers.local;
    WorldPose& world = buffers.world;
    positions.resize(n * nj);
    rotations.resize(n * nj);
    std::vector<Eigen::Quaterniond> locals_at_frame(nj);
    local.translations_m.resize(nj);
    local.rotations.resize(nj);
    for (std::size_t f = f0; f <= f1; ++f) {
      if (rig) {
        retarget_clip_frame(*rig, m, f - base, skel, local, world);
      } else {
        for (std::size_t j = 0; j < nj; ++j) {
          const int fjnt = map[j];
          const double scale = skel.translation_scales.empty() ? 1.0 : skel.translation_scales[j];
          local.rotations[j] =
              fjnt >= 0 ? m.local_rotations[(f - base) * fj + static_cast<std::size_t>(fjnt)]
                        : Eigen::Quaterniond::Identity();
          const bool file_pos =
              fjnt >= 0 && m.skeleton.channels[static_cast<std::size_t>(fjnt)].has_position();
          local.translations_m[j] =
              (file_pos && skel.channels[j].has_position())
                  ? Eigen::Vector3d(
                        m.local_translations_m[(f - base) * fj + static_cast<std::size_t>(fjnt)] *
                        scale)
                  : Eigen::Vector3d(skel.offsets_m[j] * scale);
        }
        forward_kinematics(skel, local, world);
      }
      if (f == spec.bvh_frame) locals_at_frame = local.rotations;
      std::copy(world.positions_m.begin(), world.positions_m.end(),
                positions.begin() + static_cast<std::ptrdiff_t>((f - f0) * nj));
      std::copy(world.rotations.begin(), world.rotations.end(),
                rotations.begin() + static_cast<std::ptrdiff_t>((f - f0) * nj));
    }
    ClipDynamics& dyn = buffers.dyn;
    compute_clip_dynamics(model, n, m.frame_time_s, positions.data(), rotations.data(), dyn);
    const StateView v = dyn.state(spec.bvh_frame - f0);
    const std::size_t r = static_cast<std::size_t>(root);
    out.local_rotations = locals_at_frame;
    out.file_joints = map;
    out.file_pose = ground_pose_of(v.joint_positions_m[r], v.rotations[r]);
    if (rig) {
      out.cross_rig = true;
      out.compared_joints = rig->compared;
      out.compared_classes = rig->compared_classes;
    }
    if (spec.only.empty()) {
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
        if (map[j] >= 0)
          partial.joint_rotations.emplace_back(static_cast<int>(j), locals_at_frame[j]);
      return out;
    }
    for (std::size_t k = 0; k < spec.only.size(); ++k) {
      const std::string& dof = spec.only[k];
      const std::string p = fmt::format("{}.only[{}]", path, k);
      if (dof == "root_position") {
        for (int a = 0; a < 3; ++a)
          partial.root_position_m[static_cast<std::size_t>(a)] = v.joint_positions_m[r][a];
      } else if (dof == "root_position_xz") {
        partial.root_position_m[0] = v.joint_positions_m[r][0];
        partial.root_position_m[2] = v.joint_positions_m[r][2];
      } else if (dof == "root_heading") {
        partial.root_heading_rad = heading_rad(v.rotations[r]);
      } else {
        const int j = resolve_joint(q, p, skel, dof);
        partial.joint_rotations.emplace_back(j, locals_at_frame[static_cast<std::size_t>(j)]);
      }
    }
  } else {
    partial.root_position_m = spec.root_position_m;
    if (spec.root_heading_deg)
      partial.root_heading_rad = *spec.root_heading_deg * std::numbers::pi / 180.0;
    for (const auto& jr : spec.joints) {
      const int j = resolve_joint(q, path + ".joints." + jr.name, skel, jr.name);
      partial.joint_rotations.emplace_back(j, jr.rotation);
    }
  }
  // Deduplicate joints named twice through different aliases: the last wins.
  {
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
  return out;
}

namespace search_detail {

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
  } catch (const InputError& e) {
    fail(q, field(i), e.detail());
  }
  return out;
}

}  // namespace search_detail
}  // namespace mocap
