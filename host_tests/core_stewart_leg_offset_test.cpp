// The 6-UPS with leg lines beside their U centres (core/stewart.hpp,
// leg_offset_sq; issue #31): core's closed form l_i = √(|L_i|² − s_i)
// against the independent simulator's leg closure (independent/
// independent_common.hpp: a U joint with two revolutes, a prismatic line
// displaced from the U centre, Newton on θa, θb, x — no distance formula), the
// IK's Jacobian against finite differences of the IK, and the FK as the IK's
// inverse. What differs from the 42-parameter tests: the legs are not
// distances, and the offsets are millimetres in random directions.
#include <gtest/gtest.h>

#include <random>

#include "independent/independent_common.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/core/stewart.hpp"

namespace {

using namespace kincal;
namespace ind = kincal::independent;

// Seed 001's machine with leg i's line beside its U centre by o_i (mm) in a
// random direction ⟂ the leg at home; returns the geometry with s_i = o_i²
// and the independent legs.
struct OffsetMachine {
  StewartGeometry<double> g;
  std::array<ind::UpsLeg, 6> legs;
};

OffsetMachine offset_machine(double size_mm, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  OffsetMachine m;
  m.g = make_stewart_seed001<double>();
  const Eigen::Matrix<double, 3, 6> home = m.g.home.R * m.g.platform;
  for (int i = 0; i < 6; ++i) {
    const Vec3<double> S = home.col(i) + m.g.home.p;
    const Vec3<double> u = (S - m.g.base.col(i)).normalized();
    ind::UpsLegErrors e;
    e.leg_offset = {ind::uniform(rng, size_mm), ind::uniform(rng, size_mm)};
    m.legs[std::size_t(i)] = ind::make_ups_leg(m.g.base.col(i), u, e);
    m.g.leg_offset_sq(i) = e.leg_offset[0] * e.leg_offset[0] + e.leg_offset[1] * e.leg_offset[1];
  }
  return m;
}

Pose<double> random_pose(std::mt19937_64& rng) {
  return Pose<double>::from_xyz_rpy(ind::uniform(rng, 30), ind::uniform(rng, 30), 195 + ind::uniform(rng, 20),
                                    ind::uniform(rng, 0.08), ind::uniform(rng, 0.08), ind::uniform(rng, 0.08));
}

TEST(StewartLegOffsets, IkEqualsTheIndependentLegClosure) {
  for (const double size : {0.1, 1.0, 5.0}) {
    const OffsetMachine m = offset_machine(size, 77);
    std::mt19937_64 rng(78);
    double worst = 0;
    for (int k = 0; k < 50; ++k) {
      const Pose<double> pose = random_pose(rng);
      Vec6<double> q;
      ASSERT_EQ(stewart_ik(m.g, pose, q), Status::Ok);
      for (int i = 0; i < 6; ++i) {
        const Vec3<double> S = pose.R * m.g.platform.col(i) + pose.p;
        const ind::LegSolution sol = ind::solve_leg(m.legs[std::size_t(i)], S);
        ASSERT_TRUE(sol.ok);
        worst = std::max(worst, std::abs(q(i) - sol.x));
      }
    }
    // The distance alone would be off by s/(2l) ≈ 0.05 mm at 5 mm offsets.
    EXPECT_LT(worst, 1e-9) << size << " mm offsets";
  }
}

TEST(StewartLegOffsets, JacobianIsTheDerivativeAndFkInvertsIk) {
  const OffsetMachine m = offset_machine(2.0, 91);
  std::mt19937_64 rng(92);
  for (int k = 0; k < 20; ++k) {
    const Pose<double> pose = random_pose(rng);
    Vec6<double> q;
    Mat6<double> J;
    ASSERT_EQ(stewart_ik(m.g, pose, q, &J), Status::Ok);
    const double h = 1e-6;
    for (int c = 0; c < 6; ++c) {
      Twist<double> t = Twist<double>::Zero();
      t(c) = h;
      Vec6<double> qp, qm;
      ASSERT_EQ(stewart_ik(m.g, apply_twist(pose, t), qp), Status::Ok);
      ASSERT_EQ(stewart_ik(m.g, apply_twist(pose, Twist<double>(-t)), qm), Status::Ok);
      const Vec6<double> fd = (qp - qm) / (2 * h);
      EXPECT_LT((fd - J.col(c)).cwiseAbs().maxCoeff(), 1e-6 * (1 + J.col(c).cwiseAbs().maxCoeff())) << c;
    }
    Pose<double> back;
    ASSERT_EQ(stewart_fk(m.g, q, m.g.home, back).status, Status::Ok);
    EXPECT_LT(pose_error(pose, back).cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(StewartLegOffsets, ZeroOffsetsChangeNothingAndTooShortALegIsUnreachable) {
  StewartGeometry<double> g = make_stewart_seed001<double>();
  std::mt19937_64 rng(5);
  const Pose<double> pose = random_pose(rng);
  Vec6<double> q;
  ASSERT_EQ(stewart_ik(g, pose, q), Status::Ok);
  const Eigen::Matrix<double, 3, 6> legs = stewart_leg_vectors(g, pose);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(q(i), legs.col(i).norm(), 1e-12);  // the distance (to its rounding order)
  g.leg_offset_sq(2) = legs.col(2).squaredNorm() + 1;  // the line farther from the U centre than the S centre
  EXPECT_EQ(stewart_ik(g, pose, q), Status::Unreachable);
  g.leg_offset_sq(2) = std::nan("");
  EXPECT_EQ(stewart_ik(g, pose, q), Status::InvalidInput);
}

}  // namespace
