// Body-frame constraints on a pose (pose_constraints.hpp).
#include "mocap/common/body/pose_constraints.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "mocap/common/body/ground_pose.hpp"

namespace mocap {

namespace {

constexpr double kTiny = 1e-12;

double clamp_unit(double c) {
  return std::clamp(c, -1.0, 1.0);
}

double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  // atan2 form: accurate for small and near-pi angles alike.
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// What a constraint measures on a pose, in radians: the angle kinds' angle,
// a direction's angle from its target. Also the segment vector.
struct Measure {
  double angle = 0.0;
  Eigen::Vector3d segment = Eigen::Vector3d::Zero();
  bool valid = false;
};

Measure measure(const std::vector<int>& parents, const PoseConstraint& c, const GroundPose& body,
                const Eigen::Vector3d* pos) {
  Measure m;
  if (c.kind == PoseConstraintKind::local_rotation || c.kind == PoseConstraintKind::effector)
    return m;
  const auto j = static_cast<std::size_t>(c.joint);
  const auto e = static_cast<std::size_t>(c.end);
  m.segment = pos[e] - pos[j];
  if (m.segment.norm() < kTiny) return m;
  const Eigen::Vector3d u = m.segment.normalized();
  switch (c.kind) {
    case PoseConstraintKind::direction:
      m.angle = angle_between(u, body.turn(c.target));
      break;
    case PoseConstraintKind::sagittal_flexion: {
      const Eigen::Vector3d b = body.inverse().turn(u);
      m.angle = c.from_down ? std::atan2(b.z(), -b.y()) : std::atan2(b.z(), b.y());
      break;
    }
    case PoseConstraintKind::hinge_flexion: {
      const Eigen::Vector3d upper = pos[j] - pos[static_cast<std::size_t>(c.middle)];
      if (upper.norm() < kTiny) return m;
      m.angle = angle_between(upper, m.segment);
      break;
    }
    case PoseConstraintKind::elevation:
      m.angle = angle_between(u, -Eigen::Vector3d::UnitY());
      break;
    default:
      break;
  }
  (void)parents;
  m.valid = true;
  return m;
}

// Turns the subtree of joint j rigidly by `turn` about j's origin.
void turn_subtree(const std::vector<int>& parents, std::size_t j, const Eigen::Quaterniond& turn,
                  PoseConstraintScratch& s) {
  const std::size_t n = parents.size();
  const Eigen::Vector3d pivot = s.pos[j];
  for (std::size_t d = j; d < n; ++d) {
    const int p = parents[d];
    s.moved[d] = d == j || (p >= static_cast<int>(j) && s.moved[static_cast<std::size_t>(p)]);
    if (!s.moved[d]) continue;
    s.turned[d] = 1;
    s.pos[d] = pivot + turn * (s.pos[d] - pivot);
    s.rot[d] = (turn * s.rot[d]).normalized();
  }
}

// Reduces a signed angle change by the tolerance (0 within it).
double beyond_tolerance(double d, double tol) {
  if (std::abs(d) <= tol) return 0.0;
  return d > 0.0 ? d - tol : d + tol;
}

// A unit axis about which a positive turn takes `from` towards `to`; when
// they are (anti)parallel, one that takes `from` towards `hint`.
bool turn_axis(const Eigen::Vector3d& from, const Eigen::Vector3d& to, const Eigen::Vector3d& hint,
               Eigen::Vector3d& axis) {
  axis = from.cross(to);
  if (axis.norm() > 1e-9 * from.norm() * to.norm()) {
    axis.normalize();
    return true;
  }
  axis = from.cross(hint);
  if (axis.norm() <= 1e-9 * from.norm() * hint.norm() || axis.norm() < kTiny) return false;
  axis.normalize();
  return true;
}

// An axis that bends a straight limb `u`: towards the body-frame `hint`,
// else (the limb along it) towards body up, else towards the body's left.
bool bend_axis(const Eigen::Vector3d& u, const GroundPose& body, const Eigen::Vector3d& hint,
               Eigen::Vector3d& axis) {
  return turn_axis(u, body.turn(hint), Eigen::Vector3d::Zero(), axis) ||
         turn_axis(u, Eigen::Vector3d::UnitY(), Eigen::Vector3d::Zero(), axis) ||
         turn_axis(u, body.turn(Eigen::Vector3d::UnitX()), Eigen::Vector3d::Zero(), axis);
}

void apply_angle(const std::vector<int>& parents, const PoseConstraint& c, const GroundPose& body,
                 PoseConstraintScratch& s) {
  const Measure m = measure(parents, c, body, s.pos.data());
  if (!m.valid) return;
  const auto j = static_cast<std::size_t>(c.joint);
  const Eigen::Vector3d u = m.segment.normalized();
  Eigen::Vector3d axis;
  double turn = 0.0;
  switch (c.kind) {
    case PoseConstraintKind::direction: {
      const Eigen::Vector3d target = body.turn(c.target);
      if (!turn_axis(u, target, Eigen::Vector3d::Zero(), axis) &&
          !bend_axis(u, body, c.bend_hint, axis))
        return;
      turn = beyond_tolerance(m.angle, c.tolerance);
      break;
    }
    case PoseConstraintKind::sagittal_flexion: {
      axis = body.turn(Eigen::Vector3d::UnitX());
      const double d = beyond_tolerance(c.angle_rad - m.angle, c.tolerance);
      turn = c.from_down ? -d : d;
      break;
    }
    case PoseConstraintKind::hinge_flexion: {
      const Eigen::Vector3d upper = s.pos[j] - s.pos[static_cast<std::size_t>(c.middle)];
      if (!turn_axis(upper.normalized(), u, Eigen::Vector3d::Zero(), axis) &&
          !bend_axis(u, body, c.bend_hint, axis))
        return;
      turn = beyond_tolerance(c.angle_rad - m.angle, c.tolerance);
      break;
    }
    case PoseConstraintKind::elevation: {
      const Eigen::Vector3d down = -Eigen::Vector3d::UnitY();
      if (!turn_axis(down, u, Eigen::Vector3d::Zero(), axis) &&
          !bend_axis(u, body, c.bend_hint, axis))
        return;
      turn = beyond_tolerance(c.angle_rad - m.angle, c.tolerance);
      break;
    }
    default:
      return;
  }
  if (turn != 0.0) turn_subtree(parents, j, Eigen::Quaterniond(Eigen::AngleAxisd(turn, axis)), s);
}

void apply_effector(const std::vector<int>& parents, const PoseConstraint& c,
                    const GroundPose& body, PoseConstraintScratch& s) {
  const auto a = static_cast<std::size_t>(c.joint);
  const auto b = static_cast<std::size_t>(c.middle);
  const auto e = static_cast<std::size_t>(c.end);
  Eigen::Vector3d target = body.apply(c.target);
  const double dist = (s.pos[e] - target).norm();
  if (dist <= c.tolerance) return;
  target += (s.pos[e] - target) * (c.tolerance / dist);  // the nearest point within tolerance
  const double la = (s.pos[b] - s.pos[a]).norm(), lb = (s.pos[e] - s.pos[b]).norm();
  if (la < kTiny || lb < kTiny) return;
  // Bend at the middle joint to the distance the target asks for (within reach).
  const double lo = std::abs(la - lb) + 1e-9, hi = la + lb - 1e-9;
  if (hi > lo) {
    const double want = std::clamp((target - s.pos[a]).norm(), lo, hi);
    const double now = (s.pos[e] - s.pos[a]).norm();
    auto interior = [&](double c2) {
      return std::acos(clamp_unit((la * la + lb * lb - c2 * c2) / (2.0 * la * lb)));
    };
    const double turn = interior(now) - interior(want);  // more flexion = smaller interior angle
    Eigen::Vector3d axis;
    const Eigen::Vector3d upper = (s.pos[b] - s.pos[a]).normalized();
    const Eigen::Vector3d lower = (s.pos[e] - s.pos[b]).normalized();
    if (turn != 0.0 && (turn_axis(upper, lower, Eigen::Vector3d::Zero(), axis) ||
                        bend_axis(lower, body, c.bend_hint, axis)))
      turn_subtree(parents, b, Eigen::Quaterniond(Eigen::AngleAxisd(turn, axis)), s);
  }
  // Aim the chain at the target.
  const Eigen::Vector3d from = s.pos[e] - s.pos[a], to = target - s.pos[a];
  if (from.norm() < kTiny || to.norm() < kTiny) return;
  turn_subtree(parents, a, Eigen::Quaterniond::FromTwoVectors(from, to), s);
}

void apply_local(const std::vector<int>& parents, const PoseConstraint& c,
                 PoseConstraintScratch& s) {
  const auto j = static_cast<std::size_t>(c.joint);
  const int p = parents[j];
  const Eigen::Quaterniond want = p < 0 ? c.local : s.rot[static_cast<std::size_t>(p)] * c.local;
  turn_subtree(parents, j, (want * s.rot[j].conjugate()).normalized(), s);
}

}  // namespace

std::vector<int> driven_joints(const std::vector<PoseConstraint>& constraints,
                               std::size_t joint_count) {
  std::vector<std::uint8_t> seen(joint_count, 0);
  std::vector<int> out;
  auto add = [&](int j) {
    if (j < 0 || static_cast<std::size_t>(j) >= joint_count)
      throw std::invalid_argument("driven_joints: joint out of range");
    if (seen[static_cast<std::size_t>(j)])
      throw std::invalid_argument("driven_joints: a joint is driven twice");
    seen[static_cast<std::size_t>(j)] = 1;
    out.push_back(j);
  };
  for (const PoseConstraint& c : constraints) {
    add(c.joint);
    if (c.kind == PoseConstraintKind::effector) add(c.middle);
  }
  std::sort(out.begin(), out.end());
  return out;
}

void sort_constraints(std::vector<PoseConstraint>& constraints) {
  std::stable_sort(
      constraints.begin(), constraints.end(),
      [](const PoseConstraint& a, const PoseConstraint& b) { return a.joint < b.joint; });
}

void solve_pose_constraints(const std::vector<int>& parents, int root,
                            const std::vector<PoseConstraint>& constraints,
                            const Eigen::Vector3d* pos, const Eigen::Quaterniond* rot,
                            PoseConstraintScratch& scratch, Eigen::Quaterniond* locals) {
  const std::size_t n = parents.size();
  scratch.pos.assign(pos, pos + n);
  scratch.rot.assign(rot, rot + n);
  scratch.moved.assign(n, 0);
  scratch.turned.assign(n, 0);
  const auto r = static_cast<std::size_t>(root);
  const GroundPose body = ground_pose_of(pos[r], rot[r]);
  for (const PoseConstraint& c : constraints) {
    switch (c.kind) {
      case PoseConstraintKind::local_rotation:
        apply_local(parents, c, scratch);
        break;
      case PoseConstraintKind::effector:
        apply_effector(parents, c, body, scratch);
        break;
      default:
        apply_angle(parents, c, body, scratch);
        break;
    }
  }
  // The driven joints' local rotations, in index order (a given local
  // rotation exactly as given).
  auto& driven = scratch.driven;
  driven.clear();
  for (const PoseConstraint& c : constraints) {
    driven.emplace_back(c.joint, &c);
    if (c.kind == PoseConstraintKind::effector) driven.emplace_back(c.middle, nullptr);
  }
  std::sort(driven.begin(), driven.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (std::size_t i = 0; i < driven.size(); ++i) {
    const auto j = static_cast<std::size_t>(driven[i].first);
    const PoseConstraint* c = driven[i].second;
    if (c != nullptr && c->kind == PoseConstraintKind::local_rotation) {
      locals[i] = c->local.normalized();
      continue;
    }
    const int p = parents[j];
    locals[i] =
        p < 0
            ? scratch.rot[j]
            : (scratch.rot[static_cast<std::size_t>(p)].conjugate() * scratch.rot[j]).normalized();
  }
}

double constraint_residual(const std::vector<int>& parents, int root, const PoseConstraint& c,
                           const Eigen::Vector3d* pos, const Eigen::Quaterniond* rot) {
  const auto r = static_cast<std::size_t>(root);
  const GroundPose body = ground_pose_of(pos[r], rot[r]);
  constexpr double deg = 180.0 / std::numbers::pi;
  switch (c.kind) {
    case PoseConstraintKind::effector:
      return (pos[static_cast<std::size_t>(c.end)] - body.apply(c.target)).norm();
    case PoseConstraintKind::local_rotation: {
      const auto j = static_cast<std::size_t>(c.joint);
      const int p = parents[j];
      const Eigen::Quaterniond local =
          p < 0 ? rot[j] : rot[static_cast<std::size_t>(p)].conjugate() * rot[j];
      return local.normalized().angularDistance(c.local.normalized()) * deg;
    }
    case PoseConstraintKind::direction: {
      const Measure m = measure(parents, c, body, pos);
      return m.valid ? m.angle * deg : 180.0;
    }
    default: {
      const Measure m = measure(parents, c, body, pos);
      return m.valid ? std::abs(m.angle - c.angle_rad) * deg : 180.0;
    }
  }
}

}  // namespace mocap
