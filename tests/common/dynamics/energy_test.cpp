// The approximate energy change h on hand-built bodies: definition, properties,
// partial queries, the kd-tree bound and the vectorised scan.
#include "mocap/common/dynamics/energy.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

#include "energy_fixtures.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {
namespace {

using test::make_test_body;
using test::random_state;

// The start-plus-stop terms (docs/energy.md, "h"), written independently of the library (world
// inertia per state, rotation vector by AngleAxis), returning the literal
// h_b, h_j and the "stop-and-go" credit our dK removes.
struct Literal {
  double h = 0.0;
  double credit = 0.0;
};
Literal literal_h(const DynamicsModel& m, const BodyState& a, const BodyState& b, double t) {
  Literal out;
  for (int jj : m.segments) {
    const auto j = static_cast<std::size_t>(jj);
    const double mass = m.masses_kg[j];
    const Eigen::Vector3d dc = b.coms_m[j] - a.coms_m[j];
    const Eigen::Vector3d u = dc / t;
    const double ka = 0.5 * mass * a.com_velocities_mps[j].squaredNorm();
    const double ku = 0.5 * mass * u.squaredNorm();
    const double kb = 0.5 * mass * b.com_velocities_mps[j].squaredNorm();
    out.h += std::abs(mass * Eigen::Vector3d(0, -9.81, 0).dot(dc)) + std::abs(ku - ka) +
             std::abs(kb - ku);
    out.credit += 2.0 * std::max(0.0, std::min(ka, kb) - ku);
    const Eigen::Matrix3d ra = a.rotations[j].toRotationMatrix(),
                          rb = b.rotations[j].toRotationMatrix();
    const Eigen::Matrix3d ia = ra * m.inertias_local_kgm2[j] * ra.transpose();
    const Eigen::Matrix3d ib = rb * m.inertias_local_kgm2[j] * rb.transpose();
    const Eigen::AngleAxisd aa(rb * ra.transpose());
    const Eigen::Vector3d w_hat = aa.angle() * aa.axis() / t;
    const double kra = 0.5 * a.angular_velocities_radps[j].dot(ia * a.angular_velocities_radps[j]);
    const double kru = 0.5 * w_hat.dot(ia * w_hat);
    const double krb = 0.5 * b.angular_velocities_radps[j].dot(ib * b.angular_velocities_radps[j]);
    out.h += std::abs(kru - kra) + std::abs(krb - kru);
    out.credit += 2.0 * std::max(0.0, std::min(kra, krb) - kru);
  }
  return out;
}

BodyState static_copy(const BodyState& s) {
  BodyState o = s;
  o.set_rates_zero();
  return o;
}

TEST(TransitionKineticChange, Cases) {
  EXPECT_DOUBLE_EQ(transition_kinetic_change(0, 0, 0), 0.0);
  EXPECT_DOUBLE_EQ(transition_kinetic_change(0, 2, 0), 4.0);  // start and stop
  EXPECT_DOUBLE_EQ(transition_kinetic_change(1, 2, 3), 2.0);  // monotone: |K_B - K_A|
  EXPECT_DOUBLE_EQ(transition_kinetic_change(3, 5, 1), 6.0);  // overshoot: 2 K_u - K_A - K_B
  EXPECT_DOUBLE_EQ(transition_kinetic_change(3, 0, 3), 0.0);  // keep speed, curve the path
  EXPECT_DOUBLE_EQ(transition_kinetic_change(4, 1, 2), 2.0);
}

TEST(ApproximateEnergy, RejectsBadInput) {
  const auto t = make_test_body();
  std::mt19937 rng(1);
  const BodyState a = random_state(t, rng);
  EXPECT_THROW(approximate_energy(t.model, a.view(), a.view(), 0.0), std::invalid_argument);
  EXPECT_THROW(approximate_energy(t.model, a.view(), a.view(), -1.0), std::invalid_argument);
  EXPECT_THROW(approximate_energy(t.model, a.view(), a.view(), std::nan("")),
               std::invalid_argument);
  BodyState small;
  small.resize(3);
  EXPECT_THROW(approximate_energy(t.model, a.view(), small.view(), 0.5), std::invalid_argument);
}

TEST(ApproximateEnergy, SingleSegmentByHand) {
  // One segment, mass 2 kg, I = diag(0.1, 0.2, 0.3); A static at the origin,
  // B 0.3 m up and 0.4 m along x, turned by 0.5 rad about local z, moving.
  const Skeleton s = test::make_skeleton({"a"}, {-1}, {{0, 0, 0}});
  Body b;
  b.segments = {test::make_segment(0, 2.0, {0, 0, 0}, {0, 0.3, 0}, {0.1, 0.2, 0.3})};
  const DynamicsModel m = build_dynamics_model(s, b);
  BodyState sa, sb;
  sa.resize(1);
  sb.resize(1);
  sb.joint_positions_m[0] = sb.coms_m[0] = Eigen::Vector3d(0.4, 0.3, 0.0);
  sb.rotations[0] = Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()));
  sb.com_velocities_mps[0] = Eigen::Vector3d(1.0, 0.0, 0.0);
  sb.angular_velocities_radps[0] = Eigen::Vector3d(0.0, 0.0, 2.0);
  const double t = 0.5;
  EnergyTerms terms;
  const double h = approximate_energy(m, sa.view(), sb.view(), t, &terms);
  // Gravity 2 * 9.81 * 0.3; K_u = 1/2 * 2 * (0.5/0.5)^2 = 1; K_B = 1: dK = max(1, 2 - 1) = 1.
  const double seg = 2.0 * 9.81 * 0.3 + 1.0;
  // Rotation: w^ = 1 rad/s about z, K_w = 1/2 * 0.3 * 1 = 0.15; K_B = 1/2 * 0.3 * 4 = 0.6 ->
  // max(0.6, -0.3).
  const double rot = 0.6;
  EXPECT_NEAR(terms.segment_J[0], seg, 1e-12);
  EXPECT_NEAR(terms.joint_J[0], rot, 1e-12);
  EXPECT_NEAR(h, seg + rot, 1e-12);
  EXPECT_NEAR(terms.total(), h, 1e-12);
}

TEST(ApproximateEnergy, MatchesStartPlusStopSumWhereDefinitionsAgree) {
  const auto t = make_test_body();
  std::mt19937 rng(2);
  for (int i = 0; i < 200; ++i) {
    const BodyState a = random_state(t, rng), b = random_state(t, rng);
    const double tt = 0.1 + 0.01 * i;
    // Static A: identical to the literal formula.
    const BodyState sa = static_copy(a);
    const Literal lit = literal_h(t.model, sa, b, tt);
    EXPECT_EQ(lit.credit, 0.0);
    EXPECT_NEAR(approximate_energy(t.model, sa.view(), b.view(), tt), lit.h, 1e-9 * (1.0 + lit.h));
    // Both moving: literal minus the stop-and-go credit.
    const Literal both = literal_h(t.model, a, b, tt);
    EXPECT_NEAR(approximate_energy(t.model, a.view(), b.view(), tt), both.h - both.credit,
                1e-9 * (1.0 + both.h));
  }
}

TEST(ApproximateEnergy, ZeroForTheSameStateStaticOrMoving) {
  const auto t = make_test_body();
  std::mt19937 rng(3);
  for (int i = 0; i < 20; ++i) {
    const BodyState a = random_state(t, rng);
    EXPECT_EQ(approximate_energy(t.model, a.view(), a.view(), 0.5), 0.0);
    const BodyState s = static_copy(a);
    EXPECT_EQ(approximate_energy(t.model, s.view(), s.view(), 0.5), 0.0);
  }
}

TEST(ApproximateEnergy, NonNegativeSymmetricAndInvariant) {
  const auto t = make_test_body();
  std::mt19937 rng(4);
  for (int i = 0; i < 200; ++i) {
    const BodyState a = random_state(t, rng), b = random_state(t, rng);
    const double h = approximate_energy(t.model, a.view(), b.view(), 0.4);
    EXPECT_GE(h, 0.0);
    EXPECT_NEAR(approximate_energy(t.model, b.view(), a.view(), 0.4), h, 1e-12 * (1.0 + h));
    const Eigen::Quaterniond yaw(Eigen::AngleAxisd(0.3 + 0.05 * i, Eigen::Vector3d::UnitY()));
    const Eigen::Vector3d shift(1.5 - 0.02 * i, 0.0, -3.0 + 0.01 * i);
    const BodyState ta = test::transform_state(a, yaw, shift),
                    tb = test::transform_state(b, yaw, shift);
    EXPECT_NEAR(approximate_energy(t.model, ta.view(), tb.view(), 0.4), h, 1e-9 * (1.0 + h));
    // A tilt (not about the vertical) changes gravity work: h is not invariant then.
    const Eigen::Quaterniond tilt(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitX()));
    const BodyState xa = test::transform_state(a, tilt, shift),
                    xb = test::transform_state(b, tilt, shift);
    if (i == 0) {
      EXPECT_GT(std::abs(approximate_energy(t.model, xa.view(), xb.view(), 0.4) - h), 1e-6);
    }
  }
}

TEST(ApproximateEnergy, SegmentMassScalesItsTermsOnly) {
  auto t = make_test_body();
  std::mt19937 rng(5);
  const BodyState a = static_copy(random_state(t, rng)), b = random_state(t, rng);
  EnergyTerms base, heavy;
  approximate_energy(t.model, a.view(), b.view(), 0.5, &base);
  const int arm = 5;  // LowerArm_L
  const double k = 2.5;
  t.body.segments[arm].mass_kg *= k;
  t.body.segments[arm].inertia_local_kgm2 *= k;
  const DynamicsModel heavier = build_dynamics_model(t.skeleton, t.body);
  approximate_energy(heavier, a.view(), b.view(), 0.5, &heavy);
  for (std::size_t j = 0; j < heavier.joint_count(); ++j) {
    const double f = static_cast<int>(j) == arm ? k : 1.0;
    EXPECT_NEAR(heavy.segment_J[j], f * base.segment_J[j], 1e-12 * (1.0 + heavy.segment_J[j])) << j;
    EXPECT_NEAR(heavy.joint_J[j], f * base.joint_J[j], 1e-12 * (1.0 + heavy.joint_J[j])) << j;
  }
  EXPECT_GT(base.segment_J[arm], 0.0);
}

TEST(ApproximateEnergy, StaticPairRotationalTermIsTheTransitionEnergy) {
  // Two static poses differing by a turn of the forearm about its long axis
  // (local x): h_j = 2 * 1/2 * I_xx (theta / T)^2 for that segment.
  const auto t = make_test_body();
  const std::size_t n = t.model.joint_count();
  std::vector<Eigen::Quaterniond> la(n, Eigen::Quaterniond::Identity()), lb = la;
  const double theta = 0.6, tt = 0.5;
  lb[5] = Eigen::Quaterniond(Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitX()));
  std::vector<Eigen::Vector3d> xa, xb;
  std::vector<Eigen::Quaterniond> ra, rb;
  test::pose_from_locals(t.skeleton, Eigen::Vector3d::Zero(), la, xa, ra);
  test::pose_from_locals(t.skeleton, Eigen::Vector3d::Zero(), lb, xb, rb);
  BodyState a, b;
  static_state(t.model, PoseView{xa.data(), ra.data()}, a);
  static_state(t.model, PoseView{xb.data(), rb.data()}, b);
  EnergyTerms terms;
  approximate_energy(t.model, a.view(), b.view(), tt, &terms);
  const double ixx = t.model.inertias_local_kgm2[5](0, 0);
  EXPECT_NEAR(terms.joint_J[5], ixx * theta * theta / (tt * tt), 1e-12);
  for (std::size_t j = 0; j < n; ++j)
    if (j != 5) {
      EXPECT_EQ(terms.joint_J[j], 0.0) << j;
    }
}

// ---------------------------------------------------------------- kd bound

TEST(KdFeature, SquaredDistanceLowerBoundsH) {
  const auto t = make_test_body();
  std::mt19937 rng(6);
  const std::size_t dim = kd_feature_dimension(t.model);
  EXPECT_EQ(dim, 3 * t.model.segments.size());
  std::vector<float> fa(dim), fb(dim);
  for (int i = 0; i < 500; ++i) {
    const BodyState q = static_copy(random_state(t, rng)), f = random_state(t, rng, 1.2, 2.0);
    const double tt = 0.1 + 0.002 * i;
    kd_feature(t.model, q.view(), tt, fa.data());
    kd_feature(t.model, f.view(), tt, fb.data());
    double d2 = 0.0;
    for (std::size_t k = 0; k < dim; ++k)
      d2 += (double(fa[k]) - double(fb[k])) * (double(fa[k]) - double(fb[k]));
    double exact = 0.0;
    for (int jj : t.model.segments) {
      const auto j = static_cast<std::size_t>(jj);
      exact += 0.5 * t.model.masses_kg[j] * (f.coms_m[j] - q.coms_m[j]).squaredNorm() / (tt * tt);
    }
    EXPECT_NEAR(d2, exact, 1e-5 * (1.0 + exact));
    const double h = approximate_energy(t.model, q.view(), f.view(), tt);
    EXPECT_LE(exact, h * (1.0 + 1e-12));
    EXPECT_LE(exact, approximate_energy(t.model, f.view(), q.view(), tt) * (1.0 + 1e-12));
  }
}

// ---------------------------------------------------------------- partial queries

// A frame with its local pose, made from a random state of the test body.
struct Frame {
  BodyState state;
  std::vector<Eigen::Vector3d> local_t;
  std::vector<Eigen::Quaterniond> local_q;
  FrameRef ref() const { return {state.view(), local_t.data(), local_q.data()}; }
};

Frame random_frame(const test::TestBody& t, std::mt19937& rng) {
  const std::size_t n = t.model.joint_count();
  Frame f;
  f.local_t = t.skeleton.offsets_m;
  f.local_q.assign(n, Eigen::Quaterniond::Identity());
  std::uniform_real_distribution<double> u(-0.8, 0.8);
  for (std::size_t j = 1; j < n; ++j)
    f.local_q[j] =
        Eigen::Quaterniond(Eigen::AngleAxisd(u(rng), test::random_vector(rng, 1.0).normalized()));
  f.local_t[0] = Eigen::Vector3d(u(rng), 0.0, u(rng));
  std::vector<Eigen::Vector3d> x;
  std::vector<Eigen::Quaterniond> r;
  test::pose_from_locals(t.skeleton, f.local_t[0], f.local_q, x, r);
  set_state_pose(t.model, PoseView{x.data(), r.data()}, f.state);
  for (std::size_t j = 0; j < n; ++j) {
    f.state.com_velocities_mps[j] = test::random_vector(rng, 1.0);
    f.state.angular_velocities_radps[j] = test::random_vector(rng, 3.0);
  }
  return f;
}

TEST(PartialQuery, RejectsBadSpecs) {
  const auto t = make_test_body();
  PartialPoseSpec s;
  s.joint_rotations = {{99, Eigen::Quaterniond::Identity()}};
  EXPECT_THROW(prepare_partial_query(t.model, s), InputError);
  s.joint_rotations = {{4, Eigen::Quaterniond::Identity()}, {4, Eigen::Quaterniond::Identity()}};
  EXPECT_THROW(prepare_partial_query(t.model, s), InputError);
  s.joint_rotations = {{4, Eigen::Quaterniond(0, 0, 0, 0)}};
  EXPECT_THROW(prepare_partial_query(t.model, s), InputError);
  PartialPoseSpec p;
  p.root_position_m[0] = std::nan("");
  EXPECT_THROW(prepare_partial_query(t.model, p), InputError);
  PartialPoseSpec h;
  h.root_heading_rad = INFINITY;
  EXPECT_THROW(prepare_partial_query(t.model, h), InputError);
}

TEST(PartialQuery, AffectedSets) {
  const auto t = make_test_body();
  PartialPoseSpec s;
  s.joint_rotations = {{4, Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()))}};
  const PartialQuery q = prepare_partial_query(t.model, s);
  EXPECT_FALSE(q.moves_whole_body);
  EXPECT_EQ(q.affected_joints, (std::vector<int>{4, 5}));
  PartialPoseSpec r;
  r.root_position_m[0] = 1.0;
  const PartialQuery qr = prepare_partial_query(t.model, r);
  EXPECT_TRUE(qr.moves_whole_body);
  EXPECT_EQ(qr.affected_joints.size(), t.model.joint_count());
}

TEST(PartialQuery, CompletionTakesGivenValuesAndFramesRest) {
  const auto t = make_test_body();
  std::mt19937 rng(8);
  const Frame f = random_frame(t, rng);
  PartialPoseSpec s;
  const Eigen::Quaterniond elbow(Eigen::AngleAxisd(1.1, Eigen::Vector3d::UnitY()));
  s.joint_rotations = {{5, elbow}};
  s.root_position_m = {2.0, std::nullopt, -1.0};
  s.root_heading_rad = 0.7;
  const PartialQuery q = prepare_partial_query(t.model, s);
  BodyState c;
  complete_partial_query(t.model, q, f.ref(), c);
  const int root = t.model.root();
  EXPECT_NEAR(c.joint_positions_m[root].x(), 2.0, 1e-12);
  EXPECT_NEAR(c.joint_positions_m[root].y(), f.state.joint_positions_m[root].y(), 1e-12);
  EXPECT_NEAR(c.joint_positions_m[root].z(), -1.0, 1e-12);
  EXPECT_NEAR(heading_rad(c.rotations[root]), 0.7, 1e-12);
  // The given local rotation holds: R_parent^-1 R_joint.
  const Eigen::Quaterniond local = c.rotations[4].conjugate() * c.rotations[5];
  EXPECT_NEAR(std::abs(local.dot(elbow)), 1.0, 1e-12);
  // Whole body static.
  for (std::size_t j = 0; j < t.model.joint_count(); ++j)
    EXPECT_EQ(c.com_velocities_mps[j], Eigen::Vector3d::Zero());
  // Bone lengths preserved.
  for (std::size_t j = 1; j < t.model.joint_count(); ++j) {
    const auto p = static_cast<std::size_t>(t.skeleton.parents[j]);
    EXPECT_NEAR((c.joint_positions_m[j] - c.joint_positions_m[p]).norm(),
                (f.state.joint_positions_m[j] - f.state.joint_positions_m[p]).norm(), 1e-12);
  }
}

TEST(PartialQuery, OnlyMovedSegmentsCostAndFastPathMatchesReference) {
  const auto t = make_test_body();
  std::mt19937 rng(9);
  BodyState scratch, completed;
  for (int i = 0; i < 100; ++i) {
    const Frame f = random_frame(t, rng);
    PartialPoseSpec s;
    s.joint_rotations = {{4, test::random_rotation(rng)}, {12, test::random_rotation(rng)}};
    if (i % 3 == 1) s.root_position_m = {0.5, std::nullopt, std::nullopt};
    if (i % 3 == 2) s.root_heading_rad = 0.1 * i;
    const PartialQuery q = prepare_partial_query(t.model, s);
    complete_partial_query(t.model, q, f.ref(), completed);
    EnergyTerms ref_terms, fast_terms;
    const double ref =
        approximate_energy(t.model, completed.view(), f.state.view(), 0.5, &ref_terms);
    const double fast = partial_approximate_energy(t.model, q, f.ref(), 0.5, scratch, &fast_terms);
    EXPECT_NEAR(fast, ref, 1e-10 * (1.0 + ref));
    for (std::size_t j = 0; j < t.model.joint_count(); ++j) {
      if (!q.affected[j]) {
        EXPECT_EQ(ref_terms.segment_J[j], 0.0) << j;
        EXPECT_EQ(ref_terms.joint_J[j], 0.0) << j;
      }
      EXPECT_NEAR(fast_terms.segment_J[j], ref_terms.segment_J[j], 1e-10 * (1.0 + ref)) << j;
    }
    if (!q.moves_whole_body) {
      EXPECT_GT(ref_terms.segment_J[5], 0.0);
    }
  }
}

// ---------------------------------------------------------------- SoA scan

TEST(HScan, AgreesWithReferenceForStaticAndMovingQueries) {
  const auto t = make_test_body();
  std::mt19937 rng(10);
  const std::size_t frames = 203;  // not a multiple of 16
  std::vector<BodyState> db;
  for (std::size_t f = 0; f < frames; ++f) db.push_back(random_state(t, rng, 1.5, 2.0));
  HScanTable table;
  init_h_scan_table(t.model, frames, table);
  EXPECT_EQ(table.stride % 16, 0u);
  for (std::size_t f = 0; f < frames; ++f) set_h_scan_frame(t.model, db[f].view(), f, table);
  std::vector<float> out(frames);
  for (int qi = 0; qi < 6; ++qi) {
    BodyState q = random_state(t, rng, 1.5, 2.0);
    if (qi % 2 == 0) q.set_rates_zero();
    const double tt = 0.2 + 0.1 * qi;
    const HScanQuery hq = make_h_scan_query(t.model, q.view(), tt);
    scan_approximate_energy(table, hq, 0, frames, out.data());
    for (std::size_t f = 0; f < frames; ++f) {
      const double ref = approximate_energy(t.model, q.view(), db[f].view(), tt);
      EXPECT_NEAR(double(out[f]), ref, 2e-5 * ref + 1e-5) << qi << " " << f;
    }
    // A sub-range gives the same values.
    std::vector<float> part(50);
    scan_approximate_energy(table, hq, 17, 67, part.data());
    for (std::size_t i = 0; i < 50; ++i) EXPECT_EQ(part[i], out[17 + i]);
  }
  // Same state: zero up to float rounding of the rotation polynomial.
  const HScanQuery self = make_h_scan_query(t.model, db[3].view(), 0.5);
  scan_approximate_energy(table, self, 3, 4, out.data());
  EXPECT_NEAR(double(out[0]), 0.0, 1e-3);
  EXPECT_THROW(scan_approximate_energy(table, self, 10, frames + 1, out.data()), std::out_of_range);
}

// An index's h_scan row (h_scan_row, row-major) holds bit for bit the
// values set_h_scan_frame writes into the field-major table's column.
TEST(HScan, RowEqualsTheTablesColumn) {
  const auto t = make_test_body();
  std::mt19937 rng(31);
  const std::size_t frames = 19;
  HScanTable table;
  init_h_scan_table(t.model, frames, table);
  const std::size_t S = t.model.segments.size(), F = HScanTable::kFields;
  std::vector<float> rows(frames * S * F, -1.0f);
  for (std::size_t f = 0; f < frames; ++f) {
    const BodyState state = random_state(t, rng, 1.5, 2.0);
    set_h_scan_frame(t.model, state.view(), f, table);
    h_scan_row(t.model, state.view(), rows.data() + f * S * F);
  }
  for (std::size_t f = 0; f < frames; ++f)
    for (std::size_t s = 0; s < S; ++s)
      for (std::size_t k = 0; k < F; ++k)
        ASSERT_EQ(rows[(f * S + s) * F + k], table.field(s, k)[f]) << f << " " << s << " " << k;
}

// A view of blocks copied out of a table (the search engine's tiles: stride
// 16, rows elsewhere) scans to the very values of the table.
TEST(HScan, ViewOfCopiedBlocksEqualsTheTable) {
  const auto t = make_test_body();
  std::mt19937 rng(12);
  const std::size_t frames = 37;  // two whole blocks and a short one
  HScanTable table;
  init_h_scan_table(t.model, frames, table);
  for (std::size_t f = 0; f < frames; ++f)
    set_h_scan_frame(t.model, random_state(t, rng, 1.5, 2.0).view(), f, table);
  const std::size_t rows = table.segment_count * HScanTable::kFields;
  std::vector<float> all(frames), part(16);
  for (int qi = 0; qi < 3; ++qi) {
    const BodyState q = random_state(t, rng, 1.5, 2.0);
    const HScanQuery hq = make_h_scan_query(t.model, q.view(), 0.5);
    PartialPoseSpec s;
    s.root_position_m = {0.2 * qi, std::nullopt, 0.1};
    const HScanRootQuery rq = make_h_scan_root_query(t.model, s.root_position_m, 0.5);
    for (int root = 0; root < 2; ++root) {
      if (root == 0)
        scan_approximate_energy(table, hq, 0, frames, all.data());
      else
        scan_root_translation_energy(table, rq, 0, frames, all.data());
      for (std::size_t g0 = 0; g0 < frames; g0 += 16) {
        const std::size_t n = std::min<std::size_t>(16, frames - g0);
        // Garbage in the unused frames of the block: never read.
        std::vector<float> values(rows * 16, 1e30f), roots(3 * 16, 1e30f);
        for (std::size_t r = 0; r < rows; ++r)
          std::copy_n(table.values.begin() + static_cast<std::ptrdiff_t>(r * table.stride + g0), n,
                      values.begin() + static_cast<std::ptrdiff_t>(r * 16));
        for (std::size_t a = 0; a < 3; ++a)
          std::copy_n(
              table.root_positions.begin() + static_cast<std::ptrdiff_t>(a * table.stride + g0), n,
              roots.begin() + static_cast<std::ptrdiff_t>(a * 16));
        const HScanView view{values.data(), roots.data(), n, 16, table.segment_count};
        if (root == 0)
          scan_approximate_energy(view, hq, 0, n, part.data());
        else
          scan_root_translation_energy(view, rq, 0, n, part.data());
        for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(part[i], all[g0 + i]) << qi << " " << g0 + i;
        EXPECT_THROW(scan_approximate_energy(view, hq, 0, n + 1, part.data()), std::out_of_range);
      }
    }
  }
}

TEST(HScan, LargeRotationsAreAccurate) {
  // Rotations up to pi: the polynomial for theta^2 / sin^2(theta/2) covers [0, 1].
  const Skeleton s = test::make_skeleton({"a"}, {-1}, {{0, 0, 0}});
  Body b;
  b.segments = {test::make_segment(0, 3.0, {0, 0.1, 0}, {0, 0.3, 0}, {0.1, 0.2, 0.3})};
  const DynamicsModel m = build_dynamics_model(s, b);
  BodyState q;
  q.resize(1);
  q.coms_m[0] = Eigen::Vector3d(0, 0.1, 0);
  HScanTable table;
  const int n = 64;
  init_h_scan_table(m, n, table);
  std::vector<BodyState> frames(n);
  for (int i = 0; i < n; ++i) {
    frames[i].resize(1);
    frames[i].coms_m[0] = q.coms_m[0];
    const double angle = std::numbers::pi * i / (n - 1);
    frames[i].rotations[0] =
        Eigen::Quaterniond(Eigen::AngleAxisd(angle, Eigen::Vector3d(1, 1, 0).normalized()));
    set_h_scan_frame(m, frames[i].view(), static_cast<std::size_t>(i), table);
  }
  std::vector<float> out(n);
  scan_approximate_energy(table, make_h_scan_query(m, q.view(), 0.5), 0, n, out.data());
  for (int i = 0; i < n; ++i) {
    const double ref = approximate_energy(m, q.view(), frames[i].view(), 0.5);
    EXPECT_NEAR(double(out[i]), ref, 1e-5 * ref + 1e-7) << i;
  }
}

TEST(HScan, RootTranslationQueryMatchesPartialReference) {
  const auto t = make_test_body();
  std::mt19937 rng(11);
  const std::size_t frames = 40;
  std::vector<Frame> db;
  HScanTable table;
  init_h_scan_table(t.model, frames, table);
  for (std::size_t f = 0; f < frames; ++f) {
    db.push_back(random_frame(t, rng));
    set_h_scan_frame(t.model, db.back().state.view(), f, table);
  }
  std::vector<float> out(frames);
  BodyState scratch;
  for (int variant = 0; variant < 3; ++variant) {
    PartialPoseSpec s;
    s.root_position_m = {0.3, std::nullopt, -0.2};
    if (variant == 1) s.root_position_m = {std::nullopt, 1.2, std::nullopt};
    if (variant == 2) s.root_position_m = {0.1, 0.9, 0.4};
    const PartialQuery q = prepare_partial_query(t.model, s);
    const HScanRootQuery rq = make_h_scan_root_query(t.model, s.root_position_m, 0.5);
    scan_root_translation_energy(table, rq, 0, frames, out.data());
    for (std::size_t f = 0; f < frames; ++f) {
      const double ref = partial_approximate_energy(t.model, q, db[f].ref(), 0.5, scratch);
      EXPECT_NEAR(double(out[f]), ref, 2e-5 * ref + 1e-5) << variant << " " << f;
      // kd root feature bound.
      std::array<bool, 3> axes{s.root_position_m[0].has_value(), s.root_position_m[1].has_value(),
                               s.root_position_m[2].has_value()};
      float fq[3], ff[3];
      Eigen::Vector3d qp(s.root_position_m[0].value_or(0), s.root_position_m[1].value_or(0),
                         s.root_position_m[2].value_or(0));
      kd_root_feature(t.model, axes, qp, 0.5, fq);
      kd_root_feature(t.model, axes, db[f].state.joint_positions_m[t.model.root()], 0.5, ff);
      double d2 = 0.0;
      const int count = int(axes[0]) + int(axes[1]) + int(axes[2]);
      for (int k = 0; k < count; ++k)
        d2 += (double(fq[k]) - double(ff[k])) * (double(fq[k]) - double(ff[k]));
      EXPECT_LE(d2, ref * (1.0 + 1e-5) + 1e-6);
    }
  }
}

// A frame's value does not depend on the range it is scanned in: the exact
// search evaluates the end frames its bounds leave, brute force all of them,
// and both must rank by the same numbers. (With fused multiply-adds the
// vectorised loop body and its scalar remainder round differently: the
// build turns contraction off.)
TEST(HScan, ValueOfAFrameDoesNotDependOnTheRangeScanned) {
  const std::size_t segments = 21, n = 203;
  std::vector<float> values(segments * HScanTable::kFields * n), roots(3 * n);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (float& v : values) v = u(rng);
  for (float& v : roots) v = u(rng);
  const HScanView table{values.data(), roots.data(), n, n, segments};
  HScanQuery q;
  q.segment_count = segments;
  q.constants.resize(segments * HScanQuery::kConstants);
  for (float& c : q.constants) c = u(rng);
  // Every third segment left out (the mask), the others summed.
  for (std::size_t s = 0; s < segments; ++s)
    q.constants[s * HScanQuery::kConstants + 15] = s % 3 == 0 ? 1.0f : 0.0f;
  HScanRootQuery rq;
  rq.position = {0.3f, 0.9f, -0.2f};
  rq.given = {1.0f, 0.0f, 1.0f};
  rq.inv_t2 = 4.0f;
  rq.gravity = 9.81f;
  for (std::size_t s = 0; s < segments; ++s) rq.masses.push_back(1.0f + u(rng));
  std::vector<float> whole(n), root_whole(n), part(n);
  scan_approximate_energy(table, q, 0, n, whole.data());
  scan_root_translation_energy(table, rq, 0, n, root_whole.data());
  for (std::size_t b = 0; b < n; b += 5)
    for (std::size_t len : {std::size_t{1}, std::size_t{3}, std::size_t{17}, n - b}) {
      const std::size_t e = std::min(n, b + len);
      scan_approximate_energy(table, q, b, e, part.data());
      for (std::size_t f = b; f < e; ++f) ASSERT_EQ(part[f - b], whole[f]) << "frame " << f;
      scan_root_translation_energy(table, rq, b, e, part.data());
      for (std::size_t f = b; f < e; ++f) ASSERT_EQ(part[f - b], root_whole[f]) << "frame " << f;
    }
}

TEST(EnergyTermNames, SegmentsAndJoints) {
  const auto t = make_test_body();
  const auto names = energy_term_names(t.model);
  // 13 segments + 13 term joints; joint_Root has neither.
  EXPECT_EQ(names.size(), 26u);
  EXPECT_EQ(names.front().name, "Hips");
  EXPECT_FALSE(names.front().is_joint);
  EXPECT_TRUE(names[1].is_joint);
  for (const auto& n : names) EXPECT_NE(n.name, "joint_Root");
}

}  // namespace
}  // namespace mocap
