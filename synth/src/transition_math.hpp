// The small rotation and interpolation steps every transition method shares
// (private to synth/src): exp / log of rotations, the checks of a gap, the
// geodesic (slerp) frame and the cubic Hermite step.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>

#include "mocap/synth/synth.hpp"

namespace mocap::synth_detail {

/// exp of a rotation vector (rad): the unit quaternion turning |v| about v;
/// identity below 1e-12 rad.
Eigen::Quaterniond quat_exp(const Eigen::Vector3d& v);

/// log(a^-1 b) in a's local frame: the rotation vector (rad) taking a to b.
Eigen::Vector3d local_log(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

/// std::invalid_argument unless the gap has a skeleton, a finite frame time
/// > 0, four frames of the skeleton's joint count and (if any) a range of
/// motion of that joint count.
void check_gap(const GapProblem& gap);

/// The frame a fraction `s` (0: `from`, 1: `to`) of the way from `from` to
/// `to`: root position linear, each joint's local rotation slerped and
/// normalised; `out` is reused (its rotations resized to `from`'s count).
/// The slerp baseline, the A* base proposal and its lookahead all use it.
void geodesic_frame(const SynthFrame& from, const SynthFrame& to, double s, SynthFrame& out);

/// The geodesic step from `cur` toward the gap's goal: 1 / remaining of the
/// way (remaining >= 1 steps left).
SynthFrame geodesic_step(const GapProblem& gap, const SynthFrame& cur, std::size_t remaining);

/// The first step of the cubic Hermite path from `cur` (its velocity from
/// `prev`) to the goal (its velocity toward S_G+1) over `remaining` steps:
/// root in world space, each joint as a rotation vector about the goal's
/// local rotation. The velocity-continuing variant of the A* proposals.
SynthFrame hermite_step(const GapProblem& gap, const SynthFrame& prev, const SynthFrame& cur,
                        std::size_t remaining);

}  // namespace mocap::synth_detail
