#pragma once
// The h scan's float layouts, named once for the code that writes them
// (energy.cpp: set_h_scan_frame, make_h_scan_query, place_h_scan_query) and
// the code that reads them (the scan kernels, the search's bounds and
// tables). energy.hpp's HScanTable and HScanQuery hold them.
#include <cstddef>

namespace mocap {

/// The rows of one segment in an HScanTable / HScanView: value(s, k, f) =
/// values[(s * HScanField::count + k) * stride + f].
struct HScanField {
  static constexpr std::size_t com_x = 0, com_y = 1, com_z = 2;  // COM (m)
  static constexpr std::size_t kinetic = 3;                      // translational KE 1/2 m |v|^2 (J)
  // The segment's orientation in its principal axes q = R P (w >= 0).
  static constexpr std::size_t orient_w = 4, orient_x = 5, orient_y = 6, orient_z = 7;
  static constexpr std::size_t kinetic_rot = 8;  // rotational KE 1/2 w^T I_world w (J)
  static constexpr std::size_t count = 9;
};

/// The constants of one segment in an HScanQuery: constants[s *
/// HScanConstant::count + i], float.
struct HScanConstant {
  static constexpr std::size_t com_x = 0, com_y = 1, com_z = 2;  // the query's COM (m)
  static constexpr std::size_t kinetic = 3;                      // K_A (J)
  static constexpr std::size_t mass_gravity = 4;                 // m g (N)
  static constexpr std::size_t mass_half_inv_t2 = 5;             // m / (2 T^2) (kg / s^2)
  // conj(q_A P): the query's principal axes, inverted (w x y z).
  static constexpr std::size_t conj_w = 6, conj_x = 7, conj_y = 8, conj_z = 9;
  static constexpr std::size_t kinetic_rot = 10;  // K_A^rot (J)
  // D_k / (2 T^2), k = 0..2: principal moments (kg m^2 / s^2) at moments + k.
  static constexpr std::size_t moments_half_inv_t2 = 11;
  // 0: the segment is summed; 1: left out (make_h_scan_query's compared_joints).
  // Constant 14 is unused (0).
  static constexpr std::size_t left_out = 15;
  static constexpr std::size_t count = 16;
};

}  // namespace mocap
