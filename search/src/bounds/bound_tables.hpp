#pragma once
// Internal to mocap_search: the bound tables of a skeleton (docs/search.md
// "Box bounds", "Whole-body sketches", "Chain sketches"), built once from
// its h scan table, and the sketches that database and query frames share.
#include <array>
#include <cstddef>

#include "bounds/skeleton_tables.hpp"

namespace mocap::search_detail {

// Allocates the 16-frame scan tiles (zeroed) and the root positions of
// `tables` for its clips' blocks (init_skeleton_data first). They are then
// filled by set_tile_rows and set_root_rows, or set_tiles_from_table.
void init_scan_tiles(SkeletonTables& tables);

// Writes skeleton frames [first, first + count) into the tiles from `rows`:
// count rows of S x 9 scan values, frame-major (the index's h_scan layout).
void set_tile_rows(SkeletonTables& tables, std::size_t first, std::size_t count, const float* rows);

// Writes the root positions of skeleton frames [first, first + count) into
// root_positions from count rows of x, y, z.
void set_root_rows(SkeletonTables& tables, std::size_t first, std::size_t count, const float* rows);

// Every frame's scan values and root position from a field-major table of
// the skeleton's frames (a query character's, built by set_h_scan_frame).
void set_tiles_from_table(SkeletonTables& tables, const HScanTable& table);

// Fills the block and clip bound tables, the whole-body and chain
// sketches, the lane-major clip and group tables of `tables` from its
// scan tiles (SkeletonTables documents each; parallel over clips). The
// float rows used only while building are released.
void build_bound_tables(SkeletonTables& tables);

// Sketches of groups of segments (kSketchFields values each: mass-weighted
// mean COM x y z, summed KE, summed KE_rot) from per-segment values:
// com(s, axis), ke(s), rot(s), summed in double in segment order, in one pass;
// group(s) in [0, groups) is segment s's group and mass[c] group c's mass.
// Database frames and query frames are formed by this one function, as the
// bounds require. A group without mass gets a zero COM (no segment: h = 0
// there, and so is the bound).
template <class Group, class Com, class Ke, class Rot>
void group_sketches(const SkeletonTables& tables, Group group, const double* mass,
                    std::size_t groups, Com com, Ke ke, Rot rot,
                    std::array<double, kSketchFields>* out) {
  for (std::size_t c = 0; c < groups; ++c) out[c] = {};
  for (std::size_t b = 0; b < tables.segments; ++b) {
    std::array<double, kSketchFields>& v = out[group(b)];
    for (std::size_t a = 0; a < 3; ++a) v[a] += tables.masses[b] * static_cast<double>(com(b, a));
    v[3] += static_cast<double>(ke(b));
    v[4] += static_cast<double>(rot(b));
  }
  for (std::size_t c = 0; c < groups; ++c)
    if (mass[c] > 0.0)
      for (std::size_t a = 0; a < 3; ++a) out[c][a] /= mass[c];
}

// The whole body as one group.
template <class Com, class Ke, class Rot>
std::array<double, kSketchFields> whole_body_sketch(const SkeletonTables& tables, Com com, Ke ke,
                                                    Rot rot) {
  std::array<double, kSketchFields> v;
  group_sketches(
      tables, [](std::size_t) { return std::size_t{0}; }, &tables.segment_mass, 1, com, ke, rot,
      &v);
  return v;
}

// Each kinematic chain as a group (SkeletonTables::chain_of_segment): out[c], c < tables.chains.
template <class Com, class Ke, class Rot>
void chain_sketches(const SkeletonTables& tables, Com com, Ke ke, Rot rot,
                    std::array<double, kSketchFields>* out) {
  group_sketches(
      tables, [&](std::size_t b) { return static_cast<std::size_t>(tables.chain_of_segment[b]); },
      tables.chain_mass.data(), tables.chains, com, ke, rot, out);
}

}  // namespace mocap::search_detail
