#pragma once
// Internal to mocap_search: per-thread scratch of the search (one per TBB
// worker, kept by the engine across queries: its buffers grow to the largest
// clip once instead of being allocated again for every query).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "bounds/relative_bounds.hpp"
#include "mocap/common/body/pose_constraints.hpp"
#include "mocap/common/dynamics/energy.hpp"

namespace mocap::search_detail {

struct Scratch {
  std::vector<float> fbuf;  // evaluate_h: the float scan's values
  // evaluate_h: the scan values of a range of frames copied out of the
  // tiles, HScanTable's layout with stride `gathered.stride` (the range's
  // frame count), and their root positions.
  std::vector<float> gathered_values, gathered_roots;
  HScanView gathered;
  // A clip's h values of the pair's query frames a (into F^s) and b (out of
  // F^e), their per-frame lower bounds, and the frames skipped (clip scans).
  std::vector<double> a, b, la, lb;
  std::vector<std::uint8_t> skip_a, skip_b;
  // eval_clip_blocks: per block suffix / prefix minima, needed blocks.
  std::vector<double> sb, pa;
  std::vector<std::uint8_t> need_a, need_b;
  // eval_clip_blocks: blocks the probe scanned, the computed side's running
  // minima, the second side's keys and its blocks in the order of them.
  std::vector<std::uint8_t> done_a, done_b;
  std::vector<double> run, key;
  std::vector<std::size_t> order;
  // Bounds of a clip's blocks (clip_block_bounds).
  std::vector<double> blk_a, blk_b;
  std::vector<std::uint8_t> blk_need;      // and the boxes needed (bit 0: a, bit 1: b)
  std::vector<Eigen::Quaterniond> mq, mf;  // partial bound: composite rotations
  std::vector<double> nq, nf;              // and their squared norms
  std::vector<float> lanes;                // partial_bounds_columns' per-slot lanes
  std::vector<double> subtree_lanes;       // subtree_energy's lane arrays
  // Database frames converted for partial_approximate_energy.
  std::vector<Eigen::Vector3d> pos, com, vel, angvel, zero, ltrans;
  std::vector<Eigen::Quaterniond> rot, lrot;
  BodyState state;
  HScanQuery shifted_scan;
  // Relative clip scan: per-frame bounds of a and b (relative_bounds.hpp),
  // and which a values are exact (not bounds).
  RelativeBoundFrames out_frames, in_frames;
  RootBlocks root_blocks;
  std::vector<std::uint8_t> a_exact;
  // b(e) of a placement-free Q^h+1 (its h does not depend on s), per clip
  // frame, and which of them are computed.
  std::vector<double> b_free;
  std::vector<std::uint8_t> b_free_done;
  HScanRootQuery shifted_root;
  PartialQuery shifted_partial;
  // Constrained frames: the solver's pose, the solved rotations, the terms.
  PoseConstraintScratch constraints;
  std::vector<Eigen::Quaterniond> solved;
  EnergyTerms terms;
};

}  // namespace mocap::search_detail
