#pragma once
// Internal to mocap_search: the subtree kernel, h(Q_F -> F) of partial query
// frames that give joint rotations only (no root position, no heading):
// forward kinematics of the given subtrees on F's stored pose (as
// complete_partial_query), then per segment of the subtrees the h-scan
// formula with a static A (K_A = K_A^rot = 0) against F's scan-table fields
// (COM, KE, principal orientation, KE_rot); docs/search.md "Joint-rotation
// frames"; test Search.SubtreeEnergyEqualsPartialEnergySet1. In double,
// vectorised over frames from per-joint columns (SkeletonCaches::columns).
#include <cstddef>
#include <cstdint>

#include "bounds/skeleton_tables.hpp"
#include "engine/scratch.hpp"
#include "mocap/common/io/index.hpp"
#include "query/resolved_frame.hpp"

namespace mocap::search_detail {

// Prepares q.subtree / q.subtree_segments for partial frames that give
// joint rotations only (empty otherwise), with transition time t (s), and
// loads the frame-array columns the kernel reads (ensure_columns: throws
// what the index read throws).
void set_subtree_plan(ResolvedFrame& q, const SkeletonData& skeleton, const Index& index, double t);

// h(Q_F -> F) (J) for skeleton frames [g0, g1) of a frame with a subtree plan
// (set_subtree_plan) into out[0, g1 - g0). Frames with skip[i] != 0 are left
// alone. The value of a frame does not depend on the range (exact and brute
// stay bit-identical).
void subtree_energy(const ResolvedFrame& q, const SkeletonTables& tables, std::size_t g0,
                    std::size_t g1, double* out, Scratch& scratch,
                    const std::uint8_t* skip = nullptr);

}  // namespace mocap::search_detail
