// The controller loop allocates nothing (GUIDE "No malloc is enforced, not
// promised"; Eigen's test/nomalloc.cpp): with EIGEN_RUNTIME_NO_MALLOC every
// Eigen heap allocation checks a flag, and here the whole loop — table check,
// register writes, stream, compensation of every point including failures —
// runs with the flag down. The outputs go to a fixed array, not a container.
// (The firmware image additionally fails to link if anything reaches the
// heap: docs/firmware.md "No heap".)
#include <cstdio>
#include <cstdlib>

#include "eigen_no_malloc.hpp"  // first: before anything includes Eigen

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>

#include "kincal/core/compensation.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/core/rus6_machine.hpp"
#include "kincal/port/controller.hpp"
#include "kincal/port/emulator/encoder_registers.hpp"
#include "kincal/port/emulator/nc_stream.hpp"

namespace {

using namespace kincal;
using namespace kincal::port;

struct HeapForbidden {
  HeapForbidden() { Eigen::internal::set_is_malloc_allowed(false); }
  ~HeapForbidden() { Eigen::internal::set_is_malloc_allowed(true); }
};

TEST(PortNoMallocDeathTest, TrapFires) {
  EXPECT_DEATH(
      {
        HeapForbidden guard;
        Eigen::MatrixXd m(6, 6);
        m.setIdentity();
        std::printf("%f\n", m.trace());
      },
      "eigen_assert failed");
}

template <class Machine> void run_without_heap(const CalibrationTable<Machine>& table, const CalibrationTable<Machine>& nominal,
                                               const Vec6<double>& centre, const Vec6<double>& span) {
  using Scalar = typename Machine::Scalar;
  static emulator::EncoderRegisters regs;
  static emulator::NcStream<Scalar, 4, 4> stream;
  regs = emulator::EncoderRegisters();
  stream = emulator::NcStream<Scalar, 4, 4>();
  ControllerConfig<Scalar> config;
  config.scaling = EncoderOffsetScaling<Scalar>::template of<Machine>();
  constexpr int kPoints = 200;
  static JointCommand<Scalar> out[kPoints];
  int n_out = 0;
  {
    HeapForbidden guard;
    const MachineLimits<Scalar> limits = limits_from_bounds(nominal.bounds);
    Controller<Machine, emulator::EncoderRegisters, emulator::NcStream<Scalar, 4, 4>> ctl(regs, stream, table, nominal,
                                                                                           limits, config);
    ctl.start();
    int next = 0;
    for (int period = 0; period < 10 * kPoints && n_out < kPoints; ++period) {
      if (next < kPoints && period % 2 == 0) {
        NcInput<Scalar> p;
        p.sequence = static_cast<std::uint32_t>(next + 1);
        const double s = double(next) / kPoints;
        for (int i = 0; i < 6; ++i) p.pose(i) = Scalar(centre(i) + span(i) * std::sin(7.0 * s + i));
        if (next % 37 == 5) p.pose(0) = std::numeric_limits<Scalar>::quiet_NaN();  // refused, held
        if (next % 53 == 7) p.pose(2) = Scalar(centre(2) + 1e4);                    // out of reach
        if (stream.push(p) == PortStatus::Ok) ++next;
        if (next == kPoints) stream.end();
      }
      ctl.step();
      JointCommand<Scalar> c;
      while (n_out < kPoints && stream.pop(c)) out[n_out++] = c;
    }
    EXPECT_EQ(ctl.counters().points, static_cast<std::uint32_t>(kPoints));
    EXPECT_GT(ctl.counters().held, 0u);
    EXPECT_GT(ctl.counters().compensated, 150u);
  }
  ASSERT_EQ(n_out, kPoints);
  for (int k = 0; k < kPoints; ++k) EXPECT_EQ(out[k].sequence, static_cast<std::uint32_t>(k + 1));
}

TEST(PortNoMalloc, HybridControllerLoop) {
  static const HybridCalibrationTabled nominal = nominal_table(make_hybrid_seed000<double>());
  static const HybridCalibrationTabled table = [] {
    HybridCalibrationTabled t = nominal;
    for (int i = 0; i < 6; ++i) t.machine.encoder_offsets[i] = i < 3 ? 0.2 : 3e-4;
    for (int k = 6; k < HybridErrorLayout::tool(); k += 5) t.machine.source_errors[k] = 0.02;
    // The tool frame too (a 0.02 rad tool rotation would need more wrist
    // correction than the default bound).
    t.machine.source_errors[HybridErrorLayout::tool() + 1] = -0.04;
    t.machine.source_errors[HybridErrorLayout::tool() + 4] = 2e-3;
    t.effects.scale[0] = 1e-4;
    return seal_table(t);
  }();
  Vec6<double> centre, span;
  centre << 0, 0, 0, 0, 0, 0;
  span << 200, 200, 50, 0.05, 0.05, 0.05;
  run_without_heap(table, nominal, centre, span);
}

TEST(PortNoMalloc, StewartControllerLoopInFloat) {
  static const StewartCalibrationTablef nominal = nominal_table(make_stewart_seed001<float>());
  static const StewartCalibrationTablef table = [] {
    StewartCalibrationTablef t = nominal;
    for (int i = 0; i < 6; ++i) t.machine.calibrated.length_offset[i] = 0.05f;
    return seal_table(t);
  }();
  Vec6<double> centre, span;
  centre << 0, 0, 200, 0, 0, 0;
  span << 20, 20, 10, 0.03, 0.03, 0.05;
  run_without_heap(table, nominal, centre, span);
}

// The 6-RUS's compensator (core/rus6_machine.hpp: the calibrated geometry's
// closed-form IK), in double and float, through the same controller.
template <class S> void run_rus6_without_heap() {
  static const Rus6CalibrationTable<S> nominal = nominal_table(make_rus6_ref<S>());
  static const Rus6CalibrationTable<S> table = [] {
    Rus6CalibrationTable<S> t = nominal;
    for (int i = 0; i < 6; ++i) {
      t.machine.calibrated.joint_offset[i] = S(2e-3);
      t.machine.calibrated.rod_length[i] += S(0.05);
      t.machine.calibrated.shaft_points[3 * i + 2] += S(0.03);
    }
    return seal_table(t);
  }();
  Vec6<double> centre, span;
  centre << 0, 0, 274, 0, 0, 0;
  span << 30, 30, 30, 0.1, 0.1, 0.1;
  run_without_heap(table, nominal, centre, span);
}

TEST(PortNoMalloc, Rus6ControllerLoop) { run_rus6_without_heap<double>(); }
TEST(PortNoMalloc, Rus6ControllerLoopInFloat) { run_rus6_without_heap<float>(); }

}  // namespace
