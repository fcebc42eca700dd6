// W, the work energy (work_energy.hpp): invalid inputs, a static body held
// by the ground or by nothing, a body sliding over planted feet, its joint
// and residual terms against g's (newton_euler.hpp), invariance, units, and
// the property it is for: on real walking, running and dashing, the capture
// costs less than the glide of interpolation over the same gap.
#include "mocap/common/dynamics/work_energy.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "energy_fixtures.hpp"
#include "mocap/common/body/body.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/units.hpp"
#include "raw_clip_builder.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

constexpr double kG = 9.81;

double work(const DynamicsModel& model, const StateView& a, const StateView& b, double t,
            WorkEnergyTerms* terms = nullptr, const WorkEnergyParams& params = {}) {
  NewtonEulerData da, db;
  inverse_dynamics(model, a, da);
  inverse_dynamics(model, b, db);
  return work_energy(model, a, b, t, da, db, params, terms);
}

TEST(WorkEnergy, RejectsInvalidInputs) {
  const auto t = test::make_test_body();
  const BodyState s = test::standing_state(t);
  NewtonEulerData d;
  inverse_dynamics(t.model, s.view(), d);
  for (const double bad : {0.0, -0.1, std::nan("")})
    EXPECT_THROW(work_energy(t.model, s.view(), s.view(), bad, d, d), std::invalid_argument);
  WorkEnergyParams p;
  p.unsupported_speed_mps = -1.0;
  EXPECT_THROW(work_energy(t.model, s.view(), s.view(), 0.1, d, d, p), std::invalid_argument);
  p.unsupported_speed_mps = std::nan("");
  EXPECT_THROW(work_energy(t.model, s.view(), s.view(), 0.1, d, d, p), std::invalid_argument);
  NewtonEulerData wrong;  // not run on this model
  EXPECT_THROW(work_energy(t.model, s.view(), s.view(), 0.1, wrong, d), std::invalid_argument);
}

// Standing still on the ground costs nothing; held in the air, the whole
// weight is unsupported: v_u T M g, and nothing else.
TEST(WorkEnergy, StaticBodyCostsNothingOnTheGroundAndItsWeightInTheAir) {
  const auto t = test::make_test_body();
  const BodyState ground = test::standing_state(t);
  WorkEnergyTerms terms;
  EXPECT_NEAR(work(t.model, ground.view(), ground.view(), 0.5, &terms), 0.0, 1e-12);
  const BodyState air = test::standing_state(t, Eigen::Vector3d(0, 1.0, 0));
  const double mg = t.model.total_mass_kg * kG;
  WorkEnergyParams p;
  for (const double v : {5.0, 2.0, 0.0}) {
    p.unsupported_speed_mps = v;
    const double w = work(t.model, air.view(), air.view(), 0.25, &terms, p);
    EXPECT_NEAR(w, v * 0.25 * mg, 1e-9 * mg) << v;
    EXPECT_NEAR(terms.unsupported_J, w, 1e-12 * mg);
    EXPECT_NEAR(terms.residual_work_J, 0.0, 1e-12);
  }
}

// The whole body slid by d over the ground, feet in contact, no rotation:
// the joints do nothing, the feet's friction dissipates mu M g d.
TEST(WorkEnergy, SlidingOverPlantedFeetCostsFriction) {
  const auto t = test::make_test_body();
  const double d = 0.3;
  const BodyState a = test::standing_state(t),
                  b = test::standing_state(t, Eigen::Vector3d(d, 0, 0));
  WorkEnergyTerms terms;
  const double w = work(t.model, a.view(), b.view(), 0.5, &terms);
  const double mg = t.model.total_mass_kg * kG;
  EXPECT_NEAR(w, t.model.params.friction_coefficient * mg * d, 1e-9 * mg);
  double joints = 0.0;
  for (const double v : terms.joint_J) joints += v;
  EXPECT_NEAR(joints, 0.0, 1e-12);
  EXPECT_GT(terms.ground_J[10], 0.0);  // both feet
  EXPECT_GT(terms.ground_J[13], 0.0);
}

TEST(WorkEnergy, InvariantUnderYawAndHorizontalShift) {
  const auto t = test::make_test_body();
  std::mt19937 rng(11);
  for (int i = 0; i < 50; ++i) {
    const BodyState a = test::random_state(t, rng, 0.3, 0.2, 1.0),
                    b = test::random_state(t, rng, 0.3, 0.2, 1.0);
    const double w = work(t.model, a.view(), b.view(), 0.2);
    EXPECT_GE(w, 0.0);
    const Eigen::Quaterniond yaw(Eigen::AngleAxisd(0.3 + 0.1 * i, Eigen::Vector3d::UnitY()));
    const Eigen::Vector3d shift(-2.0 + 0.1 * i, 0.0, 0.07 * i);
    const BodyState ta = test::transform_state(a, yaw, shift),
                    tb = test::transform_state(b, yaw, shift);
    EXPECT_NEAR(work(t.model, ta.view(), tb.view(), 0.2), w, 1e-9 * (1.0 + w)) << i;
  }
}

// --- real clips ---------------------------------------------------------

struct Clip {
  ClipMotion motion;
  DynamicsModel model;
  ClipDynamics dyn;
};

Clip load_raw(const RawClip& raw, double scale_m) {
  Clip c;
  c.motion = clip_motion_from_raw(raw, scale_m);
  c.model = build_dynamics_model(c.motion.skeleton, build_body(c.motion.skeleton, Character{}));
  c.dyn = compute_clip_dynamics(c.model, c.motion);
  return c;
}

Clip load(const std::string& stem) {
  const RawClip raw =
      read_bvh_file(test::data_dir() / "bandai-namco-1" / "data" / ("dataset-1_" + stem + ".bvh"));
  return load_raw(raw, unit_scale_m(detect_unit(raw)));
}

// W of the steps first -> last of a clip's dynamics.
double clip_work(const DynamicsModel& model, const ClipDynamics& dyn, std::size_t first,
                 std::size_t last) {
  double w = 0.0;
  for (std::size_t f = first; f < last; ++f)
    w += work(model, dyn.state(f), dyn.state(f + 1), dyn.frame_time_s);
  return w;
}

// W's joint terms are g's joint work and its residual work g's, step by step.
TEST(WorkEnergy, JointAndResidualWorkAreThoseOfG) {
  MOCAP_REQUIRE_DATA();
  const Clip c = load("run_normal_001");
  NewtonEulerWorkspace ws;
  FullEnergyTerms g;
  WorkEnergyTerms w;
  for (std::size_t f = 0; f + 1 < c.dyn.frame_count; f += 3) {
    NewtonEulerData da, db;
    inverse_dynamics(c.model, c.dyn.state(f), da);
    inverse_dynamics(c.model, c.dyn.state(f + 1), db);
    full_energy(c.model, c.dyn.state(f), c.dyn.state(f + 1), c.dyn.frame_time_s, da, db, ws, &g);
    work_energy(c.model, c.dyn.state(f), c.dyn.state(f + 1), c.dyn.frame_time_s, da, db, {}, &w);
    for (std::size_t j = 0; j < w.joint_J.size(); ++j)
      EXPECT_NEAR(w.joint_J[j], g.joint_work_J[j], 1e-9 * (1.0 + g.joint_work_J[j]))
          << f << " " << j;
    EXPECT_NEAR(w.residual_work_J, g.residual_work_J, 1e-9 * (1.0 + g.residual_work_J)) << f;
  }
}

// A clip in centimetres and the same clip with every length in metres give
// the same W, step by step.
TEST(WorkEnergy, CentimetresAndMetresGiveTheSameEnergy) {
  MOCAP_REQUIRE_DATA();
  const RawClip cm =
      read_bvh_file(test::data_dir() / "bandai-namco-1" / "data" / "dataset-1_walk_normal_001.bvh");
  ASSERT_EQ(detect_unit(cm), LengthUnit::cm);
  const Clip a = load_raw(cm, 0.01), b = load_raw(test::in_metres(cm), 1.0);
  for (std::size_t f = 5; f < 60; f += 5) {
    const double wa = clip_work(a.model, a.dyn, f, f + 1);
    EXPECT_NEAR(clip_work(b.model, b.dyn, f, f + 1), wa, 1e-6 * (1.0 + wa)) << f;
  }
}

// The realism property: over a held-out gap of 31 steps, the capture costs
// less than interpolation (root and joints slerped), which glides over the
// ground: its feet slide, or leave it and leave the body unsupported.
TEST(WorkEnergy, CaptureCostsLessThanTheGlideOfInterpolation) {
  MOCAP_REQUIRE_DATA();
  for (const char* stem : {"walk_normal_001", "walk_tired_001", "run_sad_001", "dash_happy_001"}) {
    const Clip c = load(stem);
    const std::size_t n = c.motion.joint_count();
    const std::size_t a = (c.motion.frame_count - 1) * 4 / 10, b = a + 31;
    ASSERT_LT(b + 1, c.motion.frame_count) << stem;
    // Frames a-1 .. b+1: the take's own at both ends, interpolation inside.
    const std::size_t frames = b - a + 3;
    std::vector<Eigen::Vector3d> x(frames * n);
    std::vector<Eigen::Quaterniond> r(frames * n);
    LocalPose local;
    WorldPose world;
    local.translations_m.resize(n);
    local.rotations.resize(n);
    for (std::size_t i = 0; i < frames; ++i) {
      const std::size_t f = a - 1 + i;
      const double s = f <= a ? 0.0 : f >= b ? 1.0 : static_cast<double>(f - a) / (b - a);
      for (std::size_t j = 0; j < n; ++j) {
        const std::size_t ka = a * n + j, kb = b * n + j, kf = f * n + j;
        const bool inside = f > a && f < b;
        local.translations_m[j] =
            inside ? Eigen::Vector3d((1 - s) * c.motion.local_translations_m[ka] +
                                     s * c.motion.local_translations_m[kb])
                   : c.motion.local_translations_m[kf];
        local.rotations[j] =
            inside ? c.motion.local_rotations[ka].slerp(s, c.motion.local_rotations[kb])
                   : c.motion.local_rotations[kf];
      }
      forward_kinematics(c.motion.skeleton, local, world);
      std::copy(world.positions_m.begin(), world.positions_m.end(), x.begin() + i * n);
      std::copy(world.rotations.begin(), world.rotations.end(), r.begin() + i * n);
    }
    ClipDynamics glide;
    compute_clip_dynamics(c.model, frames, c.motion.frame_time_s, x.data(), r.data(), glide);
    const double w_capture = clip_work(c.model, c.dyn, a, b);
    const double w_glide = clip_work(c.model, glide, 1, frames - 2);
    EXPECT_LT(w_capture, w_glide) << stem;
    EXPECT_GT(w_capture, 0.0) << stem;
  }
}

}  // namespace
}  // namespace mocap
