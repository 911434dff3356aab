// A user effect added from outside the library (examples/user-effect/
// quadratic_lead.hpp, walked through in docs/effects.md): one templated
// function, registered at start-up (its identification columns are its
// derivative) and plugged into core's compensator. On data from a 6-UPS
// whose screws carry it, the diagnosis must name and accept it,
// identification must fit it, and the compensator with the plug-in must
// bring the held-out error down to the noise floor (and without the plug-in
// it must not).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "../examples/user-effect/quadratic_lead.hpp"
#include "kincal/core/compensation.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/diagnosis.hpp"
#include "kincal/identify/effect_calibration.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/simulate.hpp"

namespace ki = kincal::identify;
using kincal::Pose;
using kincal::Vec6;

namespace {

const std::string kDir = std::string(KINCAL_SOURCE_DIR) + "/examples/seed001";

struct Plant {
  ki::Robot nominal, actual;
  ki::PoseTable poses;
  ki::EffectValues truth;
};

// stewart-seed001 with the example's source errors and the screws' lead
// drift on legs 2 and 5 (up to ~35 µm at the stroke ends).
const Plant& plant() {
  static const Plant p = [] {
    ki::register_effect(quadratic_lead::effect());
    Plant out;
    out.nominal = ki::builtin_robot("stewart-seed001");
    out.actual = ki::apply_parameters(out.nominal, ki::read_parameters(kDir + "/errors.csv", out.nominal));
    out.poses = ki::read_pose_table(kDir + "/diagnosis_poses.csv");
    out.truth.set(out.nominal, "quadratic_lead", "w2", 1.5e-5);
    out.truth.set(out.nominal, "quadratic_lead", "w5", -1.2e-5);
    return out;
  }();
  return p;
}

ki::PoseTable measure(const Plant& p, const ki::EffectValues& effects, double noise_mm) {
  ki::SimulateOptions o;
  o.noise_mm = noise_mm;
  o.noise_rad = noise_mm * 5e-3;  // 1 µm ↔ 5 µrad (200 mm lever)
  o.seed = 3;
  o.effects = effects;
  ki::SimulateReport report;
  ki::PoseTable t = ki::simulate(p.nominal, p.actual, p.poses, o, report);
  EXPECT_EQ(report.failed, 0u);
  return t;
}

// Position RMS (µm) of the test rows that the actual machine (with `effects`)
// reaches for the commands of core's compensator on `model`'s table, the user
// effect plugged in or not.
double compensated_test_rms_um(const ki::CalibrationModel& model, const ki::EffectValues& effects, bool plug_in) {
  const Plant& p = plant();
  ki::PoseTable commands = p.poses;
  commands.has_q = true;
  std::visit(
      [&](const auto& table) {
        kincal::Compensator<typename std::decay_t<decltype(table)>::MachineType> compensator(table, kincal::trust_table_bounds);
        ASSERT_EQ(compensator.status(), kincal::CompensationStatus::Ok);
        if (plug_in) compensator.set_user_effect(model.effects.to_core(model.nominal).user_error);
        Vec6<double> home = Vec6<double>::Zero();
        compensator.home_command(home);
        auto state = compensator.start(home);
        for (ki::PoseRow& row : commands.rows) {
          kincal::NcPoint<double> point;
          point.pose = Pose<double>::from_xyz_rpy(row.commanded);
          Vec6<double> q;
          ASSERT_EQ(compensator.compensate(state, point, q), kincal::CompensationStatus::Ok) << row.id;
          row.q = Eigen::VectorXd(q);
        }
      },
      ki::calibration_table(model));
  // Drive the actual machine (no noise) with the compensated commands.
  double ss = 0;
  int n = 0;
  ki::SimulateOptions o;
  o.effects = effects;
  ki::SimulateReport report;
  const ki::PoseTable driven = ki::simulate(p.nominal, p.actual, commands, o, report);
  EXPECT_EQ(report.failed, 0u);
  for (const ki::PoseRow& r : driven.rows) {
    if (r.role != ki::Role::Test) continue;
    ss += (r.measured->head<3>() - r.commanded.head<3>()).squaredNorm();
    ++n;
  }
  return n > 0 ? 1000.0 * std::sqrt(ss / n) : NAN;
}

TEST(UserEffect, IsDiagnosedIdentifiedAndCompensatedThroughThePlugIn) {
  const Plant& p = plant();
  const ki::PoseTable data = measure(p, p.truth, 0.001);

  // Diagnosis: the user effect is a candidate like the built-in five.
  ki::DiagnoseOptions o;
  o.noise_um = 1.0;
  const ki::Diagnosis d = ki::diagnose(p.nominal, data, o);
  ASSERT_FALSE(d.ranking.empty());
  EXPECT_EQ(d.ranking.front().effect, "quadratic_lead");
  ASSERT_FALSE(d.accepted.empty());
  EXPECT_EQ(d.accepted.front(), "quadratic_lead");
  EXPECT_EQ(d.verdict, "explained");
  std::printf("diagnosis: held-out RMS %.2f um (base) -> %.2f um with quadratic_lead\n", d.rms.test, d.final_rms.test);

  // Identification recovers w2 and w5 (and leaves the others near zero).
  const ki::CalibrationModel model = ki::calibrate_with_effects(p.nominal, data, {"quadratic_lead"});
  const Eigen::VectorXd& w = model.effects.values.at("quadratic_lead");
  std::printf("identified w: %.3g %.3g %.3g %.3g %.3g %.3g (truth 0 1.5e-05 0 0 -1.2e-05 0)\n", w(0), w(1), w(2),
              w(3), w(4), w(5));
  EXPECT_NEAR(w(1), 1.5e-5, 1.5e-6);
  EXPECT_NEAR(w(4), -1.2e-5, 1.2e-6);

  // Compensation: the base model alone, the model with the effect but the
  // controller without its code, and with the plug-in.
  const ki::CalibrationModel base_only = ki::calibrate_with_effects(p.nominal, data, {});
  const double uncompensated = compensated_test_rms_um(base_only, p.truth, false);
  const double without_plug_in = compensated_test_rms_um(model, p.truth, false);
  const double with_plug_in = compensated_test_rms_um(model, p.truth, true);
  // The floor: the base model on the same machine without the effect.
  const ki::CalibrationModel clean = ki::calibrate_with_effects(p.nominal, measure(p, {}, 0.001), {});
  const double floor = compensated_test_rms_um(clean, {}, false);
  std::printf("held-out position RMS: base model %.2f um, effect without plug-in %.2f um, with plug-in %.2f um "
              "(clean floor %.2f um)\n",
              uncompensated, without_plug_in, with_plug_in, floor);
  EXPECT_LT(with_plug_in, 1.3 * floor);
  EXPECT_LT(with_plug_in, 0.3 * uncompensated);
  EXPECT_GT(without_plug_in, 2.0 * with_plug_in);
}

TEST(UserEffect, TwoEffectsCannotShareTheControllerSlot) {
  const Plant& p = plant();
  // A second user effect with another name wants the same slot.
  class Other final : public ki::Effect {
   public:
    std::string name() const override { return "other_user_effect"; }
    std::string description() const override { return "test"; }
    std::vector<std::string> parameter_names(const ki::Robot&) const override { return {"u"}; }
    std::string missing_inputs(const ki::PoseTable&) const override { return {}; }
    void twist_columns(const ki::Robot&, const kincal::EffectParameters<double>&, const ki::EffectNode&,
                       Eigen::Ref<Eigen::MatrixXd> c) const override {
      c.setZero();
    }
    void apply(const ki::Robot&, const Eigen::VectorXd& v, kincal::EffectParameters<double>& out) const override {
      out.user(7) += v(0);
      out.user_error = [](const double*, int, const Vec6<double>&, const kincal::EffectInputs<double>&) {
        return 0.0;
      };
    }
  };
  ki::register_effect(std::make_shared<Other>());
  ki::EffectValues both = p.truth;
  both.set(p.nominal, "other_user_effect", "u", 1.0);
  EXPECT_THROW(both.to_core(p.nominal), ki::InputError);
}

// A user effect is its function and a registration; what core's one slot
// cannot hold is refused when the effect is made, not when it is used.
TEST(UserEffect, WhatCoresSlotCannotHoldIsRefusedWhenTheEffectIsMade) {
  const auto f = &quadratic_lead::joint_error<double>;
  const auto fd = &quadratic_lead::joint_error<ki::EffectDual>;
  EXPECT_NO_THROW(ki::UserJointEffect("ok", "d", {"u1"}, f, fd));
  EXPECT_THROW(ki::UserJointEffect("", "d", {"u1"}, f, fd), std::invalid_argument);
  EXPECT_THROW(ki::UserJointEffect("none", "d", {}, f, fd), std::invalid_argument);
  std::vector<std::string> one_too_many;  // core's slot holds kUserEffectParameters
  for (int k = 0; k <= kincal::kUserEffectParameters; ++k) one_too_many.push_back("u" + std::to_string(k + 1));
  EXPECT_THROW(ki::UserJointEffect("too_many", "d", one_too_many, f, fd), std::invalid_argument);
  EXPECT_THROW(ki::UserJointEffect("no_derivative", "d", {"u1"}, f, nullptr), std::invalid_argument);
}

}  // namespace
