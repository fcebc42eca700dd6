#pragma once
// Internal to mocap_search: the context energy of a key pose with context
// frames (docs/queries.md "Context frames"): how far a database frame's
// neighbours move otherwise than the key pose's file frames did.
//
// For a context of K rows (FrameContext) and database frame F at clip frame
// f of a clip with frame time dt_F, row j compares the query's body-frame
// segment COM velocities u_j (m/s) with the clip's at the same time from F:
//
//     C(F) = (1 / K) sum_j sum_b 1/2 m_b | u_{j,b} - R_y(-psi_F) v_{j,b} |^2   (J)
//
// where psi_F is F's root heading and v_j the clip's difference of segment
// COMs over one clip frame, o_j = round(j * dt_Q / dt_F) clip frames from F:
// before the key pose the frames (f - o_j - 1, f - o_j), after it
// (f + o_j, f + o_j + 1), moved inside the clip where they would run past
// either end (a one-frame clip moves nothing). The COMs are the h scan
// table's (SkeletonTables tiles), so every reader sees the same floats.
// C >= 0: adding it to h keeps every lower bound of h a lower bound.
#include <cstddef>
#include <cstdint>

#include "bounds/skeleton_tables.hpp"
#include "mocap/common/io/index.hpp"
#include "query/resolved_frame.hpp"

namespace mocap::search_detail {

// C(F) of skeleton frame g, unweighted (J).
double context_energy(const FrameContext& c, const SkeletonData& skeleton, const Index& index,
                      std::size_t g);

// out[i] += c.weight * C(F) for skeleton frames g0 + i in [g0, g1), except
// where skip[i] != 0 or out[i] is not finite (a frame left out stays so).
void add_context_energy(const FrameContext& c, const SkeletonData& skeleton, const Index& index,
                        std::size_t g0, std::size_t g1, double* out, const std::uint8_t* skip);

}  // namespace mocap::search_detail
