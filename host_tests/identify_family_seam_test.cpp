// The family seam's contract (identify/src/families/family.hpp), checked on
// every registered family the same way: what a third family must satisfy
// before identify, diagnose, simulate and plan can rely on it
// (docs/architecture.md "Adding a machine family").
//
// Independent evidence rather than the families' own code paths:
// - the forward Jacobian and the error twists against central finite
//   differences of the family's own nonlinear pose (FamilyErrors::pose);
// - the description against a write → parse → write round trip;
// - the simulated machine with no errors against the commanded pose;
// - the measurement model's map against finite differences of its prediction;
// - every joint-space effect's identification columns (derivatives of core's
//   correction by automatic differentiation) against central finite
//   differences of the family's nonlinear pose at the commands core's
//   effect_joint_error moves, in double; with the five built-ins and a user
//   effect nonlinear in q that this test writes and registers itself.
// Robots: the three built-ins, a hexapod of another size (legs 0.6–1.1 m)
// and a 6-RUS of another size and layout from a description file
// (large_rus6.hpp), at home and at poses drawn at random around it (not a
// grid).
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "../identify/src/families/family.hpp"
#include "../identify/src/families/family_errors.hpp"
#include "kincal/core/effects.hpp"
#include "large_rus6.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/measurement_model.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/target_calibration.hpp"
#include "large_hexapod.hpp"

namespace ki = kincal::identify;
using kincal::Mat6;
using kincal::Pose;
using kincal::Status;
using kincal::Vec6;

namespace {

ki::Robot robot_named(const std::string& name) {
  if (name == "large-hexapod") return kincal_test::large_hexapod();
  if (name == "large-rus6") return kincal_test::large_rus6();
  return ki::builtin_robot(name);
}

// Poses around home the nominal IK reaches within the limits: random
// offsets of up to 5 % of the machine's reach and 0.05 rad.
std::vector<Pose<double>> poses_around_home(const ki::Robot& robot, int count, unsigned seed) {
  const ki::Family& family = ki::family_of(robot);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double size = 0.05 * family.kinematics().reach(robot);
  Vec6<double> lo, hi;
  robot.joint_limits(lo, hi);
  std::vector<Pose<double>> out{robot.home_pose()};
  for (int tries = 0; tries < 1000 && int(out.size()) < count; ++tries) {
    Vec6<double> x = robot.home_pose().to_xyz_rpy();
    for (int d = 0; d < 3; ++d) x(d) += size * unit(rng);
    for (int d = 3; d < 6; ++d) x(d) += 0.05 * unit(rng);
    const Pose<double> pose = Pose<double>::from_xyz_rpy(x);
    Vec6<double> q;
    if (family.kinematics().inverse(robot, pose, q) != Status::Ok) continue;
    if (((q.array() < lo.array()) || (q.array() > hi.array())).any()) continue;
    out.push_back(pose);
  }
  EXPECT_EQ(int(out.size()), count) << "too few reachable poses around home";
  return out;
}

// The machine's pose for joint commands q and error values, by the family's
// own nonlinear model, started from the nominal IK's configuration.
Pose<double> pose_at(const ki::detail::FamilyErrors& errors, const Pose<double>& commanded, const Vec6<double>& q,
                     const Eigen::VectorXd& values) {
  ki::detail::NodeGuess guess = errors.start(commanded);
  Pose<double> pose;
  EXPECT_TRUE(errors.pose(values, q, guess, pose));
  return pose;
}

class FamilySeam : public ::testing::TestWithParam<std::string> {
 protected:
  ki::Robot robot = robot_named(GetParam());
  const ki::Family& family = ki::family_of(robot);
};

TEST_P(FamilySeam, TheRegistryFindsTheFamilyByRobotAndByName) {
  EXPECT_STREQ(family.name(), robot.family());
  EXPECT_EQ(ki::family_named(family.name()), &family);
  EXPECT_TRUE(family.description().describes(robot));
  EXPECT_EQ(ki::family_named("no-such-family"), nullptr);
  EXPECT_NE(ki::family_names().find(family.name()), std::string::npos);
  // Another family's robot is not this family's.
  const ki::Robot other = robot_named(robot.is_stewart() ? "hybrid-seed000" : "stewart-seed001");
  EXPECT_FALSE(family.description().describes(other));
}

// Who reads a table: the family's own pipeline or the family-free target
// fit, never both and never neither. What each family is expected to do is
// written here, by hand (the 6-UPS's own pipeline reads full poses, the
// hybrid's reads its gauge's targets, the 6-RUS has none), not read off
// the family; the library's router (uses_target_model) must agree with it.
TEST_P(FamilySeam, EachTableHasOneReaderTheOwnPipelineOrTheTargetFit) {
  ki::PoseTable poses, targets;
  poses.has_measured = true;
  targets.has_targets = true;
  const std::string kind = family.name();
  const bool own_reads_poses = kind == ki::kStewartFamily;
  const bool own_reads_targets = kind == ki::kHybridFamily;
  EXPECT_EQ(family.own_pipeline() != nullptr, own_reads_poses || own_reads_targets);
  EXPECT_EQ(family.pipeline_reading(robot, poses) != nullptr, own_reads_poses);
  EXPECT_EQ(family.pipeline_reading(robot, targets) != nullptr, own_reads_targets);
  EXPECT_EQ(ki::uses_target_model(robot, poses), !own_reads_poses);
  EXPECT_EQ(ki::uses_target_model(robot, targets), !own_reads_targets);
  for (const ki::PoseTable* t : {&poses, &targets}) {
    EXPECT_EQ(family.measurement().missing_measurement(robot, *t), "");
    if (const ki::FamilyPipeline* reader = family.pipeline_reading(robot, *t)) {
      EXPECT_EQ(reader, family.own_pipeline());
      EXPECT_STRNE(reader->base_fit(), "");
    }
  }
  // A table with neither is refused with a message, whoever would read it.
  EXPECT_NE(family.measurement().missing_measurement(robot, ki::PoseTable{}), "");
  // Targets in the instrument's frame go to the target fit, whoever reads
  // them in the base frame (only it estimates the registration).
  ki::PoseTable in_tracker = targets;
  in_tracker.in_instrument_frame = true;
  EXPECT_EQ(family.pipeline_reading(robot, in_tracker), nullptr);
  EXPECT_TRUE(ki::uses_target_model(robot, in_tracker));
  // The description's own targets send even the hybrid's targets to the
  // target fit (they are not its gauge).
  ki::Robot with_targets = robot;
  with_targets.targets = {kincal::Vec3<double>(10, 20, 30)};
  EXPECT_EQ(family.pipeline_reading(with_targets, targets), nullptr);
}

TEST_P(FamilySeam, DescriptionRoundTripsThroughWriteAndParse) {
  const std::string json = ki::robot_to_json(robot);
  const ki::Robot again = ki::parse_robot(json, "round-trip.json");
  EXPECT_EQ(ki::robot_to_json(again), json);
  EXPECT_EQ(&ki::family_of(again), &family);
  EXPECT_FALSE(ki::robot_summary(robot).empty());
}

TEST_P(FamilySeam, HomeIsReachableInsideTheLimits) {
  Vec6<double> lo, hi, q;
  family.kinematics().joint_limits(robot, lo, hi);
  const std::vector<ki::PassiveLimit> passive_limits = family.kinematics().passive_limits(robot);
  ASSERT_LE(passive_limits.size(), 4u);
  double passive[4] = {0, 0, 0, 0};
  ASSERT_EQ(family.kinematics().inverse(robot, family.kinematics().home_pose(robot), q, nullptr, passive), Status::Ok);
  for (int i = 0; i < 6; ++i) {
    EXPECT_GE(q(i), lo(i)) << "joint " << i + 1;
    EXPECT_LE(q(i), hi(i)) << "joint " << i + 1;
  }
  for (std::size_t k = 0; k < passive_limits.size(); ++k) {
    EXPECT_GE(passive[k], passive_limits[k].lo) << passive_limits[k].name;
    EXPECT_LE(passive[k], passive_limits[k].hi) << passive_limits[k].name;
  }
  EXPECT_GT(family.kinematics().reach(robot), 0.0);
  EXPECT_GT(family.kinematics().characteristic_length(robot), 0.0);
  const kincal::TableBounds<double> bounds = family.table().default_bounds(robot);
  for (int i = 0; i < 6; ++i) EXPECT_GT(bounds.max_correction[i], 0.0);
}

TEST_P(FamilySeam, ForwardJacobianMatchesFiniteDifferencesOfTheFamilysOwnPose) {
  const std::unique_ptr<ki::detail::FamilyErrors> errors = ki::detail::family_errors(robot);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(errors->size());
  for (const Pose<double>& commanded : poses_around_home(robot, 5, 11)) {
    Vec6<double> q;
    Mat6<double> J;
    ASSERT_TRUE(family.kinematics().forward_jacobian(robot, commanded, q, J));
    for (int i = 0; i < 6; ++i) {
      const double h = family.kinematics().revolute(i) ? 1e-6 : 1e-4;  // rad, mm
      Vec6<double> up = q, down = q;
      up(i) += h;
      down(i) -= h;
      const Vec6<double> fd = kincal::pose_error(pose_at(*errors, commanded, up, zero),
                                                 pose_at(*errors, commanded, down, zero)) / (2 * h);
      EXPECT_LT((fd - J.col(i)).norm(), 1e-5 * std::max(1.0, J.col(i).norm())) << "joint " << i + 1;
    }
  }
}

TEST_P(FamilySeam, ErrorTwistsMatchFiniteDifferencesOfTheFamilysOwnPose) {
  const std::unique_ptr<ki::detail::FamilyErrors> errors = ki::detail::family_errors(robot);
  const int n = errors->size();
  ASSERT_EQ(int(errors->names().size()), n);
  ASSERT_EQ(int(errors->units().size()), n);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  // Every column of the 6-UPS's 42; every 7th of the hybrid's 150 and its
  // six encoder offsets.
  std::vector<int> columns;
  for (int j = 0; j < n; ++j)
    if (n <= 60 || j < 6 || j % 7 == 0) columns.push_back(j);
  for (const Pose<double>& commanded : poses_around_home(robot, 3, 5)) {
    Vec6<double> q;
    ASSERT_EQ(family.kinematics().inverse(ki::without_limits(robot), commanded, q), Status::Ok);
    const Pose<double> reached = pose_at(*errors, commanded, q, zero);
    const Eigen::MatrixXd T = errors->twist_columns(zero, reached);
    Eigen::MatrixXd nominal;
    ASSERT_TRUE(errors->nominal_twist_columns(reached, nominal));
    EXPECT_LT((nominal - T).norm(), 1e-9 * std::max(1.0, T.norm()));
    for (int j : columns) {
      const double h = errors->units()[std::size_t(j)] == "rad" ? 1e-6 : 1e-4;
      Eigen::VectorXd up = zero, down = zero;
      up(j) = h;
      down(j) = -h;
      const Vec6<double> fd =
          kincal::pose_error(pose_at(*errors, commanded, q, up), pose_at(*errors, commanded, q, down)) / (2 * h);
      EXPECT_LT((fd - T.col(j)).norm(), 1e-5 * std::max(1.0, T.col(j).norm())) << errors->names()[std::size_t(j)];
    }
    const std::vector<Eigen::Index> kept = errors->identifiable_columns(T);
    EXPECT_TRUE(std::is_sorted(kept.begin(), kept.end()));
    EXPECT_EQ(std::set<Eigen::Index>(kept.begin(), kept.end()).size(), kept.size());
    for (Eigen::Index j : kept) EXPECT_TRUE(j >= 0 && j < n);
    if (!errors->selects_columns()) {
      EXPECT_EQ(Eigen::Index(kept.size()), n);
    }
  }
}

TEST_P(FamilySeam, ParameterNamesAreUniqueWithUnitsAndSymmetricAliases) {
  std::set<std::string> names;
  for (const ki::ParameterSpec& s : family.error_model().parameter_specs(robot)) {
    EXPECT_TRUE(names.insert(s.name).second) << "twice: " << s.name;
    EXPECT_TRUE(std::string(s.unit) == "mm" || std::string(s.unit) == "rad") << s.name;
  }
  if (robot.is_stewart()) {  // with the key leg_offset_sq: six more, in mm² (squared leg-line offsets)
    ki::Robot with_legs = robot;
    with_legs.stewart_description().models_leg_offsets = true;
    const std::vector<ki::ParameterSpec>& specs = family.error_model().parameter_specs(with_legs);
    ASSERT_EQ(specs.size(), family.error_model().parameter_specs(robot).size() + 6);
    for (std::size_t k = specs.size() - 6; k < specs.size(); ++k) {
      EXPECT_TRUE(names.insert(specs[k].name).second) << "twice: " << specs[k].name;
      EXPECT_EQ(std::string(specs[k].unit), "mm2") << specs[k].name;
    }
  }
  for (const std::string& name : names) {
    const std::string alias = family.error_model().alias_of(name);
    if (alias.empty()) continue;
    EXPECT_TRUE(names.count(alias)) << name << " -> " << alias;
    EXPECT_EQ(family.error_model().alias_of(alias), name);
  }
}

TEST_P(FamilySeam, TheSimulatedMachineWithoutErrorsReachesTheCommandedPose) {
  const std::unique_ptr<ki::ActualMachine> machine = family.kinematics().actual_machine(robot, robot);
  for (const Pose<double>& commanded : poses_around_home(robot, 6, 3)) {
    ki::PoseRow row;
    row.commanded = commanded.to_xyz_rpy();
    const ki::ReachedPose reached = machine->reach(row, {});
    ASSERT_EQ(reached.status, Status::Ok) << reached.stage;
    EXPECT_LT(kincal::pose_error(reached.pose, commanded).norm(), 1e-8);
  }
}

TEST_P(FamilySeam, AModelWithoutErrorsGivesATableThatPassesItsCheck) {
  ki::CalibrationModel model;
  model.nominal = robot;
  const ki::AnyCalibrationTable table = ki::calibration_table(model);
  EXPECT_TRUE(std::visit(
      [&](const auto& t) { return kincal::validate_table(t, ki::machine_limits(robot)) == kincal::CompensationStatus::Ok; },
      table));
}

// The measurement model's map against central finite differences of its own
// prediction along each twist direction (apply_twist), for the tracker's
// targets seen from a turned and shifted instrument, seed 000's gauge (the
// hybrid family's own targets) and one target at the tool point; and the
// full pose's map against pose_error of the twisted pose.
// A user joint effect of another shape than the built-ins (nonlinear in q,
// coupling two joints), written once as a template.
template <class Scalar>
Scalar wobble(const Scalar* u, int joint, const Vec6<Scalar>& q, const kincal::EffectInputs<Scalar>& in) {
  using std::sin;
  const Scalar other = q((joint + 1) % 6);
  return u[0] * sin(q(joint) / Scalar(7)) + u[1] * other * other * Scalar(1e-3) + u[2] * in.direction(joint);
}

TEST_P(FamilySeam, EffectColumnsAreTheDerivativeOfCoresCorrectionOnTheFamilysPose) {
  ki::register_effect(std::make_shared<ki::UserJointEffect>("wobble", "test: nonlinear in q",
                                                            std::vector<std::string>{"u1", "u2", "u3"},
                                                            &wobble<double>, &wobble<ki::EffectDual>));
  const std::unique_ptr<ki::detail::FamilyErrors> errors = ki::detail::family_errors(robot);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(errors->size());
  const kincal::EffectParameters<double> frame = ki::effect_frame(robot);
  const ki::Robot open = ki::without_limits(robot);
  std::mt19937 rng(17);
  int checked = 0;
  for (const Pose<double>& commanded : poses_around_home(robot, 3, 23)) {
    ki::EffectNode node;
    node.pose = commanded;
    ASSERT_TRUE(family.kinematics().forward_jacobian(open, commanded, node.q, node.joint_twist));
    node.inputs.load = kincal::static_load_forward(node.joint_twist, frame.load_direction);
    for (int i = 0; i < 6; ++i) node.inputs.direction(i) = rng() % 2 ? 1.0 : -1.0;
    for (const std::shared_ptr<const ki::Effect>& effect : ki::effect_registry()) {
      if (!effect->acts_on_joints()) continue;
      const int n = int(effect->parameter_names(robot).size());
      Eigen::MatrixXd columns(6, n);
      effect->twist_columns(robot, frame, node, columns);
      for (int k = 0; k < n; ++k) {
        // A step that moves the joints by ~1e-4 mm (rad).
        const double h = 1e-4 / std::max(columns.col(k).norm(), 1e-3);
        auto reached = [&](double value) {
          Eigen::VectorXd values = Eigen::VectorXd::Zero(n);
          values(k) = value;
          kincal::EffectParameters<double> e = frame;
          effect->apply(robot, values, e);
          const Vec6<double> dq = kincal::effect_joint_error(e, node.q, node.inputs);
          return pose_at(*errors, commanded, Vec6<double>(node.q + dq), zero);
        };
        const Vec6<double> fd = kincal::pose_error(reached(h), reached(-h)) / (2 * h);
        EXPECT_LT((fd - columns.col(k)).norm(), 1e-5 * std::max(1.0, columns.col(k).norm()))
            << effect->name() << " " << effect->parameter_names(robot)[std::size_t(k)];
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 3 * 20);  // scale, backlash, compliance (6 each), cyclic, wobble's 3, per pose
}

// The allocation-free forms the per-node loops use (design_into, map_into,
// the planner's row-weighted design) write what map() and M·T give, into a
// block of a larger stacked design, and nothing outside it.
void check_into_blocks(const ki::MeasurementModel& m, const Pose<double>& pose, const Eigen::MatrixXd& T) {
  const Eigen::MatrixXd M = m.map(pose);
  const Eigen::Index r = m.rows();
  Eigen::MatrixXd stacked = Eigen::MatrixXd::Constant(3 * r, T.cols(), 7.0);
  m.design_into(pose, T, stacked.middleRows(r, r));
  EXPECT_LT((stacked.middleRows(r, r) - M * T).norm(), 1e-12 * (M * T).norm()) << m.describe();
  EXPECT_TRUE((stacked.topRows(r).array() == 7.0).all()) << m.describe();
  EXPECT_TRUE((stacked.bottomRows(r).array() == 7.0).all()) << m.describe();
  const Eigen::VectorXd w = Eigen::VectorXd::LinSpaced(r, 0.5, 2.0);
  Eigen::MatrixXd weighted(r, T.cols());
  m.design_into(pose, T, w, weighted);
  EXPECT_LT((weighted - w.asDiagonal() * M * T).norm(), 1e-12 * (M * T).norm()) << m.describe();
  Eigen::MatrixXd M_block = Eigen::MatrixXd::Zero(r + 2, 6);
  m.map_into(pose, M_block.bottomRows(r));
  EXPECT_EQ(M_block.bottomRows(r), M) << m.describe();
  EXPECT_TRUE(M_block.topRows(2).isZero()) << m.describe();
}

TEST(MeasurementModel, MapsMatchFiniteDifferencesOfThePrediction) {
  const ki::Robot hybrid = ki::builtin_robot("hybrid-seed000");
  const Pose<double> registration = Pose<double>::from_xyz_rpy(1500, -200, 300, 0.1, -0.2, 2.1);
  const std::optional<ki::MeasurementModel> gauge = ki::family_of(hybrid).measurement().own_targets(hybrid);
  ASSERT_TRUE(gauge.has_value());
  EXPECT_EQ(gauge->rows(), 9);
  EXPECT_FALSE(ki::family_of(ki::builtin_robot("stewart-seed001")).measurement().own_targets(hybrid).has_value());
  const std::vector<ki::MeasurementModel> models = {
      ki::MeasurementModel::targets({{30, 40, 10}}, registration),
      ki::MeasurementModel::targets({{30, 40, 10}, {-35, 20, 15}, {5, -45, 12}}, registration),
      ki::MeasurementModel::targets({kincal::Vec3<double>::Zero()}), *gauge};
  const Pose<double> pose = Pose<double>::from_xyz_rpy(20, -15, 40, 0.05, -0.1, 0.2);
  for (const ki::MeasurementModel& m : models) {
    const Eigen::MatrixXd M = m.map(pose);
    ASSERT_EQ(M.rows(), m.rows());
    EXPECT_FALSE(m.measures_orientation());
    for (int i = 0; i < 6; ++i) {
      const double h = 1e-6;
      Vec6<double> t = Vec6<double>::Zero();
      t(i) = h;
      const Eigen::VectorXd fd = (m.predict(kincal::apply_twist(pose, kincal::Twist<double>(t))) -
                                  m.predict(kincal::apply_twist(pose, kincal::Twist<double>(-t)))) / (2 * h);
      EXPECT_LT((fd - M.col(i)).norm(), 1e-6 * std::max(1.0, M.col(i).norm())) << m.describe() << ", twist " << i;
    }
    const Eigen::MatrixXd T = Eigen::MatrixXd::Random(6, 4);
    EXPECT_LT((m.design(pose, T) - M * T).norm(), 1e-12 * (M * T).norm());
    check_into_blocks(m, pose, T);
  }
  const ki::MeasurementModel full = ki::MeasurementModel::full_pose();
  EXPECT_TRUE(full.measures_orientation());
  EXPECT_EQ(full.map(pose), Eigen::MatrixXd::Identity(6, 6));
  check_into_blocks(full, pose, Eigen::MatrixXd::Random(6, 3));
}

INSTANTIATE_TEST_SUITE_P(RegisteredFamilies, FamilySeam,
                         ::testing::Values("stewart-seed001", "hybrid-seed000", "large-hexapod", "rus6-ref",
                                           "large-rus6"),
                         [](const ::testing::TestParamInfo<std::string>& param) {
                           std::string n = param.param;
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

}  // namespace
