#pragma once
// Private to common/src/dynamics: what the step A -> B does to a contact point
// and a body root's residual wrench, shared by g (newton_euler.cpp) and W
// (work_energy.cpp) so that both price the same sliding and the same residual.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>

#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"

namespace mocap::detail {

/// Displacement (m, world) over the step of segment j's contact point,
/// carried rigidly with the segment from the state where it touches (A when
/// it touches in A, else B) to the other. j must touch in A or in B.
inline Eigen::Vector3d contact_slide(const StateView& a, const StateView& b,
                                     const NewtonEulerData& da, const NewtonEulerData& db,
                                     std::size_t j) {
  if (da.in_contact[j]) {
    const Eigen::Vector3d& p = da.contact_points_m[j];
    return b.coms_m[j] + (b.rotations[j] * a.rotations[j].conjugate()) * (p - a.coms_m[j]) - p;
  }
  const Eigen::Vector3d& p = db.contact_points_m[j];
  return p - (a.coms_m[j] + (a.rotations[j] * b.rotations[j].conjugate()) * (p - b.coms_m[j]));
}

/// Body root j's residual wrench, the mean of A and B: force (N) and moment
/// about the root's COM (N m).
struct MeanWrench {
  Eigen::Vector3d force_N;
  Eigen::Vector3d moment_Nm;
};
inline MeanWrench mean_residual_wrench(const StateView& a, const StateView& b,
                                       const NewtonEulerData& da, const NewtonEulerData& db,
                                       std::size_t j) {
  return {0.5 * (da.joint_forces_N[j] + db.joint_forces_N[j]),
          0.5 * (da.joint_torques_Nm[j] +
                 (a.joint_positions_m[j] - a.coms_m[j]).cross(da.joint_forces_N[j]) +
                 db.joint_torques_Nm[j] +
                 (b.joint_positions_m[j] - b.coms_m[j]).cross(db.joint_forces_N[j]))};
}

}  // namespace mocap::detail
