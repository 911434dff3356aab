// The controller's compensation (core/) against identify's reference
// implementation, and the parameter table built from an identified model:
//   - hybrid_error_twist = identify's B·Δχ (seed 000 Eq. (8)) without forming B;
//   - the core Compensator = identify::compensate_hybrid (Eq. (16)) and, for the
//     6-UPS, the IK of calibrated_robot(model) (seed 001);
//   - the table from MODEL.json passes its check, survives the float cast, and
//     `kincal compensate` is exactly this routine.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "kincal/core/compensation.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/stewart_calibration.hpp"

namespace {

using namespace kincal;
namespace ki = kincal::identify;

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// A pose in the hybrid's task cuboid (500 × 500 × 120 mm, ±5° of orientation).
Pose<double> hybrid_pose(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return Pose<double>::from_xyz_rpy(250 * u(rng), 250 * u(rng), 60 * u(rng), 5 * kDeg * u(rng), 5 * kDeg * u(rng),
                                    5 * kDeg * u(rng));
}

// Source errors of the size seed 000's machine has (encoder offsets of tenths
// of a millimetre / milliradian, structural errors of tens of micrometres and
// a tenth of a milliradian), every one of the 150 non-zero.
Eigen::VectorXd random_errors(const ki::HybridErrorModel& m, std::mt19937_64& rng, bool encoders) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::VectorXd chi(m.size());
  for (int k = 0; k < m.size(); ++k) {
    const ki::HybridErrorParameter& p = m.parameters()[static_cast<std::size_t>(k)];
    const double sigma = p.encoder() ? (p.angular() ? 5e-4 : 0.3) : (p.angular() ? 1e-4 : 0.03);
    chi(k) = (p.encoder() && !encoders) ? 0.0 : sigma * n(rng);
  }
  return chi;
}

ki::CalibrationModel hybrid_model_with(const Eigen::VectorXd& chi) {
  ki::CalibrationModel model;
  model.nominal = ki::builtin_robot("hybrid-seed000");
  model.estimator = "liu";
  const ki::HybridErrorModel m(model.nominal.hybrid());
  for (int k = 0; k < m.size(); ++k)
    model.parameters.push_back({m.parameters()[static_cast<std::size_t>(k)].name, chi(k), 0.0, true});
  return model;
}

TEST(identifyCalibrationTable, HybridErrorTwistEqualsBTimesChi) {
  const HybridGeometry<double> g = make_hybrid_seed000<double>();
  const ki::HybridErrorModel model(g);
  const HybridGeometry<float> gf = g.cast<float>();
  std::mt19937_64 rng(5);
  Eigen::MatrixXd B;
  double worst = 0, worst_float_mm = 0, worst_float_rad = 0;
  for (int k = 0; k < 200; ++k) {
    const Pose<double> pose = hybrid_pose(rng);
    const Eigen::VectorXd chi = random_errors(model, rng, true);
    ASSERT_EQ(model.error_jacobian(pose, B), Status::Ok);
    const Twist<double> expected = B * chi;
    HybridFrames<double> f;
    Vec3<double> angles;
    ASSERT_EQ(hybrid_frames_at_pose(g, pose, f, angles), Status::Ok);
    Twist<double> got;
    ASSERT_EQ(hybrid_error_twist(g, ki::HybridErrorModelOptions().up_split, f, chi.data(), got), Status::Ok);
    // Relative to the twist's size, angles taken at 1 m.
    Twist<double> scale_err = got - expected;
    scale_err.tail<3>() *= 1000.0;
    Twist<double> scaled = expected;
    scaled.tail<3>() *= 1000.0;
    worst = std::max(worst, scale_err.norm() / scaled.norm());
    // float: the same twist from float geometry, pose and errors.
    const Eigen::Matrix<float, ki::HybridErrorModel::kParameterCount, 1> chif = chi.cast<float>();
    HybridFrames<float> ff;
    Vec3<float> af;
    ASSERT_EQ(hybrid_frames_at_pose(gf, pose.cast<float>(), ff, af), Status::Ok);
    Twist<float> tf;
    ASSERT_EQ(hybrid_error_twist(gf, 345.0f, ff, chif.data(), tf), Status::Ok);
    const Twist<double> df = tf.cast<double>() - expected;
    worst_float_mm = std::max(worst_float_mm, df.head<3>().norm());
    worst_float_rad = std::max(worst_float_rad, df.tail<3>().norm());
  }
  std::printf("hybrid error twist vs identify B*chi: double worst relative %.2e; float worst %.2e mm, %.2e rad\n",
              worst, worst_float_mm, worst_float_rad);
  EXPECT_LT(worst, 1e-9);
  EXPECT_LT(worst_float_mm, 1e-4);  // |$_t| ~ 1 mm: float's 7 digits
  EXPECT_LT(worst_float_rad, 1e-7);
}

TEST(identifyCalibrationTable, HybridCompensatorEqualsCompensateHybrid) {
  std::mt19937_64 rng(11);
  const ki::HybridErrorModel m(make_hybrid_seed000<double>());
  const ki::CalibrationModel model = hybrid_model_with(random_errors(m, rng, true));
  const ki::HybridCompensation reference = ki::hybrid_compensation_from_model(model);
  const HybridCalibrationTable<double> table = ki::hybrid_calibration_table(model);
  ASSERT_EQ(validate_table(table), CompensationStatus::Ok);
  const HybridCompensator<double> comp(table, trust_table_bounds);
  ASSERT_EQ(comp.status(), CompensationStatus::Ok);
  const HybridCalibrationTable<float> table_f = table_cast<float>(table);
  ASSERT_EQ(validate_table(table_f), CompensationStatus::Ok);
  const HybridCompensator<float> comp_f(table_f, trust_table_bounds);
  Vec6<double> home;
  ASSERT_EQ(comp.home_command(home), CompensationStatus::Ok);
  auto state = comp.start(home);
  auto state_f = comp_f.start(home.cast<float>());
  double worst_mm = 0, worst_rad = 0, float_mm = 0, float_rad = 0;
  for (int k = 0; k < 300; ++k) {
    const Pose<double> pose = hybrid_pose(rng);
    Vec6<double> expected, got;
    ASSERT_EQ(ki::compensate_hybrid(reference, pose, expected), Status::Ok);
    ASSERT_EQ(comp.compensate(state, pose, got), CompensationStatus::Ok);
    worst_mm = std::max(worst_mm, (got - expected).head<3>().cwiseAbs().maxCoeff());
    worst_rad = std::max(worst_rad, (got - expected).tail<3>().cwiseAbs().maxCoeff());
    Vec6<float> qf;
    ASSERT_EQ(comp_f.compensate(state_f, pose.cast<float>(), qf), CompensationStatus::Ok);
    float_mm = std::max(float_mm, (qf.cast<double>() - expected).head<3>().cwiseAbs().maxCoeff());
    float_rad = std::max(float_rad, (qf.cast<double>() - expected).tail<3>().cwiseAbs().maxCoeff());
  }
  std::printf("hybrid compensation, core vs identify::compensate_hybrid: double %.2e mm, %.2e rad; "
              "float %.2e mm, %.2e rad\n",
              worst_mm, worst_rad, float_mm, float_rad);
  EXPECT_LT(worst_mm, 1e-9);
  EXPECT_LT(worst_rad * 1000.0, 1e-9);  // rad at 1 m: mm-equivalent
  EXPECT_LT(float_mm, 2e-3);
  EXPECT_LT(float_rad, 2e-6);
  EXPECT_EQ(state.count(CompensationStatus::Ok), 300u);
  EXPECT_EQ(state.failures(), 0u);
}

TEST(identifyCalibrationTable, StewartCompensatorIsTheCalibratedIk) {
  ki::CalibrationModel model;
  model.nominal = ki::builtin_robot("stewart-seed001");
  model.estimator = "ols";
  const char* const kinds[7] = {"dXB", "dYB", "dZB", "dl", "dXP", "dYP", "dZP"};
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, 0.05);
  for (int leg = 1; leg <= 6; ++leg)
    for (const char* kind : kinds) model.parameters.push_back({kind + std::to_string(leg), n(rng), 0.0, true});
  const ki::Robot calibrated = ki::calibrated_robot(model);
  const StewartCalibrationTable<double> table = ki::stewart_calibration_table(model);
  ASSERT_EQ(validate_table(table), CompensationStatus::Ok);
  const StewartCompensator<double> comp(table, trust_table_bounds);
  Vec6<double> home;
  ASSERT_EQ(comp.home_command(home), CompensationStatus::Ok);
  auto state = comp.start(home);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = 0;
  for (int k = 0; k < 200; ++k) {
    const Pose<double> pose =
        Pose<double>::from_xyz_rpy(20 * u(rng), 20 * u(rng), 200 + 15 * u(rng), 3 * kDeg * u(rng), 3 * kDeg * u(rng),
                                   3 * kDeg * u(rng));
    Vec6<double> expected, got;
    ASSERT_EQ(calibrated.inverse(pose, expected), Status::Ok);
    ASSERT_EQ(comp.compensate(state, pose, got), CompensationStatus::Ok);
    worst = std::max(worst, (got - expected).cwiseAbs().maxCoeff());
  }
  EXPECT_EQ(worst, 0.0);  // the same IK on the same numbers
}

TEST(identifyCalibrationTable, TableFromModelCarriesEffectsAndChecks) {
  std::mt19937_64 rng(2);
  const ki::HybridErrorModel m(make_hybrid_seed000<double>());
  ki::CalibrationModel model = hybrid_model_with(random_errors(m, rng, true));
  model.effects.set(model.nominal, "scale", "s1", 1e-4);
  model.effects.set(model.nominal, "thermal", "c", 1.2e-5);
  const HybridCalibrationTable<double> t = ki::hybrid_calibration_table(model);
  EXPECT_EQ(t.version, kCalibrationTableVersion);
  EXPECT_EQ(t.family, MachineFamily::Hybrid);
  EXPECT_EQ(t.crc, table_crc(t));
  EXPECT_EQ(t.effects.scale[0], 1e-4);
  EXPECT_EQ(t.effects.thermal, 1.2e-5);
  // The weight and the thermal origin in the workpiece frame (identify's effect frame).
  const EffectParameters<double> frame = model.effects.to_core(model.nominal);
  EXPECT_EQ(to_core(t.effects).load_direction, frame.load_direction);
  EXPECT_EQ(t.effects.screw_joints, double(frame.screw_joints));
  for (int i = 0; i < 6; ++i) EXPECT_EQ(t.machine.source_errors[i], 0.0);
  // Round trip through the canonical value list.
  double values[table_value_count<HybridMachine<double>>()];
  table_to_values(t, values);
  const HybridCalibrationTable<double> back = table_from_values<HybridMachine<double>>(values, t.crc);
  EXPECT_EQ(validate_table(back), CompensationStatus::Ok);
  // A correction bound below an encoder offset is refused with the reason.
  ki::CalibrationTableOptions tight;
  tight.max_correction = Vec6<double>::Constant(1e-6);
  try {
    ki::hybrid_calibration_table(model, tight);
    ADD_FAILURE() << "expected InputError";
  } catch (const ki::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("table values"), std::string::npos) << e.what();
  }
  // The wrong family is refused.
  EXPECT_THROW(ki::stewart_calibration_table(model), ki::InputError);
  EXPECT_TRUE(std::holds_alternative<HybridCalibrationTable<double>>(ki::calibration_table(model)));
}

}  // namespace
