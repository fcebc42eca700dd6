#pragma once
// The cached sequence of a transition: S_-1, S_0, the inserted frames, S_G,
// S_G+1 with their world poses, states (rates by central differences),
// inverse dynamics and the g of every step S_0 -> ... -> S_G. It gives the
// transition's g (measure_transition's energy_J without the other measures)
// and recomputes locally what changes when a few consecutive inserted frames
// move (the refinement's finite differences and polishing moves).
//
// Sequence indices: 0 = S_-1, 1 = S_0, 2 .. L-3 = inserted frames 0 .. m-1,
// L-2 = S_G, L-1 = S_G+1 (L = m + 4). Step k joins states k and k + 1,
// k = 1 .. L-3. Energies in joules, positions in metres.
#include <cstddef>
#include <vector>

#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"
#include "mocap/synth/synth.hpp"

namespace mocap {

struct PathCache {
  std::vector<WorldPose> world;
  std::vector<BodyState> states;
  std::vector<NewtonEulerData> ids;
  /// steps[k]: g(state k -> state k + 1), k = 1 .. L-3 (others 0).
  std::vector<double> steps;
  NewtonEulerWorkspace ws;
  std::size_t L = 0;
  /// Joules; > 0: build() and delta() use g smoothed at this level
  /// (NewtonEulerWorkspace::smoothing_J); 0: the exact g.
  double smoothing_J = 0.0;

  /// Scratch of delta() (one per thread: delta() only reads the cache),
  /// sized for the longest run of changed frames seen.
  struct DeltaScratch {
    std::vector<WorldPose> w_changed;         // the changed frames' poses
    std::vector<BodyState> s_changed;         // their states and the two beside them
    std::vector<NewtonEulerData> id_changed;  // (count + 2 of each)
    NewtonEulerWorkspace ws;
    std::vector<double> steps_changed;  // the recomputed steps, k0 .. k1
    void reserve(std::size_t count);
  };

  /// The world poses of the sequence only (all foot_sliding() needs).
  void build_poses(const GapProblem& gap, const std::vector<SynthFrame>& frames);

  /// The world poses, then states 1 .. L-2 with central rates and their
  /// inverse dynamics (what measure_transition also needs).
  void build_states(const GapProblem& gap, const std::vector<SynthFrame>& frames);

  /// Builds the cache for `frames`; returns the transition's g (summed over
  /// steps 1 .. L-3 in order).
  double build(const GapProblem& gap, const std::vector<SynthFrame>& frames);

  /// Foot sliding of the cached transition, metres (measure_transition's).
  double foot_sliding(const GapProblem& gap) const;

  /// The same sum with changed[0 .. count) in place of the poses at sequence
  /// indices first .. first + count - 1 (the same additions in the same
  /// order: what foot_sliding() gives once those poses are applied).
  double foot_sliding_with(const GapProblem& gap, std::size_t first, std::size_t count,
                           const WorldPose* changed) const;

  /// Change of the transition's g when inserted frames i .. i + count - 1
  /// become changed[0 .. count): only states i+1 .. i+count+2 (theirs and
  /// their neighbours' rates) and the steps touching them are recomputed,
  /// into `sc`. count >= 1, i + count <= m.
  double delta(const GapProblem& gap, std::size_t i, std::size_t count, const SynthFrame* changed,
               DeltaScratch& sc) const;

  /// Makes the last delta() for inserted frames i .. i + count - 1 (computed
  /// into `sc`) the cached path: their poses, the states and the steps
  /// touching them (exact steps: the cache must not be smoothed).
  void apply(std::size_t i, std::size_t count, DeltaScratch& sc);

  /// State k of the sequence, its rates by central differences, with
  /// changed[0 .. count) in place of the world poses at first ..
  /// first + count - 1.
  void state_at(const GapProblem& gap, std::size_t k, std::size_t first, std::size_t count,
                const WorldPose* changed, BodyState& out) const;
};

}  // namespace mocap
