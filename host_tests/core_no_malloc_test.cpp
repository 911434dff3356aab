// "No malloc" enforced, not promised (Eigen's test/nomalloc.cpp): with
// EIGEN_RUNTIME_NO_MALLOC every Eigen heap allocation checks a flag; we first
// prove the trap fires, then call the core's IK/FK/Jacobians with the heap
// forbidden. eigen_assert is routed to abort() so the trap also works in
// Release builds (where NDEBUG disables assert).
#include <cstdio>
#include <cstdlib>

#include "eigen_no_malloc.hpp"  // first: before anything includes Eigen

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "kincal/core/reference_machines.hpp"

namespace {

struct HeapForbidden {
  HeapForbidden() { Eigen::internal::set_is_malloc_allowed(false); }
  ~HeapForbidden() { Eigen::internal::set_is_malloc_allowed(true); }
};

}  // namespace

TEST(CoreNoMallocDeathTest, TrapFiresOnDynamicEigen) {
  EXPECT_DEATH(
      {
        HeapForbidden guard;
        Eigen::MatrixXd m(8, 8);
        m.setIdentity();
        std::printf("%f\n", m.trace());
      },
      "eigen_assert failed");
}

template <class Scalar> void run_core_without_heap() {
  using namespace kincal;
  const StewartGeometry<Scalar> sg = make_stewart_seed001<Scalar>();
  const HybridGeometry<Scalar> hg = make_hybrid_seed000<Scalar>();
  HeapForbidden guard;
  const Pose<Scalar> sp = Pose<Scalar>::from_xyz_rpy(Scalar(10), Scalar(5), Scalar(205), Scalar(0.03), Scalar(0.02), Scalar(-0.05));
  Vec6<Scalar> q;
  Mat6<Scalar> J;
  ASSERT_EQ(stewart_ik(sg, sp, q, &J), Status::Ok);
  Pose<Scalar> out;
  ASSERT_EQ(stewart_fk(sg, q, out).status, Status::Ok);
  const Pose<Scalar> hp = Pose<Scalar>::from_xyz_rpy(Scalar(120), Scalar(-80), Scalar(30), Scalar(0.02), Scalar(0), Scalar(0.01));
  HybridPassive<Scalar> s;
  ASSERT_EQ(hybrid_ik(hg, hp, q, &J, &s), Status::Ok);
  ASSERT_EQ(hybrid_fk(hg, q, out).status, Status::Ok);
  const Twist<Scalar> e = pose_error(out, hp);
  EXPECT_LT(double(e.norm()), sizeof(Scalar) == 8 ? 1e-9 : 1e-2);
}

TEST(CoreNoMalloc, KinematicsDouble) { run_core_without_heap<double>(); }
TEST(CoreNoMalloc, KinematicsFloat) { run_core_without_heap<float>(); }
