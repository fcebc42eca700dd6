// Recursive Newton-Euler against closed-form (Lagrangian) torques, contacts,
// and the full energy change g on hand-built bodies.
#include "mocap/common/dynamics/newton_euler.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "energy_fixtures.hpp"

namespace mocap {
namespace {

constexpr double kG = 9.81;

double rel_err(double got, double want) {
  return std::abs(got - want) / std::max(1.0, std::abs(want));
}

// ---------------------------------------------------------------- pendulum

struct Pendulum {
  double m = 3.0, l = 0.7, ic = 0.04;
  DynamicsModel model;
  Pendulum() {
    const Skeleton s = test::make_skeleton({"p"}, {-1}, {{0, 10, 0}});
    Body b;
    b.segments = {test::make_segment(0, m, {0, -l, 0}, {0, -2 * l, 0}, {0.2, 0.05, ic})};
    model = build_dynamics_model(s, b);
  }
};

TEST(NewtonEuler, SinglePendulumMatchesLagrangian) {
  const Pendulum p;
  NewtonEulerData data;
  BodyState state;
  JointMotion motion;
  motion.resize(1);
  for (double theta : {-2.5, -0.4, 0.0, 0.3, 1.2, 3.0})
    for (double rate : {-4.0, 0.0, 1.5})
      for (double acc : {-7.0, 0.0, 2.0}) {
        const Eigen::Vector3d x(0, 10, 0);
        const Eigen::Quaterniond r(Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()));
        motion.relative_angular_velocities_radps[0] = rate * Eigen::Vector3d::UnitZ();
        motion.relative_angular_accelerations_radps2[0] = acc * Eigen::Vector3d::UnitZ();
        rnea_forward(p.model, PoseView{&x, &r}, motion, data, state);
        inverse_dynamics(p.model, state.view(), data);
        const double want = (p.ic + p.m * p.l * p.l) * acc + p.m * kG * p.l * std::sin(theta);
        // The pivot (the world) is the pendulum's "parent": its torque is the root residual.
        const Eigen::Vector3d n = data.joint_torques_Nm[0];
        EXPECT_LT(rel_err(n.z(), want), 1e-9) << theta << " " << rate << " " << acc;
        EXPECT_LT(std::abs(n.x()) + std::abs(n.y()), 1e-9);
        // Pivot force: m (a_c - g), a_c from the closed form of circular motion.
        const Eigen::Vector3d radial(std::sin(theta), -std::cos(theta), 0.0);
        const Eigen::Vector3d tangent(std::cos(theta), std::sin(theta), 0.0);
        const Eigen::Vector3d a_c = p.l * acc * tangent - p.l * rate * rate * radial;
        EXPECT_LT((data.joint_forces_N[0] - p.m * (a_c - Eigen::Vector3d(0, -kG, 0))).norm(),
                  1e-9 * (1.0 + p.m * kG));
        EXPECT_EQ(data.contact_count, 0u);
      }
}

// ---------------------------------------------------------------- two-link chain

struct TwoLink {
  double m1 = 2.0, m2 = 1.3, l1 = 0.5, l2 = 0.45, lc1 = 0.22, lc2 = 0.2, i1 = 0.05, i2 = 0.03;
  DynamicsModel model;
  TwoLink() {
    const Skeleton s = test::make_skeleton({"a", "b"}, {-1, 0}, {{0, 10, 0}, {l1, 0, 0}});
    Body b;
    b.segments = {test::make_segment(0, m1, {lc1, 0, 0}, {l1, 0, 0}, {0.01, 0.06, i1}),
                  test::make_segment(1, m2, {lc2, 0, 0}, {l2, 0, 0}, {0.004, 0.07, i2})};
    model = build_dynamics_model(s, b);
  }
  // Closed-form torques (Lagrange), gravity -y, angles about +z from +x.
  Eigen::Vector2d torques(double q1, double q2, double d1, double d2, double a1, double a2) const {
    const double c2 = std::cos(q2), s2 = std::sin(q2);
    const double m11 = i1 + i2 + m1 * lc1 * lc1 + m2 * (l1 * l1 + lc2 * lc2 + 2 * l1 * lc2 * c2);
    const double m12 = i2 + m2 * (lc2 * lc2 + l1 * lc2 * c2);
    const double m22 = i2 + m2 * lc2 * lc2;
    const double h = m2 * l1 * lc2 * s2;
    const double g1 = (m1 * lc1 + m2 * l1) * kG * std::cos(q1) + m2 * lc2 * kG * std::cos(q1 + q2);
    const double g2 = m2 * lc2 * kG * std::cos(q1 + q2);
    return {m11 * a1 + m12 * a2 - h * (2 * d1 * d2 + d2 * d2) + g1,
            m12 * a1 + m22 * a2 + h * d1 * d1 + g2};
  }
  void pose(double q1, double q2, Eigen::Vector3d* x, Eigen::Quaterniond* r) const {
    x[0] = Eigen::Vector3d(0, 10, 0);
    r[0] = Eigen::Quaterniond(Eigen::AngleAxisd(q1, Eigen::Vector3d::UnitZ()));
    x[1] = x[0] + r[0] * Eigen::Vector3d(l1, 0, 0);
    r[1] = r[0] * Eigen::Quaterniond(Eigen::AngleAxisd(q2, Eigen::Vector3d::UnitZ()));
  }
};

TEST(NewtonEuler, TwoLinkChainMatchesLagrangian) {
  const TwoLink c;
  NewtonEulerData data;
  BodyState state;
  JointMotion motion;
  motion.resize(2);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int i = 0; i < 200; ++i) {
    const double q1 = u(rng), q2 = u(rng), d1 = u(rng), d2 = u(rng), a1 = 3 * u(rng),
                 a2 = 3 * u(rng);
    Eigen::Vector3d x[2];
    Eigen::Quaterniond r[2];
    c.pose(q1, q2, x, r);
    motion.relative_angular_velocities_radps[0] = d1 * Eigen::Vector3d::UnitZ();
    motion.relative_angular_velocities_radps[1] = d2 * Eigen::Vector3d::UnitZ();
    motion.relative_angular_accelerations_radps2[0] = a1 * Eigen::Vector3d::UnitZ();
    motion.relative_angular_accelerations_radps2[1] = a2 * Eigen::Vector3d::UnitZ();
    rnea_forward(c.model, PoseView{x, r}, motion, data, state);
    inverse_dynamics(c.model, state.view(), data);
    const Eigen::Vector2d want = c.torques(q1, q2, d1, d2, a1, a2);
    EXPECT_LT(rel_err(data.joint_torques_Nm[0].z(), want[0]), 1e-9) << i;
    EXPECT_LT(rel_err(data.joint_torques_Nm[1].z(), want[1]), 1e-9) << i;
    EXPECT_LT(data.joint_torques_Nm[1].head<2>().norm(), 1e-9);
  }
}

TEST(NewtonEuler, TwoLinkFromFiniteDifferencesConverges) {
  // The same chain sampled at 240 Hz: clip dynamics by finite differences give
  // the closed-form torques to O(dt^2).
  const TwoLink c;
  const double dt = 1.0 / 240.0;
  const std::size_t frames = 200;
  auto q1 = [](double t) { return 0.3 + 0.8 * std::sin(2 * t); };
  auto q2 = [](double t) { return 0.5 + 0.6 * std::cos(3 * t); };
  std::vector<Eigen::Vector3d> xs(2 * frames);
  std::vector<Eigen::Quaterniond> rs(2 * frames);
  for (std::size_t f = 0; f < frames; ++f) {
    const double t = static_cast<double>(f) * dt;
    c.pose(q1(t), q2(t), &xs[2 * f], &rs[2 * f]);
  }
  ClipDynamics d;
  compute_clip_dynamics(c.model, frames, dt, xs.data(), rs.data(), d);
  NewtonEulerData data;
  for (std::size_t f = 5; f + 5 < frames; f += 7) {
    const double t = static_cast<double>(f) * dt;
    const double d1 = 1.6 * std::cos(2 * t), a1 = -3.2 * std::sin(2 * t);
    const double d2 = -1.8 * std::sin(3 * t), a2 = -5.4 * std::cos(3 * t);
    inverse_dynamics(c.model, d.state(f), data);
    const Eigen::Vector2d want = c.torques(q1(t), q2(t), d1, d2, a1, a2);
    EXPECT_NEAR(data.joint_torques_Nm[0].z(), want[0], 1e-3 * (1.0 + std::abs(want[0]))) << f;
    EXPECT_NEAR(data.joint_torques_Nm[1].z(), want[1], 1e-3 * (1.0 + std::abs(want[1]))) << f;
  }
}

// ---------------------------------------------------------------- 3-D tree

TEST(NewtonEuler, RecursionEqualsDirectSubtreeSums) {
  // Lifted off the ground (no contact): f_j = sum over the subtree of F_k and
  // n_j = sum over the subtree of tau_k + (c_k - x_j) x F_k.
  const auto t = test::make_test_body();
  std::mt19937 rng(4);
  NewtonEulerData data;
  const std::size_t n = t.model.joint_count();
  for (int i = 0; i < 50; ++i) {
    BodyState s = test::random_state(t, rng);
    s = test::transform_state(s, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 5, 0));
    inverse_dynamics(t.model, s.view(), data);
    ASSERT_EQ(data.contact_count, 0u);
    for (std::size_t j = 1; j < n; ++j) {
      Eigen::Vector3d f = Eigen::Vector3d::Zero(), tq = Eigen::Vector3d::Zero();
      for (std::size_t k = j; k < n; ++k) {
        bool below = false;
        for (int a = static_cast<int>(k); a >= 0;
             a = t.skeleton.parents[static_cast<std::size_t>(a)])
          if (a == static_cast<int>(j)) below = true;
        if (!below || !(t.model.masses_kg[k] > 0.0)) continue;
        const double m = t.model.masses_kg[k];
        const Eigen::Matrix3d r = s.rotations[k].toRotationMatrix();
        const Eigen::Matrix3d in = r * t.model.inertias_local_kgm2[k] * r.transpose();
        const Eigen::Vector3d fk = m * (s.com_accelerations_mps2[k] - Eigen::Vector3d(0, -kG, 0));
        const Eigen::Vector3d& w = s.angular_velocities_radps[k];
        f += fk;
        tq += in * s.angular_accelerations_radps2[k] + w.cross(in * w) +
              (s.coms_m[k] - s.joint_positions_m[j]).cross(fk);
      }
      EXPECT_LT((data.joint_forces_N[j] - f).norm(), 1e-9 * (1.0 + f.norm())) << j;
      EXPECT_LT((data.joint_torques_Nm[j] - tq).norm(), 1e-9 * (1.0 + tq.norm())) << j;
    }
    // The root residual is the whole requirement about the COM.
    EXPECT_LT((data.residual_force_N - data.joint_forces_N[1]).norm(),
              1e-9 * (1.0 + data.residual_force_N.norm()));
  }
}

// ---------------------------------------------------------------- contact

// The test body's rest pose stands with both foot tips on the ground (y = 0).
TEST(Contact, StaticStandingPoseIsFullySupported) {
  const auto t = test::make_test_body();
  const BodyState s = test::standing_state(t);
  NewtonEulerData data;
  inverse_dynamics(t.model, s.view(), data);
  EXPECT_EQ(data.contact_count, 2u);  // the two feet
  EXPECT_TRUE(data.in_contact[10]);
  EXPECT_TRUE(data.in_contact[13]);
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (const auto& f : data.contact_forces_N) total += f;
  EXPECT_LT((total - Eigen::Vector3d(0, t.model.total_mass_kg * kG, 0)).norm(), 1e-9);
  EXPECT_LT(data.residual_force_N.norm(), 1e-9);
  EXPECT_LT(data.residual_torque_Nm.norm(), 1e-9);
  // g(A, A) = 0 for a static, supported pose; h(A, A) = 0 too.
  NewtonEulerWorkspace ws;
  EXPECT_EQ(approximate_energy(t.model, s.view(), s.view(), 0.5), 0.0);
  EXPECT_NEAR(full_energy(t.model, s.view(), s.view(), 0.5, ws), 0.0, 1e-12);
}

TEST(Contact, UnsupportedBodyPaysForItsResidual) {
  const auto t = test::make_test_body();
  const BodyState s = test::standing_state(t, Eigen::Vector3d(0, 1.0, 0));
  NewtonEulerData data;
  inverse_dynamics(t.model, s.view(), data);
  EXPECT_EQ(data.contact_count, 0u);
  const double mg = t.model.total_mass_kg * kG;
  EXPECT_LT((data.residual_force_N - Eigen::Vector3d(0, mg, 0)).norm(), 1e-9);
  NewtonEulerWorkspace ws;
  FullEnergyTerms terms;
  const double tt = 0.5;
  const double g = full_energy(t.model, s.view(), s.view(), tt, ws, &terms);
  // T^2/2 |F_res|^2 / M (the residual torque about the COM is zero for a static body).
  EXPECT_NEAR(g, 0.5 * tt * tt * mg * mg / t.model.total_mass_kg, 1e-6);
  EXPECT_NEAR(terms.residual_impulse_J, g, 1e-12);
}

TEST(Contact, DetectionNeedsLowAndSlow) {
  const auto t = test::make_test_body();
  BodyState s = test::standing_state(t);
  s.com_velocities_mps[10] = Eigen::Vector3d(2.0, 0, 0);  // left foot fast: not a contact
  NewtonEulerData data;
  inverse_dynamics(t.model, s.view(), data);
  EXPECT_FALSE(data.in_contact[10]);
  EXPECT_TRUE(data.in_contact[13]);
  const BodyState high = test::standing_state(t, Eigen::Vector3d(0, 0.2, 0));
  inverse_dynamics(t.model, high.view(), data);
  EXPECT_EQ(data.contact_count, 0u);
}

TEST(Contact, SlidingFootCostsFriction) {
  const auto t = test::make_test_body();
  const BodyState a = test::standing_state(t);
  BodyState b = a;
  const Eigen::Vector3d slide(0.03, 0, 0);
  for (int j : {10}) {
    b.joint_positions_m[static_cast<std::size_t>(j)] += slide;
    b.coms_m[static_cast<std::size_t>(j)] += slide;
  }
  NewtonEulerWorkspace ws;
  FullEnergyTerms terms;
  const double g = full_energy(t.model, a.view(), b.view(), 0.5, ws, &terms);
  const double normal = 0.5 * t.model.total_mass_kg * kG;  // half the weight on each foot
  EXPECT_NEAR(terms.contact_work_J[10], 0.8 * normal * 0.03, 1e-9);
  EXPECT_GT(g, approximate_energy(t.model, a.view(), b.view(), 0.5) + 0.8 * normal * 0.03 - 1e-9);
}

TEST(Contact, ResidualImpulseCoefficientMatchesCompositeInertiaReference) {
  // inverse_dynamics forms I_G in its one pass (moments about a reference
  // point, shifted to the COM); composite_inertia sums it directly.
  const auto t = test::make_test_body();
  std::mt19937 rng(9);
  NewtonEulerData data;
  int with_torque = 0;
  for (int i = 0; i < 200; ++i) {
    BodyState s = test::random_state(t, rng);
    if (i % 4 == 0) s = test::standing_state(t, Eigen::Vector3d(0.3 * i, 0.02 * (i % 7), -0.1 * i));
    inverse_dynamics(t.model, s.view(), data);
    const double mass = t.model.total_mass_kg;
    double e = data.residual_force_N.squaredNorm() / mass;
    const double negligible = 1e-9 * mass * kG;
    if (data.residual_torque_Nm.squaredNorm() > negligible * negligible) {
      ++with_torque;
      const Eigen::Matrix3d i_g = composite_inertia(t.model, s.view(), data.com_m);
      const Eigen::Matrix3d reg = i_g + 1e-9 * i_g.trace() * Eigen::Matrix3d::Identity();
      e += data.residual_torque_Nm.dot(reg.ldlt().solve(data.residual_torque_Nm));
    }
    EXPECT_NEAR(data.residual_impulse_coefficient_Jps2, e, 1e-9 * (1.0 + e)) << i;
  }
  EXPECT_GT(with_torque, 100);
}

// ---------------------------------------------------------------- g

TEST(FullEnergy, AtLeastHAndTermsAddUp) {
  const auto t = test::make_test_body();
  std::mt19937 rng(5);
  NewtonEulerWorkspace ws;
  FullEnergyTerms terms;
  for (int i = 0; i < 300; ++i) {
    BodyState a = test::random_state(t, rng), b = test::random_state(t, rng);
    if (i % 3 == 0) a.set_rates_zero();
    const double tt = 0.05 + 0.003 * i;
    const double g = full_energy(t.model, a.view(), b.view(), tt, ws, &terms);
    const double h = approximate_energy(t.model, a.view(), b.view(), tt);
    EXPECT_GE(h, 0.0);
    EXPECT_GE(g, h);
    EXPECT_NEAR(terms.h.total(), h, 1e-9 * (1.0 + h));
    EXPECT_NEAR(terms.g.total(), g, 1e-9 * (1.0 + g));
    for (std::size_t j = 0; j < t.model.joint_count(); ++j) {
      EXPECT_GE(terms.g.segment_J[j], terms.h.segment_J[j]);
      EXPECT_GE(terms.g.joint_J[j], terms.h.joint_J[j]);
    }
  }
}

TEST(FullEnergy, SmoothingUnderestimatesAndConvergesToExact) {
  // The refinement's smoothed g: 0 is the exact g bit for bit; s > 0 is below
  // it, by at most s per smoothed term (about 10 per joint), and rises as s
  // shrinks (every sqrt(x^2 + s^2) - s falls with s).
  const auto t = test::make_test_body();
  const double bound_terms = 10.0 * static_cast<double>(t.model.joint_count());
  std::mt19937 rng(9);
  NewtonEulerWorkspace exact_ws, ws;
  for (int i = 0; i < 100; ++i) {
    // Near the ground in half the cases, so that contact terms take part.
    const BodyState a = i % 2 ? test::random_state(t, rng, 0.3, 0.2, 1.0)
                              : test::random_state(t, rng),
                    b = i % 2 ? test::random_state(t, rng, 0.3, 0.2, 1.0)
                              : test::random_state(t, rng);
    const double g = full_energy(t.model, a.view(), b.view(), 0.1, exact_ws);
    ws.smoothing_J = 0.0;
    EXPECT_EQ(full_energy(t.model, a.view(), b.view(), 0.1, ws), g) << i;
    double previous = g;
    for (double s : {0.01, 0.1, 1.0}) {
      ws.smoothing_J = s;
      const double gs = full_energy(t.model, a.view(), b.view(), 0.1, ws);
      EXPECT_LE(gs, previous + 1e-12 * g) << i << " s " << s;
      EXPECT_GE(gs, g - bound_terms * s) << i << " s " << s;
      previous = gs;
    }
  }
}

TEST(FullEnergy, InvariantUnderYawAndHorizontalShift) {
  const auto t = test::make_test_body();
  std::mt19937 rng(6);
  NewtonEulerWorkspace ws;
  for (int i = 0; i < 50; ++i) {
    // Near the ground so that contacts take part.
    const BodyState a = test::random_state(t, rng, 0.3, 0.2, 1.0),
                    b = test::random_state(t, rng, 0.3, 0.2, 1.0);
    const double g = full_energy(t.model, a.view(), b.view(), 0.2, ws);
    const Eigen::Quaterniond yaw(Eigen::AngleAxisd(0.2 + 0.1 * i, Eigen::Vector3d::UnitY()));
    const Eigen::Vector3d shift(3.0 - 0.1 * i, 0.0, 0.05 * i);
    const BodyState ta = test::transform_state(a, yaw, shift),
                    tb = test::transform_state(b, yaw, shift);
    EXPECT_NEAR(full_energy(t.model, ta.view(), tb.view(), 0.2, ws), g, 1e-9 * (1.0 + g)) << i;
  }
}

TEST(FullEnergy, ClipStepsAndPrefixSums) {
  const auto t = test::make_test_body();
  const std::size_t frames = 12, n = t.model.joint_count();
  std::vector<Eigen::Vector3d> xs(frames * n);
  std::vector<Eigen::Quaterniond> rs(frames * n);
  for (std::size_t f = 0; f < frames; ++f) {
    std::vector<Eigen::Quaterniond> locals(n, Eigen::Quaterniond::Identity());
    locals[4] = Eigen::Quaterniond(
        Eigen::AngleAxisd(0.1 * static_cast<double>(f), Eigen::Vector3d::UnitZ()));
    locals[8] = Eigen::Quaterniond(
        Eigen::AngleAxisd(0.05 * static_cast<double>(f), Eigen::Vector3d::UnitX()));
    std::vector<Eigen::Vector3d> x;
    std::vector<Eigen::Quaterniond> r;
    test::pose_from_locals(t.skeleton, Eigen::Vector3d(0.01 * static_cast<double>(f), 0, 0), locals,
                           x, r);
    std::copy(x.begin(), x.end(), xs.begin() + static_cast<std::ptrdiff_t>(f * n));
    std::copy(r.begin(), r.end(), rs.begin() + static_cast<std::ptrdiff_t>(f * n));
  }
  ClipDynamics d;
  compute_clip_dynamics(t.model, frames, 1.0 / 30.0, xs.data(), rs.data(), d);
  const std::vector<double> steps = clip_step_energies(t.model, d);
  ASSERT_EQ(steps.size(), frames - 1);
  NewtonEulerWorkspace ws;
  for (std::size_t f = 0; f + 1 < frames; ++f) {
    EXPECT_NEAR(steps[f], full_energy(t.model, d.state(f), d.state(f + 1), 1.0 / 30.0, ws), 1e-12);
    EXPECT_GE(steps[f], approximate_energy(t.model, d.state(f), d.state(f + 1), 1.0 / 30.0));
    EXPECT_GT(steps[f], 0.0);
  }
  const std::vector<double> p = energy_prefix_sums(steps);
  ASSERT_EQ(p.size(), frames);
  EXPECT_EQ(p[0], 0.0);
  double sum = 0.0;
  for (std::size_t s = 3; s < 9; ++s) sum += steps[s];
  EXPECT_NEAR(p[9] - p[3], sum, 1e-12);
  ClipDynamics one;
  compute_clip_dynamics(t.model, 1, 1.0 / 30.0, xs.data(), rs.data(), one);
  EXPECT_TRUE(clip_step_energies(t.model, one).empty());
  EXPECT_EQ(energy_prefix_sums({}).size(), 1u);
}

TEST(FullEnergy, RejectsMismatchedStates) {
  const auto t = test::make_test_body();
  BodyState small;
  small.resize(2);
  NewtonEulerData data;
  EXPECT_THROW(inverse_dynamics(t.model, small.view(), data), std::invalid_argument);
  JointMotion m;
  m.resize(3);
  BodyState out;
  EXPECT_THROW(
      rnea_forward(t.model, PoseView{small.joint_positions_m.data(), small.rotations.data()}, m,
                   data, out),
      std::invalid_argument);
}

}  // namespace
}  // namespace mocap
