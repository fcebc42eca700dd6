// Retargeting poses across rigs (retarget.hpp).
#include "mocap/common/body/retarget.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <span>

#include "mocap/common/body/joint_classes.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {

namespace {

// Rest distances below this are no direction (CMU's spine child at the
// pelvis's own origin, zero-length End Sites), metres.
constexpr double kMinAxisM = 0.01;
// same_rig's tolerance on the directions of rest offsets.
constexpr double kSameRigDeg = 5.0;
// Offsets shorter than this are zero for same_rig, metres.
constexpr double kZeroOffsetM = 1e-6;

constexpr std::size_t kClasses = 14;  // SegmentClass values, none included
constexpr std::size_t kSides = 3;

using JointClasses = std::vector<std::pair<SegmentClass, Side>>;

// The first joint of each class and side, -1 where there is none.
struct Representatives {
  std::array<std::array<int, kSides>, kClasses> joint;
  Representatives() {
    for (auto& row : joint) row.fill(-1);
  }
  int operator()(SegmentClass c, Side s) const {
    return joint[static_cast<std::size_t>(c)][static_cast<std::size_t>(s)];
  }
};

Representatives representatives(const JointClasses& classes) {
  Representatives r;
  for (std::size_t j = 0; j < classes.size(); ++j) {
    const auto [c, s] = classes[j];
    if (c == SegmentClass::none) continue;
    int& slot = r.joint[static_cast<std::size_t>(c)][static_cast<std::size_t>(s)];
    if (slot < 0) slot = static_cast<int>(j);
  }
  return r;
}

// The classes a class aims at, in order of preference (retarget.hpp).
std::span<const SegmentClass> aims_of(SegmentClass c) {
  using C = SegmentClass;
  static constexpr C lower[] = {C::middle_trunk, C::upper_trunk, C::neck, C::head};
  static constexpr C middle[] = {C::upper_trunk, C::neck, C::head};
  static constexpr C upper[] = {C::neck, C::head};
  static constexpr C neck[] = {C::head};
  static constexpr C clavicle[] = {C::upper_arm, C::forearm, C::hand};
  static constexpr C upper_arm[] = {C::forearm, C::hand};
  static constexpr C forearm[] = {C::hand};
  static constexpr C thigh[] = {C::shank, C::foot, C::toes};
  static constexpr C shank[] = {C::foot, C::toes};
  static constexpr C foot[] = {C::toes};
  switch (c) {
    case C::lower_trunk:
      return lower;
    case C::middle_trunk:
      return middle;
    case C::upper_trunk:
      return upper;
    case C::neck:
      return neck;
    case C::clavicle:
      return clavicle;
    case C::upper_arm:
      return upper_arm;
    case C::forearm:
      return forearm;
    case C::thigh:
      return thigh;
    case C::shank:
      return shank;
    case C::foot:
      return foot;
    default:
      return {};
  }
}

// The sided classes whose left-right axis twists a trunk class, in order of
// preference.
std::span<const SegmentClass> side_pairs_of(SegmentClass c) {
  using C = SegmentClass;
  static constexpr C lower[] = {C::thigh, C::shank};
  static constexpr C chest[] = {C::clavicle, C::upper_arm};
  switch (c) {
    case C::lower_trunk:
      return lower;
    case C::middle_trunk:
    case C::upper_trunk:
      return chest;
    default:
      return {};
  }
}

Eigen::Vector3d scaled_offset(const Skeleton& skel, std::size_t j) {
  const double s = skel.translation_scales.empty() ? 1.0 : skel.translation_scales[j];
  return skel.offsets_m[j] * s;
}

// Rest vector from joint `from` to its descendant `to` (every rotation
// identity: the offsets along the path summed), in from's frame; nullopt
// when `to` is not below `from`.
std::optional<Eigen::Vector3d> rest_vector(const Skeleton& skel, int from, int to) {
  if (from < 0 || to < 0) return std::nullopt;
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  int j = to;
  while (j >= 0 && j != from) {
    v += scaled_offset(skel, static_cast<std::size_t>(j));
    j = skel.parents[static_cast<std::size_t>(j)];
  }
  if (j != from || to == from) return std::nullopt;
  return v;
}

Side aim_side(SegmentClass aim, Side own) {
  return is_sided(aim) ? own : Side::center;
}

// Least rotation taking unit u to unit v (any half turn when opposite).
Eigen::Quaterniond swing(const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
  return Eigen::Quaterniond::FromTwoVectors(u, v).normalized();
}

// Orthonormal frame [a, b, a x b] from a unit a and b orthogonal to it.
Eigen::Matrix3d axis_frame(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  Eigen::Matrix3d f;
  f.col(0) = a;
  f.col(1) = b;
  f.col(2) = a.cross(b);
  return f;
}

// The unit component of b orthogonal to unit a, when it is at least
// kMinAxisM long.
std::optional<Eigen::Vector3d> orthogonal_unit(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d o = b - b.dot(a) * a;
  if (o.norm() < kMinAxisM) return std::nullopt;
  return o.normalized();
}

// Thigh + shank rest lengths, mean of the sides present; 0 without legs.
double leg_length(const Skeleton& skel, const Representatives& rep) {
  double sum = 0.0;
  int sides = 0;
  for (Side s : {Side::left, Side::right}) {
    const auto thigh = rest_vector(skel, rep(SegmentClass::thigh, s), rep(SegmentClass::shank, s));
    const auto shank = rest_vector(skel, rep(SegmentClass::shank, s), rep(SegmentClass::foot, s));
    if (!thigh || !shank) continue;
    sum += thigh->norm() + shank->norm();
    ++sides;
  }
  return sides > 0 ? sum / sides : 0.0;
}

int pelvis_of(const JointClasses& classes) {
  for (std::size_t j = 0; j < classes.size(); ++j)
    if (classes[j].first == SegmentClass::lower_trunk) return static_cast<int>(j);
  return -1;
}

}  // namespace

std::string class_key_name(SegmentClass c, Side s) {
  std::string name = segment_class_name(c);
  if (is_sided(c) && s != Side::center) name = std::string(side_name(s)) + " " + name;
  return name;
}

bool same_rig(const Skeleton& a, const Skeleton& b) {
  if (a.names != b.names || a.parents != b.parents) return false;
  const JointClasses classes = classify_joints(a);
  const int pelvis = pelvis_of(classes);
  // Joints below the pelvis (all non-root joints without one).
  std::vector<std::uint8_t> below(a.joint_count(), pelvis < 0 ? 1 : 0);
  for (std::size_t j = 0; j < a.joint_count(); ++j) {
    const int p = a.parents[j];
    if (p < 0)
      below[j] = 0;
    else if (pelvis >= 0)
      below[j] = p == pelvis || below[static_cast<std::size_t>(p)];
  }
  const double min_cos = std::cos(kSameRigDeg * std::numbers::pi / 180.0);
  for (std::size_t j = 0; j < a.joint_count(); ++j) {
    if (!below[j]) continue;
    const Eigen::Vector3d oa = scaled_offset(a, j), ob = scaled_offset(b, j);
    const bool za = oa.norm() < kZeroOffsetM, zb = ob.norm() < kZeroOffsetM;
    if (za != zb) return false;
    if (!za && oa.normalized().dot(ob.normalized()) < min_cos) return false;
  }
  return true;
}

namespace {

// Per class and side: a flag (make_retarget_map's directed and compared classes).
using ClassFlags = std::array<std::array<std::uint8_t, kSides>, kClasses>;

// Target joint j, the representative of its class (c, side) following source
// joint `src`, aimed along the first class of its chain both rigs have, far
// enough below: its axes and its correction (from the aim and, for trunk
// classes, the side axis when both rigs have one; else the swing of the
// parent's correction `parent_m` onto the aim). False when the rigs share no
// aim (the joint keeps its parent's correction).
bool aim_joint(RetargetMap& m, const Skeleton& source, const Skeleton& target,
               const Representatives& rs, const Representatives& rt, std::size_t j, int src,
               SegmentClass c, Side side, const Eigen::Quaterniond& parent_m) {
  const int jt = static_cast<int>(j);
  std::optional<Eigen::Vector3d> a_t, a_s;
  for (SegmentClass aim : aims_of(c)) {
    const Side as = aim_side(aim, side);
    const auto vt = rest_vector(target, jt, rt(aim, as));
    const auto vs = rest_vector(source, src, rs(aim, as));
    if (!vt || !vs || vt->norm() < kMinAxisM || vs->norm() < kMinAxisM) continue;
    a_t = vt->normalized();
    a_s = vs->normalized();
    break;
  }
  if (!a_t) return false;
  m.directed[j] = 1;
  m.target_axis[j] = *a_t;
  m.source_axis[j] = *a_s;
  // Trunk classes: the side axis, when both rigs have one.
  std::optional<Eigen::Vector3d> b_t, b_s;
  for (SegmentClass pair : side_pairs_of(c)) {
    const auto lt = rest_vector(target, jt, rt(pair, Side::left));
    const auto rgt = rest_vector(target, jt, rt(pair, Side::right));
    const auto ls = rest_vector(source, src, rs(pair, Side::left));
    const auto rgs = rest_vector(source, src, rs(pair, Side::right));
    if (!lt || !rgt || !ls || !rgs) continue;
    b_t = orthogonal_unit(*a_t, *lt - *rgt);
    b_s = orthogonal_unit(*a_s, *ls - *rgs);
    if (b_t && b_s) break;
    b_t.reset();
    b_s.reset();
  }
  if (b_t) {
    const Eigen::Matrix3d r = axis_frame(*a_s, *b_s) * axis_frame(*a_t, *b_t).transpose();
    m.correction[j] = Eigen::Quaterniond(r).normalized();
    m.has_side_axis[j] = 1;
  } else {
    m.correction[j] = (swing(parent_m * *a_t, *a_s) * parent_m).normalized();
  }
  return true;
}

// Pass 1 of make_retarget_map (parents first): per target joint, the source
// joint it follows (its class's representative, or a joint of the same name
// and class) and its correction (its nearest following ancestor's, or its
// own aim's: aim_joint). Returns the classes aimed (directed).
ClassFlags follow_source_joints(RetargetMap& m, const Skeleton& source, const Skeleton& target,
                                const JointClasses& cs, const JointClasses& ct,
                                const Representatives& rs, const Representatives& rt) {
  ClassFlags directed_class{};
  for (std::size_t j = 0; j < target.joint_count(); ++j) {
    const auto [c, side] = ct[j];
    const int jt = static_cast<int>(j);
    // The source joint it follows.
    int src = -1;
    if (c != SegmentClass::none && rt(c, side) == jt) {
      src = rs(c, side);
    } else {
      const int f = source.find(target.names[j]);
      if (f >= 0 && cs[static_cast<std::size_t>(f)] == ct[j]) src = f;
    }
    m.source_joint[j] = src;
    if (src < 0) continue;
    // M of the nearest ancestor that follows a source joint.
    Eigen::Quaterniond parent_m = Eigen::Quaterniond::Identity();
    for (int p = target.parents[j]; p >= 0; p = target.parents[static_cast<std::size_t>(p)])
      if (m.source_joint[static_cast<std::size_t>(p)] >= 0) {
        parent_m = m.correction[static_cast<std::size_t>(p)];
        break;
      }
    m.correction[j] = parent_m;
    if (c == SegmentClass::none || rt(c, side) != jt) continue;
    if (aim_joint(m, source, target, rs, rt, j, src, c, side, parent_m))
      directed_class[static_cast<std::size_t>(c)][static_cast<std::size_t>(side)] = 1;
  }
  return directed_class;
}

// Pass 2 of make_retarget_map: compared joints, every joint of a directed
// class, then point masses (no child, no bone tip) below a compared joint
// (parents first). Returns the classes compared.
ClassFlags mark_compared_joints(RetargetMap& m, const Skeleton& target, const JointClasses& ct,
                                const ClassFlags& directed_class) {
  const std::size_t n = target.joint_count();
  for (std::size_t j = 0; j < n; ++j) {
    const auto [c, side] = ct[j];
    if (c != SegmentClass::none &&
        directed_class[static_cast<std::size_t>(c)][static_cast<std::size_t>(side)])
      m.compared[j] = 1;
  }
  std::vector<std::uint8_t> has_child(n, 0);
  for (std::size_t j = 0; j < n; ++j)
    if (target.parents[j] >= 0) has_child[static_cast<std::size_t>(target.parents[j])] = 1;
  ClassFlags compared_class = directed_class;
  for (std::size_t j = 0; j < n; ++j) {
    const int p = target.parents[j];
    const double tip =
        target.has_end_site[j]
            ? (target.end_sites_m[j] *
               (target.translation_scales.empty() ? 1.0 : target.translation_scales[j]))
                  .norm()
            : 0.0;
    if (m.compared[j] || p < 0 || has_child[j] || tip >= kZeroOffsetM ||
        ct[j].first == SegmentClass::none || !m.compared[static_cast<std::size_t>(p)])
      continue;
    m.compared[j] = 1;
    compared_class[static_cast<std::size_t>(ct[j].first)][static_cast<std::size_t>(ct[j].second)] =
        1;
  }
  return compared_class;
}

}  // namespace

RetargetMap make_retarget_map(const Skeleton& source, const Skeleton& target,
                              std::vector<Eigen::Quaterniond> typical_local) {
  if (!typical_local.empty() && typical_local.size() != target.joint_count())
    throw std::invalid_argument("make_retarget_map: one typical rotation per target joint");
  const JointClasses cs = classify_joints(source), ct = classify_joints(target);
  const Representatives rs = representatives(cs), rt = representatives(ct);
  RetargetMap m;
  m.source_joint_count = source.joint_count();
  m.target_joint_count = target.joint_count();
  m.source_pelvis = rs(SegmentClass::lower_trunk, Side::center);
  m.target_pelvis = rt(SegmentClass::lower_trunk, Side::center);
  for (const auto& [pelvis, which] :
       {std::pair{m.source_pelvis, "retargeted"}, std::pair{m.target_pelvis, "retargeted onto"}})
    if (pelvis < 0)
      throw InputError("<retarget>", 0,
                       std::string("cannot retarget across rigs: the skeleton ") + which +
                           " has no joint recognised as the pelvis (docs/body-model.md)");
  const std::size_t n = target.joint_count();
  m.source_joint.assign(n, -1);
  m.correction.assign(n, Eigen::Quaterniond::Identity());
  m.directed.assign(n, 0);
  m.target_axis.assign(n, Eigen::Vector3d::Zero());
  m.source_axis.assign(n, Eigen::Vector3d::Zero());
  m.compared.assign(n, 0);
  m.has_side_axis.assign(n, 0);
  m.typical_local = std::move(typical_local);
  for (Eigen::Quaterniond& q : m.typical_local) q.normalize();
  const ClassFlags directed_class = follow_source_joints(m, source, target, cs, ct, rs, rt);
  const ClassFlags compared_class = mark_compared_joints(m, target, ct, directed_class);
  for (SegmentClass c : kMassiveClasses)
    for (Side s : {Side::center, Side::left, Side::right})
      if (compared_class[static_cast<std::size_t>(c)][static_cast<std::size_t>(s)])
        m.compared_classes.emplace_back(c, s);
  const double ls = leg_length(source, rs), lt = leg_length(target, rt);
  if (ls > 0.0 && lt > 0.0) m.leg_length_ratio = lt / ls;
  for (SegmentClass c : {SegmentClass::foot, SegmentClass::toes})
    for (Side s : {Side::left, Side::right})
      if (rs(c, s) >= 0 && rt(c, s) >= 0) m.foot_points.emplace_back(rs(c, s), rt(c, s));
  return m;
}

void retarget_pose(const RetargetMap& map, const Skeleton& target, const WorldPose& source_world,
                   LocalPose& local, WorldPose& world) {
  const std::size_t n = target.joint_count();
  if (map.target_joint_count != n || source_world.rotations.size() != map.source_joint_count ||
      source_world.positions_m.size() != map.source_joint_count)
    throw std::invalid_argument("retarget_pose: the map was made for other skeletons");
  // World rotations, parents first.
  std::vector<Eigen::Quaterniond>& rot = world.rotations;
  std::vector<Eigen::Vector3d>& pos = world.positions_m;
  rot.resize(n);
  pos.resize(n);
  const bool typical = !map.typical_local.empty();
  for (std::size_t j = 0; j < n; ++j) {
    const int src = map.source_joint[j];
    const int p = target.parents[j];
    const Eigen::Quaterniond parent =
        p >= 0 ? rot[static_cast<std::size_t>(p)] : Eigen::Quaterniond::Identity();
    if (src >= 0 && (map.directed[j] || !typical)) {
      rot[j] =
          (source_world.rotations[static_cast<std::size_t>(src)] * map.correction[j]).normalized();
      if (typical && !map.has_side_axis[j]) {
        // Turned about its own axis a to the twist nearest the typical local
        // rotation: the twist part of L^-1 L_typ about a (R a unchanged).
        const Eigen::Quaterniond delta =
            ((parent.conjugate() * rot[j]).conjugate() * map.typical_local[j]).normalized();
        const Eigen::Vector3d& a = map.target_axis[j];
        const double theta = 2.0 * std::atan2(delta.vec().dot(a), delta.w());
        rot[j] = (rot[j] * Eigen::Quaterniond(Eigen::AngleAxisd(theta, a))).normalized();
      }
    } else {
      rot[j] = typical ? (parent * map.typical_local[j]).normalized() : parent;
    }
  }
  local.rotations.resize(n);
  local.translations_m.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const int p = target.parents[j];
    local.rotations[j] =
        p >= 0 ? (rot[static_cast<std::size_t>(p)].conjugate() * rot[j]).normalized() : rot[j];
    local.translations_m[j] = scaled_offset(target, j);
  }
  // The pelvis on the ground under the source's, then lifted (retarget.hpp).
  const auto pelvis = static_cast<std::size_t>(map.target_pelvis);
  const Eigen::Vector3d& ps = source_world.positions_m[static_cast<std::size_t>(map.source_pelvis)];
  auto place_pelvis = [&](double y) {
    const Eigen::Vector3d at(ps.x(), y, ps.z());
    const int p = target.parents[pelvis];
    local.translations_m[pelvis] =
        p >= 0 ? Eigen::Vector3d(rot[static_cast<std::size_t>(p)].conjugate() *
                                 (at - pos[static_cast<std::size_t>(p)]))
               : at;
  };
  auto positions = [&] {
    for (std::size_t j = 0; j < n; ++j) {
      const int p = target.parents[j];
      pos[j] = p >= 0 ? Eigen::Vector3d(pos[static_cast<std::size_t>(p)] +
                                        rot[static_cast<std::size_t>(p)] * local.translations_m[j])
                      : local.translations_m[j];
    }
  };
  // Joints above the pelvis do not depend on it: place it at height 0 first.
  positions();
  place_pelvis(0.0);
  positions();
  // The lowest foot point at the source's, times the leg ratio; the pelvis
  // scaled itself when the rigs have no feet in common.
  double y = map.leg_length_ratio * ps.y();
  if (!map.foot_points.empty()) {
    double low_s = std::numeric_limits<double>::infinity(), low_t = low_s;
    for (const auto& [s, t] : map.foot_points) {
      low_s = std::min(low_s, source_world.positions_m[static_cast<std::size_t>(s)].y());
      low_t = std::min(low_t, pos[static_cast<std::size_t>(t)].y());
    }
    y = map.leg_length_ratio * low_s - low_t;
  }
  place_pelvis(y);
  forward_kinematics(target, local, world);
}

namespace {

// sum_f q_f q_f^T of one joint (4 x 4, w x y z) -> its top eigenvector.
Eigen::Quaterniond top_eigenvector(const Eigen::Matrix4d& sum) {
  if (!(sum.trace() > 0.0)) return Eigen::Quaterniond::Identity();  // no frames
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(sum);
  const Eigen::Vector4d top = eig.eigenvectors().col(3);  // eigenvalues ascend
  Eigen::Quaterniond q(top[0], top[1], top[2], top[3]);
  q.normalize();
  if (q.w() < 0.0) q.coeffs() *= -1.0;
  return q;
}

void add_rotation(Eigen::Matrix4d& sum, double w, double x, double y, double z) {
  const Eigen::Vector4d v(w, x, y, z);
  sum.noalias() += v * v.transpose();
}

}  // namespace

std::vector<Eigen::Quaterniond> typical_local_rotations(std::span<const Eigen::Quaterniond> locals,
                                                        std::size_t joints) {
  std::vector<Eigen::Matrix4d> sums(joints, Eigen::Matrix4d::Zero());
  for (std::size_t i = 0; joints > 0 && i < locals.size(); ++i) {
    const Eigen::Quaterniond& q = locals[i];
    add_rotation(sums[i % joints], q.w(), q.x(), q.y(), q.z());
  }
  std::vector<Eigen::Quaterniond> out;
  for (const Eigen::Matrix4d& sum : sums) out.push_back(top_eigenvector(sum));
  return out;
}

std::vector<Eigen::Quaterniond> typical_local_rotations(const Index& index,
                                                        std::uint32_t skeleton) {
  const std::size_t n = index.skeletons().at(skeleton).skeleton.joint_count();
  std::vector<Eigen::Matrix4d> sums(n, Eigen::Matrix4d::Zero());
  index.stream_rows(skeleton, "frames", "local_rotations", 4096,
                    [&](std::uint64_t, std::uint64_t count, const float* v) {
                      for (std::uint64_t f = 0; f < count; ++f)
                        for (std::size_t j = 0; j < n; ++j) {
                          const float* q = v + (f * n + j) * 4;
                          add_rotation(sums[j], q[0], q[1], q[2], q[3]);
                        }
                    });
  std::vector<Eigen::Quaterniond> out;
  for (const Eigen::Matrix4d& sum : sums) out.push_back(top_eigenvector(sum));
  return out;
}

void retarget_clip_frame(const RetargetMap& map, const ClipMotion& source, std::size_t frame,
                         const Skeleton& target, LocalPose& local, WorldPose& world) {
  const std::size_t n = source.joint_count();
  if (frame >= source.frame_count) throw std::out_of_range("retarget_clip_frame: no such frame");
  thread_local LocalPose source_local;
  thread_local WorldPose source_world;
  const auto first = static_cast<std::ptrdiff_t>(frame * n),
             last = first + static_cast<std::ptrdiff_t>(n);
  source_local.translations_m.assign(source.local_translations_m.begin() + first,
                                     source.local_translations_m.begin() + last);
  source_local.rotations.assign(source.local_rotations.begin() + first,
                                source.local_rotations.begin() + last);
  forward_kinematics(source.skeleton, source_local, source_world);
  retarget_pose(map, target, source_world, local, world);
}

}  // namespace mocap
