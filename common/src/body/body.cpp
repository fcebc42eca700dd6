// Body building: a character's length scales applied to a skeleton, and its
// segments (mass per class shared over the class's joints by bone length,
// COM, inertia tensor) built on it.
#include "mocap/common/body/body.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <set>
#include <utility>

#include "body/anthropometry.hpp"
#include "body/joint_classifier.hpp"
#include "body/skeleton_tree.hpp"

namespace mocap {

namespace {

using detail::class_params;
using detail::classify;
using detail::ClassParams;
using detail::kZeroLength_m;
using detail::relatives;
using detail::resolve_alias;
using detail::SkeletonTree;

/// Inertia about the COM of a segment of mass m and bone `tip` (joint frame):
/// principal axes u (along the bone, radius r_long), t (medio-lateral guess,
/// r_trans) and a = u x t (antero-posterior, r_sag); I = R diag(m (r L)^2) R^T.
/// t is the joint frame's X axis made orthogonal to u, or its Z axis when the
/// bone lies within 45 degrees of X (the anatomical orientation is unknown).
Eigen::Matrix3d segment_inertia(double m, const Eigen::Vector3d& tip, const ClassParams& p) {
  const double len = tip.norm();
  if (len <= kZeroLength_m || m <= 0.0) return Eigen::Matrix3d::Zero();
  const Eigen::Vector3d u = tip / len;
  const Eigen::Vector3d ref =
      std::abs(u.x()) > std::sqrt(0.5) ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d t = (ref - ref.dot(u) * u).normalized();
  const Eigen::Vector3d a = u.cross(t);
  Eigen::Matrix3d r;
  r.col(0) = u;
  r.col(1) = t;
  r.col(2) = a;
  const Eigen::Vector3d d(m * std::pow(p.r_long * len, 2), m * std::pow(p.r_trans * len, 2),
                          m * std::pow(p.r_sag * len, 2));
  Eigen::Matrix3d inertia = r * d.asDiagonal() * r.transpose();
  return 0.5 * (inertia + inertia.transpose());
}

}  // namespace

Skeleton apply_length_scales(const Skeleton& skel, const Character& ch) {
  Skeleton out = skel;
  const std::size_t n = skel.joint_count();
  if (ch.class_length_scale.empty() && ch.joint_length_scale.empty()) return out;
  const SkeletonTree tree(skel);
  const auto classes = classify(tree);
  std::vector<double> joint_scale(n, 0.0);  // 0 = not set
  for (const auto& [name, s] : ch.joint_length_scale) {
    const int j = resolve_alias(skel, classes, name);
    if (j >= 0) joint_scale[static_cast<std::size_t>(j)] = s;
  }
  // Scale of each joint's own bone; parents come first.
  std::vector<double> scale(n, 1.0);
  for (std::size_t j = 0; j < n; ++j) {
    const SegmentClass c = classes[j].first;
    const int p = skel.parents[j];
    if (joint_scale[j] > 0.0) {
      scale[j] = joint_scale[j];
    } else if (c != SegmentClass::none) {
      const auto it = ch.class_length_scale.find(c);
      if (it != ch.class_length_scale.end()) scale[j] = it->second;
    } else if (p >= 0 && tree.offset(static_cast<int>(j)).norm() <= kZeroLength_m) {
      scale[j] = scale[static_cast<std::size_t>(p)];  // part of the parent's segment
    }
  }
  if (out.translation_scales.size() != n) out.translation_scales.assign(n, 1.0);
  for (std::size_t j = 0; j < n; ++j) {
    out.end_sites_m[j] *= scale[j];
    for (int c : tree.kids(static_cast<int>(j)))
      out.translation_scales[static_cast<std::size_t>(c)] *= scale[j];
  }
  return out;
}

Body build_body(const Skeleton& skel, const Character& ch) {
  const std::size_t n = skel.joint_count();
  const SkeletonTree tree(skel);
  const auto classes = classify(tree);
  Body body;
  body.segments.resize(n);
  std::vector<ClassParams> params(n);
  for (std::size_t j = 0; j < n; ++j) {
    Segment& seg = body.segments[j];
    seg.joint = static_cast<int>(j);
    seg.cls = classes[j].first;
    seg.side = classes[j].second;
    seg.tip_local_m = tree.tip(static_cast<int>(j));
    seg.length_m = seg.tip_local_m.norm();
    if (seg.length_m <= kZeroLength_m) {
      seg.tip_local_m.setZero();
      seg.length_m = 0.0;
    }
    params[j] = class_params(seg.cls, ch.sex);
  }

  // Mass carried by each (class, side) present on the skeleton: its table
  // share of the total mass plus the shares of absent relatives.
  using Key = std::pair<SegmentClass, Side>;
  std::map<Key, std::vector<std::size_t>> groups;
  for (std::size_t j = 0; j < n; ++j)
    if (classes[j].first != SegmentClass::none) groups[classes[j]].push_back(j);
  std::map<Key, double> carried;
  for (const auto& [key, joints] : groups) carried[key] = 0.0;
  double orphan = 0.0;  // mass with no present relative
  for (SegmentClass c : kMassiveClasses) {
    const double m = class_params(c, ch.sex).mass_fraction * ch.total_mass_kg;
    for (Side s : is_sided(c) ? std::vector<Side>{Side::left, Side::right}
                              : std::vector<Side>{Side::center}) {
      Key target{c, s};
      if (!groups.count(target)) {
        target.first = SegmentClass::none;
        for (SegmentClass rel : relatives(c)) {
          const Key k{rel, is_sided(rel) ? s : Side::center};
          if (groups.count(k)) {
            target = k;
            break;
          }
        }
      }
      if (target.first == SegmentClass::none)
        orphan += m;
      else
        carried[target] += m;
    }
  }
  double carried_sum = 0.0;
  for (const auto& [key, m] : carried) carried_sum += m;
  if (carried_sum > 0.0)
    for (auto& [key, m] : carried) m += orphan * m / carried_sum;

  // Character overrides per class, then the share of each joint by bone length.
  for (auto& [key, m] : carried) {
    if (const auto it = ch.class_mass_kg.find(key.first); it != ch.class_mass_kg.end())
      m = it->second;
    else if (const auto is = ch.class_mass_scale.find(key.first); is != ch.class_mass_scale.end())
      m *= is->second;
    const std::vector<std::size_t>& joints = groups[key];
    double total_len = 0.0;
    for (std::size_t j : joints) total_len += body.segments[j].length_m;
    for (std::size_t j : joints)
      body.segments[j].mass_kg = total_len > 0.0 ? m * body.segments[j].length_m / total_len
                                                 : m / static_cast<double>(joints.size());
  }

  // No recognised joint at all: every bone gets a length-proportional share.
  if (groups.empty()) {
    double total_len = 0.0;
    for (const Segment& seg : body.segments) total_len += seg.length_m;
    if (total_len > 0.0)
      for (Segment& seg : body.segments) seg.mass_kg = ch.total_mass_kg * seg.length_m / total_len;
  }

  // Per-joint mass overrides win over everything.
  std::set<std::string> unmatched;
  for (const auto& [name, m] : ch.joint_mass_kg) {
    const int j = resolve_alias(skel, classes, name);
    if (j < 0)
      unmatched.insert(name);
    else
      body.segments[static_cast<std::size_t>(j)].mass_kg = m;
  }
  for (const auto& [name, s] : ch.joint_length_scale)
    if (resolve_alias(skel, classes, name) < 0) unmatched.insert(name);
  body.unmatched_joints.assign(unmatched.begin(), unmatched.end());

  for (std::size_t j = 0; j < n; ++j) {
    Segment& seg = body.segments[j];
    seg.com_local_m = params[j].com_fraction * seg.tip_local_m;
    seg.inertia_local_kgm2 = segment_inertia(seg.mass_kg, seg.tip_local_m, params[j]);
    body.total_mass_kg += seg.mass_kg;
  }
  return body;
}

}  // namespace mocap
