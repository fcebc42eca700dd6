#pragma once
// Internal to mocap_search: h(Q -> F) of one resolved query frame against a
// range of database frames of a skeleton, whatever the frame's kind: the
// float h scan for full and root-only frames (energy.hpp), the subtree kernel
// for joint-rotation frames (subtree_kernel.hpp), partial_approximate_energy
// on converted frame arrays for other partial frames. The value of a frame
// does not depend on the range it is evaluated in.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "bounds/skeleton_tables.hpp"
#include "engine/scratch.hpp"
#include "mocap/common/body/ground_pose.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/energy.hpp"
#include "mocap/common/io/index.hpp"
#include "query/resolved_frame.hpp"

namespace mocap::search_detail {

// h(Q -> F) (J) for skeleton frames [g0, g1) into out[0, g1 - g0), with
// transition time t (s). With `place` (relative placements) the query frame
// is in body-frame coordinates (relative_frames.hpp) and is placed on the
// ground by `place` first: full frames turned and moved, given root x/z
// components moved (and turned: both are given then), a given heading turned. Frames with skip[i]
// != 0 are left alone (partial frames only: full and root-only frames are scanned whole). With
// `tile` (a whole block in world mode: SkeletonTables::tile), the scan reads the block's tile (the
// same values, contiguous). Throws what loading the frame arrays or columns throws (InputError for
// a damaged index). A frame with q.require_met scores +inf on the frames
// that miss one of its named constraints (frame_meets).
void evaluate_h(const ResolvedFrame& q, const SkeletonData& skeleton, const Index& index, double t,
                std::size_t g0, std::size_t g1, double* out, Scratch& scratch,
                const std::optional<GroundPose>& place = std::nullopt,
                const std::uint8_t* skip = nullptr, const HScanView* tile = nullptr);

// Skeleton frame g converted into `scratch` (double, every joint): what
// evaluate_h reads of a database frame, for callers that measure it
// (residuals). Valid until `scratch` is used again.
FrameRef database_frame(const SkeletonData& skeleton, const Index& index, std::size_t g,
                        Scratch& scratch);

// Sets q.need_joints / q.local_joints: the joints partial_approximate_energy
// reads of a database frame (frame_ref) for a partial frame that does not
// move the whole body (empty, meaning all, otherwise).
void set_needed_joints(ResolvedFrame& q, const DynamicsModel& model);

}  // namespace mocap::search_detail
