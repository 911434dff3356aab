// Pose-math properties that need more than the portable checks: the adjoint of
// seed 000 Eq. transports a twist between reference points exactly as
// moving the body does.
#include <gtest/gtest.h>

#include "kincal/core/pose.hpp"

using namespace kincal;

TEST(CorePose, AdjointTransportsTwistBetweenPoints) {
  // A body with a frame at A (rotation R) gets a small twist t_A (v at A, ω),
  // expressed in A's frame. Seen at P (r = A − P) in base axes the twist must be
  // Ad(R, r)·t_A: compare with the finite motion of the point P.
  const Mat3<double> R = rotation_from_rpy(0.3, -0.2, 1.1);
  const Vec3<double> A(100, -50, 300), P(20, 40, 0);
  Twist<double> tA;
  tA << 0.01, -0.02, 0.005, 1e-4, -2e-4, 3e-4;
  const Twist<double> tP = adjoint(R, Vec3<double>(A - P)) * tA;
  // Move the body: its rotation increment is exp(R·ω) and A moves by R·v.
  const Vec3<double> w = R * tA.tail<3>();
  const Vec3<double> A_new = A + R * tA.head<3>();
  const Mat3<double> dR = exp_so3(w);
  const Vec3<double> P_new = A_new + dR * (P - A);
  EXPECT_LT((P_new - P - tP.head<3>()).norm(), 5e-5);  // second order: ½|ω|²|r| ≈ 2e-5
  EXPECT_LT((tP.tail<3>() - w).norm(), 1e-15);
}

TEST(CorePose, RpyConventionMatchesGuide) {
  // R = Rz(rz)·Ry(ry)·Rx(rx): a pure rz turns x into y.
  const Mat3<double> R = rotation_from_rpy(0.0, 0.0, 3.14159265358979323846 / 2);
  EXPECT_NEAR((R * Vec3<double>::UnitX() - Vec3<double>::UnitY()).norm(), 0.0, 1e-15);
  const Mat3<double> R2 = rotation_from_rpy(0.1, 0.2, 0.3);
  EXPECT_NEAR((R2 - rot_z(0.3) * rot_y(0.2) * rot_x(0.1)).norm(), 0.0, 1e-15);
}
