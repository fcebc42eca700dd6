#include "mocap/indexer/inspect.hpp"

#include <tbb/parallel_for.h>

#include <system_error>

#include "mocap/common/body/body.hpp"
#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/indexer/asf_pairing.hpp"

namespace mocap {

namespace {
nlohmann::json vec3(const Eigen::Vector3d& v) {
  return nlohmann::json::array({v.x(), v.y(), v.z()});
}
}  // namespace

nlohmann::json inspect_frame(const InspectOptions& opt) {
  CaptureFile file = read_capture_file(opt.file, opt.amc);
  RawClip& clip = file.clip;
  const UpAxis up = normalise_up_axis(clip, opt.up);
  if (opt.frame >= clip.frame_count)
    throw InputError(opt.file.string(), 0,
                     "frame " + std::to_string(opt.frame) + " out of range: the clip has " +
                         std::to_string(clip.frame_count) + " frames (0-based)");
  const LengthUnit unit = file.metres_per_unit ? LengthUnit::m
                          : opt.unit           ? *opt.unit
                                               : detect_unit(clip);
  const Character character = opt.character ? read_character_file(*opt.character) : Character{};
  const double scale_m = file.metres_per_unit ? *file.metres_per_unit : unit_scale_m(unit);
  const Skeleton skel = apply_length_scales(build_skeleton(clip, scale_m), character);
  const Body body = build_body(skel, character);

  LocalPose local;
  WorldPose world;
  local_pose_from_row(skel, clip.frame(opt.frame), local);
  forward_kinematics(skel, local, world);

  nlohmann::json joints = nlohmann::json::array();
  for (std::size_t j = 0; j < skel.joint_count(); ++j)
    joints.push_back({{"name", skel.names[j]},
                      {"parent", skel.parents[j]},
                      {"position_m", vec3(world.positions_m[j])}});
  nlohmann::json segments = nlohmann::json::array();
  for (const Segment& seg : body.segments) {
    if (seg.mass_kg <= 0.0) continue;
    const auto j = static_cast<std::size_t>(seg.joint);
    const Eigen::Vector3d com = world.positions_m[j] + world.rotations[j] * seg.com_local_m;
    segments.push_back({{"joint", skel.names[j]},
                        {"joint_index", seg.joint},
                        {"class", segment_class_name(seg.cls)},
                        {"side", side_name(seg.side)},
                        {"mass_kg", seg.mass_kg},
                        {"com_m", vec3(com)}});
  }
  return {{"file", opt.file.string()},
          {"frame", opt.frame},
          {"frames", clip.frame_count},
          {"frame_time_s", clip.frame_time_s},
          {"unit", file.metres_per_unit ? kAsfUnitName : unit_name(unit)},
          {"unit_scale_m", scale_m},
          {"up", up_axis_name(up)},
          {"character", character.name},
          {"total_mass_kg", body.total_mass_kg},
          {"joints", std::move(joints)},
          {"segments", std::move(segments)}};
}

std::vector<ClipSummary> summarize_files(const std::vector<std::filesystem::path>& files,
                                         std::optional<LengthUnit> unit, std::optional<UpAxis> up) {
  std::vector<ClipSummary> out(files.size());
  tbb::parallel_for(std::size_t{0}, files.size(), [&](std::size_t i) {
    ClipSummary& s = out[i];
    s.file = files[i].string();
    std::error_code ec;
    s.bytes = static_cast<std::size_t>(std::filesystem::file_size(files[i], ec));
    try {
      // AMC takes with their paired ASF at 120 fps, in the ASF's unit.
      CaptureFile file = read_capture_file(files[i], AmcReadOptions{});
      RawClip& clip = file.clip;
      normalise_up_axis(clip, up);
      const LengthUnit u = file.metres_per_unit ? LengthUnit::m : unit ? *unit : detect_unit(clip);
      s.frames = clip.frame_count;
      s.joints = clip.joints.size();
      s.frame_time_s = clip.frame_time_s;
      s.unit = file.metres_per_unit ? kAsfUnitName : unit_name(u);
      s.unit_scale_m = file.metres_per_unit ? *file.metres_per_unit : unit_scale_m(u);
      s.height_m = standing_height_file_units(clip) * s.unit_scale_m;
      s.skeleton_height_m = skeleton_height_file_units(clip) * s.unit_scale_m;
      s.ok = true;
    } catch (const InputError& e) {
      s.error = e.what();
    }
  });
  return out;
}

nlohmann::json to_json(const ClipSummary& s) {
  if (!s.ok) return {{"file", s.file}, {"ok", false}, {"error", s.error}};
  return {{"file", s.file},
          {"ok", true},
          {"frames", s.frames},
          {"joints", s.joints},
          {"frame_time_s", s.frame_time_s},
          {"duration_s", static_cast<double>(s.frames) * s.frame_time_s},
          {"unit", s.unit},
          {"unit_scale_m", s.unit_scale_m},
          {"height_m", s.height_m},
          {"skeleton_height_m", s.skeleton_height_m},
          {"bytes", s.bytes}};
}

}  // namespace mocap
