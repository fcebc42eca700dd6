#pragma once
// Four-lane double vectors for the hot loops of the energy model (GCC / Clang
// vector extension): one AVX2 register in the x86-64-v3 clones of
// multiversion.hpp, two SSE2 registers in the baseline ones. The loops keep
// four joints or segments in the four lanes, gathered from and scattered to
// the per-joint Eigen arrays. Helpers take and give vectors by reference (no
// vector-ABI dependence between the clones); they are inlined.
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>

namespace mocap::lanes {

typedef double v4d __attribute__((vector_size(32)));
typedef std::int64_t v4i __attribute__((vector_size(32)));  // lane masks (0 or -1)

// GCC 12 reports false maybe-uninitialized warnings on vectors built lane by
// lane into a struct member (below, inlined into the x86-64-v3 clones).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

/// v[0] + v[1] + v[2] + v[3], added in lane order (deterministic).
inline double sum(const v4d& v) {
  return ((v[0] + v[1]) + v[2]) + v[3];
}

/// Four quaternions, lane-wise components.
struct Quat4 {
  v4d w, x, y, z;
};

/// The quaternions q[i[0]] .. q[i[3]], lane-wise.
inline void load(const Eigen::Quaterniond* q, const std::size_t (&i)[4], Quat4& out) {
  out.w = v4d{q[i[0]].w(), q[i[1]].w(), q[i[2]].w(), q[i[3]].w()};
  out.x = v4d{q[i[0]].x(), q[i[1]].x(), q[i[2]].x(), q[i[3]].x()};
  out.y = v4d{q[i[0]].y(), q[i[1]].y(), q[i[2]].y(), q[i[3]].y()};
  out.z = v4d{q[i[0]].z(), q[i[1]].z(), q[i[2]].z(), q[i[3]].z()};
}

/// Four consecutive slots k0 .. k0+3 of an index list of `count` entries:
/// the indices (slots past the end repeat the first one), how many are real,
/// and live = 1 in the real lanes, 0 in the padding (multiply masses and
/// moments by it and the padding adds exactly nothing).
struct Group {
  std::size_t idx[4];
  std::size_t count;
  v4d live;
};
inline void group(const int* list, std::size_t size, std::size_t k0, Group& g) {
  g.count = size - k0 < 4 ? size - k0 : 4;
  for (std::size_t l = 0; l < 4; ++l)
    g.idx[l] = static_cast<std::size_t>(list[l < g.count ? k0 + l : k0]);
  g.live = v4d{1.0, g.count > 1 ? 1.0 : 0.0, g.count > 2 ? 1.0 : 0.0, g.count > 3 ? 1.0 : 0.0};
}

/// q = b * conj(a) (Hamilton product), lane-wise: the rotation from a to b.
inline void mul_conj(const Quat4& b, const Quat4& a, Quat4& q) {
  q.w = b.w * a.w + b.x * a.x + b.y * a.y + b.z * a.z;
  q.x = a.w * b.x - b.w * a.x - (b.y * a.z - b.z * a.y);
  q.y = a.w * b.y - b.w * a.y - (b.z * a.x - b.x * a.z);
  q.z = a.w * b.z - b.w * a.z - (b.x * a.y - b.y * a.x);
}

/// log of unit quaternions as rotation vectors (angle x axis), lane-wise, for
/// the small rotations of one capture frame: q is first flipped to w >= 0 (the
/// short way round, in place), then for x = |v| / w < 1/8 (angle < 14 degrees)
/// log(q) = 2 v / w * atan(x) / x with the series of atan(x) / x to x^18
/// (truncation < 1e-19), the series of rotation_vector(), here evaluated in
/// Estrin's order with one division (a short dependency chain; equal to
/// rotation_vector() to round-off). Lanes where `series` is 0 (false) need
/// rotation_vector(q) instead (q as flipped here).
inline void log_small(Quat4& q, v4d& rx, v4d& ry, v4d& rz, v4i& series) {
  const v4d sign = q.w < 0.0 ? v4d{} - 1.0 : v4d{} + 1.0;
  q.w *= sign;
  q.x *= sign;
  q.y *= sign;
  q.z *= sign;
  const v4d s2 = q.x * q.x + q.y * q.y + q.z * q.z;
  const v4d inv_w = 1.0 / q.w;
  const v4d y = s2 * (inv_w * inv_w);  // x^2
  const v4d y2 = y * y, y4 = y2 * y2, y8 = y4 * y4;
  // sum_k (-1)^k y^k / (2k + 1), k = 0 .. 9, in pairs
  const v4d p01 = 1.0 + y * (-1.0 / 3.0), p23 = 1.0 / 5.0 + y * (-1.0 / 7.0);
  const v4d p45 = 1.0 / 9.0 + y * (-1.0 / 11.0), p67 = 1.0 / 13.0 + y * (-1.0 / 15.0);
  const v4d p89 = 1.0 / 17.0 + y * (-1.0 / 19.0);
  const v4d p = (p01 + y2 * p23) + y4 * (p45 + y2 * p67) + y8 * p89;
  const v4d scale = 2.0 * p * inv_w;
  rx = q.x * scale;
  ry = q.y * scale;
  rz = q.z * scale;
  series = s2 < 0.015625 * q.w * q.w;
}

/// equal = -1 in lanes where all four components of a and b are bitwise equal, else 0.
inline void same(const Quat4& a, const Quat4& b, v4i& equal) {
  equal = (a.w == b.w) & (a.x == b.x) & (a.y == b.y) & (a.z == b.z);
}

/// The rotation vectors log(b conj(a)) from a to b, lane-wise: log_small of
/// the product q (flipped to w >= 0; the lanes where `series` is 0 need
/// rotation_vector(q)), and `equal` = -1 where a and b are bitwise equal
/// (callers give exactly zero there).
inline void rotation_steps(const Quat4& a, const Quat4& b, Quat4& q, v4d& rx, v4d& ry, v4d& rz,
                           v4i& series, v4i& equal) {
  mul_conj(b, a, q);
  log_small(q, rx, ry, rz, series);
  same(a, b, equal);
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

}  // namespace mocap::lanes
