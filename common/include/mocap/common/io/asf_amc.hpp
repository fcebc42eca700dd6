#pragma once
// Acclaim ASF (skeleton) and AMC (motion) reading, and their conversion to the
// offline RawClip the BVH reader makes (docs/asf-amc.md).
//
// Conventions (Acclaim, as used by the CMU database; verified against an
// independent row-vector implementation, tests/crosscheck/asf_amc_fk.py):
// - Every vector of the ASF (bone directions, root position) is in the global
//   frame of the rest pose. A bone's `axis ax ay az ORDER` gives its local
//   frame C: the rotations about the listed axes applied in ORDER (first axis
//   first), i.e. for "XYZ", on column vectors, C = Rz(az) * Ry(ay) * Rx(ax).
// - A frame's dof rotation M of a bone is composed in the same order from its
//   dof values (absent dofs are 0): "XYZ" gives M = Rz(rz) * Ry(ry) * Rx(rx).
// - A bone's transform relative to its parent, in the global rest frame, is
//   L_b = T(o_b) * C_b * M_b * C_b^-1, and world_b = world_parent * L_b, where
//   o_b (the joint's offset) is the parent bone's direction * length, or 0
//   for the root's children (they start at the root's origin). This is the
//   Acclaim spec's row-vector "v L = v C^-1 M C B" written for column
//   vectors. The bone's end (its child joints' origin) is
//   world_b * (direction_b * length_b).
// - The root: world_root = T(position + (TX, TY, TZ)) * C_root * M_root *
//   C_root^-1, with C_root from `orientation` and M_root from RX RY RZ, both in
//   the root's `axis` order.
//
// Conversion (asf_amc_to_raw_clip): one RawJoint for the root ("root") and one
// per bone, depth-first along :hierarchy (children in listed order). A bone's
// joint sits at the start of the bone: OFFSET = o_b (file units, global rest
// frame, which is also the parent joint's frame at rest, since every joint
// frame is the identity at rest). Its rotation channels are L_b's rotation
// C_b * M_b * C_b^-1 as Euler degrees "Zrotation Yrotation Xrotation" (BVH:
// R = Rz * Ry * Rx); bones without rotation dofs get no channels (L_b = I).
// The root gets "Xposition Yposition Zposition Zrotation Yrotation Xrotation"
// with the position values position + (TX, TY, TZ). Leaf bones get an End Site
// at direction * length. World positions of every joint and End Site equal the
// Acclaim definition above to rounding (~1e-12 relative): the Euler conversion
// is exact, not a fit.
//
// Units: the RawClip keeps the file's length unit (like BVH) and degrees.
// `:units length k` means a file length is (inches * k), so one file unit is
// 0.0254 / k metres (AsfSkeleton::metres_per_unit); CMU's k = 0.45 gives
// 0.0564444 m, the "cmu" LengthUnit (units.hpp, 0.056444 m) to 1e-5 relative.
//
// Errors: malformed input throws InputError naming the file, the 1-based line
// and what was expected. Files larger than input_limits().bvh_bytes and
// skeletons of more than input_limits().bvh_joints bones are refused.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "mocap/common/io/raw_clip.hpp"

namespace mocap {

/// One degree of freedom of the root (`order`) or of a bone (`dof`).
enum class AsfDof : std::uint8_t { tx, ty, tz, rx, ry, rz };

/// A dof's range from `limits (lo hi)`: degrees for rotations (converted when
/// the ASF says `angle rad`), file length units for translations; "inf" and
/// "-inf" are kept as infinities. lo <= hi is not checked (files disagree).
struct AsfLimit {
  double lo = 0.0;
  double hi = 0.0;
};

struct AsfBone {
  /// `id`; informative only (bones are referred to by name). 0 when absent.
  int id = 0;
  /// `name`, unique among the bones, never "root".
  std::string name;
  /// `direction`: the bone's direction in the global rest frame, normalised
  /// here (the file's vector is only nearly unit; a zero vector is an error
  /// unless length is 0, then it stays zero).
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  /// `length` in file length units, >= 0.
  double length = 0.0;
  /// `axis` angles about X, Y and Z in degrees (converted from radians when the
  /// ASF says `angle rad`); with axis_order they give the bone's frame C.
  Eigen::Vector3d axis_deg = Eigen::Vector3d::Zero();
  /// Axes (0 = X, 1 = Y, 2 = Z) in application order ("XYZ" = {0, 1, 2}: X
  /// first, C = Rz * Ry * Rx on column vectors). Also the order of M.
  std::array<std::uint8_t, 3> axis_order{0, 1, 2};
  /// `dof`: the order of the bone's values in AMC lines (rotations only; 0 to
  /// 3 distinct ones). Empty = the bone never moves relative to its parent.
  std::vector<AsfDof> dofs;
  /// `limits`: one per dof, or empty when the bone has none.
  std::vector<AsfLimit> limits;
  /// Index of the parent bone in AsfSkeleton::bones, -1 for a child of the root.
  int parent = -1;
  /// Line of the bone's `begin` (for messages).
  std::size_t line = 0;
};

struct AsfRoot {
  /// `order`: the root's values in AMC lines, e.g. TX TY TZ RX RY RZ (each
  /// at most once; any subset).
  std::vector<AsfDof> order;
  /// `axis`: the rotation order of orientation and of the AMC rotations, as
  /// in AsfBone::axis_order.
  std::array<std::uint8_t, 3> axis_order{0, 1, 2};
  /// `position` in file units, global frame (added to the AMC translation).
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  /// `orientation` angles about X, Y, Z in degrees: the root's frame C_root.
  Eigen::Vector3d orientation_deg = Eigen::Vector3d::Zero();
};

struct AsfSkeleton {
  /// File path, or a name for in-memory text; used in messages.
  std::string source;
  std::string version;  // `:version`, "" when absent
  std::string name;     // `:name`, "" when absent
  /// `:units mass` (informative).
  double mass = 1.0;
  /// `:units length` k > 0: a file length is inches * k (Acclaim default 1).
  double length = 1.0;
  /// `:units angle`: true for deg (the default), false for rad. Angles in
  /// this struct are degrees either way.
  bool angle_in_degrees = true;
  AsfRoot root;
  /// Bones in :bonedata order; each one is reached from the root by :hierarchy.
  std::vector<AsfBone> bones;
  /// Bone indices of the root's children, in :hierarchy order.
  std::vector<int> root_children;

  /// Metres per file length unit: 0.0254 / length.
  double metres_per_unit() const { return 0.0254 / length; }
  /// Index of the bone named exactly `name`, -1 if none.
  int find_bone(std::string_view name) const;
};

/// An AMC take, checked against its skeleton.
struct AmcMotion {
  std::string source;
  /// `:DEGREES` (the default) or `:RADIANS`; values below are degrees anyway.
  bool file_in_degrees = true;
  /// The first frame's number (usually 1); the others follow one by one.
  long first_frame_number = 1;
  std::size_t frame_count = 0;
  /// Values per frame: the root's (skeleton.root.order) then each bone's dofs,
  /// bones in AsfSkeleton::bones order. Rotations in degrees, translations in
  /// file units.
  std::size_t value_count = 0;
  /// Column of each bone's first dof within a frame row (bones order).
  std::vector<std::size_t> bone_columns;
  /// frame_count x value_count, row-major; a bone absent from a frame has 0s.
  std::vector<double> values;

  const double* frame(std::size_t f) const { return values.data() + f * value_count; }
};

/// Parses ASF text; `source` names it in messages.
AsfSkeleton parse_asf(std::string_view text, const std::string& source);
/// Parses AMC text for `skeleton` (a bone it does not have, or a line with the
/// wrong number of values, is an error).
AmcMotion parse_amc(std::string_view text, const std::string& source, const AsfSkeleton& skeleton);

/// The RawClip of a take (header comment: the conversion). `frame_time_s` > 0
/// (AMC has no rate; CMU captures at 120 fps), else std::invalid_argument.
/// RawClip::source is motion.source.
RawClip asf_amc_to_raw_clip(const AsfSkeleton& skeleton, const AmcMotion& motion,
                            double frame_time_s = 1.0 / 120.0);

/// File readers; unreadable files throw InputError(path, 0, reason).
AsfSkeleton read_asf_file(const std::filesystem::path& path);
AmcMotion read_amc_file(const std::filesystem::path& path, const AsfSkeleton& skeleton);
RawClip read_asf_amc_files(const std::filesystem::path& asf, const std::filesystem::path& amc,
                           double frame_time_s = 1.0 / 120.0);

}  // namespace mocap
