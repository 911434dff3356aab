// Formula effects of a robot description as candidates (issue #32; GUIDE
// "Effects written as formulas"): the description reads and writes back,
// the identification columns are the formulas' derivatives (against central
// differences of the machine's reached pose), and core's compensator with
// the host's formula policy inverts the effect (against the nominal FK of
// the commands plus the effect, a separate path), including a parameter that
// enters nonlinearly and a load under an off-centre payload.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "kincal/core/compensation.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/formula_candidate.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/robot.hpp"
#include "tool_run.hpp"

namespace {

namespace ki = kincal::identify;
using kincal::Pose;
using kincal::Vec6;

// stewart-seed001 with formula effects and a payload.
std::string description(const std::string& effects, const std::string& payload = "") {
  nlohmann::json j = nlohmann::json::parse(ki::robot_to_json(ki::builtin_robot("stewart-seed001")));
  j["name"] = "stewart-formula";
  j["effects"] = nlohmann::json::parse(effects);
  if (!payload.empty()) j["payload"] = nlohmann::json::parse(payload);
  return j.dump(2);
}

const char* kEffects = R"json([
  {"name": "leg_thermal", "kind": "joint", "joints": [1, 2], "per_joint": ["a"], "formula": "a * q * (temp - 20)"},
  {"name": "ramp", "kind": "joint", "joints": [3, 6], "per_joint": ["g"], "shared": ["q0"], "start": {"q0": 480},
   "formula": "g * max(0, q - q0)^2"},
  {"name": "clearance", "kind": "joint", "per_joint": ["c"], "formula": "c * load / sqrt(load^2 + 0.01)"}
])json";

TEST(FormulaCandidate, TheDescriptionReadsAndWritesBack) {
  const ki::Robot r = ki::parse_robot(description(kEffects, R"({"weight": 50, "com": [10, -5, 30]})"), "desc.json");
  ASSERT_EQ(r.formula_effects.size(), 3u);
  EXPECT_EQ(r.formula_effects[0]->offset(), 0);
  EXPECT_EQ(r.formula_effects[1]->offset(), 2);  // a1 a2
  EXPECT_EQ(r.formula_effects[2]->offset(), 5);  // g3 g6 q0
  EXPECT_EQ(r.payload_weight, 50.0);
  EXPECT_EQ(r.payload_com.y(), -5.0);
  const ki::Robot again = ki::parse_robot(ki::robot_to_json(r), "again.json");
  EXPECT_EQ(ki::robot_to_json(again), ki::robot_to_json(r));
  ASSERT_EQ(again.formula_effects.size(), 3u);
  EXPECT_EQ(ki::find_effect(again, "ramp")->parameter_names(again),
            (std::vector<std::string>{"g3", "g6", "q0"}));
  EXPECT_DOUBLE_EQ(ki::find_effect(again, "ramp")->start_values(again)(2), 480.0);
  // The built-in candidates first, then the description's.
  EXPECT_EQ(ki::effect_names(again), "scale, backlash, compliance, thermal, cyclic, leg_thermal, ramp, clearance");
}

TEST(FormulaCandidate, TooManyNumbersForTheTableAreRefusedWithTheKey) {
  // 3 per-joint bases on every joint: 18 numbers, the user slot holds kUserEffectParameters.
  const std::string many =
      R"json([{"name": "big", "kind": "joint", "per_joint": ["a", "b", "c"], "formula": "a + b * q + c * q^2"}])json";
  try {
    ki::parse_robot(description(many), "many.json");
    FAIL() << "accepted";
  } catch (const ki::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("18 parameters"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("many.json"), std::string::npos) << e.what();
  }
}

// The reached pose of the nominal 6-UPS for commands q with the effects' Δq
// (core's effect_joint_error plus the formulas), by core's FK.
Pose<double> reached(const ki::Robot& robot, const kincal::EffectParameters<double>& e, const ki::EffectNode& node,
                     const Vec6<double>& q) {
  const Vec6<double> actual = q + ki::effect_joint_error(robot, e, node, q);
  Pose<double> p = robot.home_pose();
  EXPECT_EQ(kincal::stewart_fk(robot.stewart(), actual, p).status, kincal::Status::Ok);
  return p;
}

TEST(FormulaCandidate, ColumnsAreTheReachedPosesDerivativeAtNonzeroValues) {
  const ki::Robot r = ki::parse_robot(description(kEffects, R"({"weight": 50, "com": [10, -5, 30]})"), "desc.json");
  ki::PoseTable t;
  t.has_temp = true;
  ki::PoseRow row;
  row.id = "p";
  row.commanded << 12, -8, 215, 0.03, -0.02, 0.05;  // legs 3 and 6 above the ramp's start below
  row.temp = 31.5;
  t.rows.push_back(row);
  const auto nodes = ki::effect_nodes(r, t);
  ASSERT_TRUE(nodes[0].has_value());
  const ki::EffectNode& node = *nodes[0];
  // Values where the ramp's start is inside the stroke and its slope non-zero
  // (at g = 0 the start has no column: the diagnosis tests it at its start).
  ki::EffectValues v;
  v.set(r, "leg_thermal", "a1", 1.2e-5);
  v.set(r, "ramp", "g3", 2e-4);
  v.set(r, "ramp", "g6", -1e-4);
  v.set(r, "ramp", "q0", node.q(2) - 6.0);
  v.set(r, "clearance", "c4", 0.01);
  for (const auto& f : r.formula_effects) {
    const kincal::EffectParameters<double> at = v.to_core(r);
    const Eigen::Index n = Eigen::Index(f->parameter_names(r).size());
    Eigen::MatrixXd cols(6, n);
    f->twist_columns(r, at, node, cols);
    for (Eigen::Index k = 0; k < n; ++k) {
      const double h = 1e-6 * std::max(1.0, std::abs(at.user(f->offset() + int(k))));
      kincal::EffectParameters<double> plus = at, minus = at;
      plus.user(f->offset() + int(k)) += h;
      minus.user(f->offset() + int(k)) -= h;
      const std::string what = f->name() + " " + f->parameter_names(r)[std::size_t(k)];
      // Δq's derivative: the formula's symbolic one against central
      // differences of the formulas' Δq (the effect's own definition).
      const Vec6<double> ddq = (ki::effect_joint_error(r, plus, node, node.q) -
                                ki::effect_joint_error(r, minus, node, node.q)) / (2 * h);
      // The column is J_f(q)·∂Δq/∂θ: the effect's joint error through the
      // tool twist per joint at the commanded configuration, as every joint
      // effect's (first order in the effect, like the built-in ones).
      EXPECT_LE((cols.col(k) - node.joint_twist * ddq).norm(), 1e-6 * std::max(1.0, cols.col(k).norm())) << what;
      // The reached pose of the machine (the nominal FK of q + Δq) moves
      // along it to first order: a 35 µm change of Δq moves J_f by ~1e-4.
      const Pose<double> a = reached(r, plus, node, node.q), b = reached(r, minus, node, node.q);
      Vec6<double> fd;
      fd << (a.p - b.p) / (2 * h), kincal::log_so3(kincal::Mat3<double>(a.R * b.R.transpose())) / (2 * h);
      EXPECT_LE((cols.col(k) - fd).norm(), 5e-4 * std::max(1.0, fd.norm()))
          << what << "\ncolumn " << cols.col(k).transpose() << "\nfd     " << fd.transpose();
    }
  }
}

TEST(FormulaCandidate, PayloadLoadIsComplianceLoadWithoutAPayloadAndMovesWithItsCentreOfMass) {
  const ki::Robot plain = ki::parse_robot(description(kEffects), "plain.json");
  const ki::Robot off = ki::parse_robot(description(kEffects, R"({"weight": 2, "com": [0, 80, 0]})"), "off.json");
  ki::PoseTable t;
  ki::PoseRow row;
  row.id = "p";
  row.commanded << 20, 10, 210, 0.02, 0.01, -0.03;
  t.rows.push_back(row);
  const ki::EffectNode node = *ki::effect_nodes(plain, t)[0];
  const std::vector<double> vp = ki::formula_variables(plain, node, node.q);
  const std::vector<double> vo = ki::formula_variables(off, node, node.q);
  for (int j = 0; j < 6; ++j) EXPECT_NEAR(vp[std::size_t(12 + j)], node.inputs.load(j), 1e-12) << j;
  // Independent statics: the weight 2·d at com r (platform frame) on the
  // nominal legs — τ solves Jᵀτ = (F, (R·r) × F) with J the IK Jacobian.
  Vec6<double> q;
  kincal::Mat6<double> J;
  const Pose<double> pose = Pose<double>::from_xyz_rpy(row.commanded);
  ASSERT_EQ(kincal::stewart_ik(plain.stewart(), pose, q, &J), kincal::Status::Ok);
  const kincal::Vec3<double> F = 2.0 * ki::effect_frame(off).load_direction;
  Vec6<double> w;
  w << F, (pose.R * kincal::Vec3<double>(0, 80, 0)).cross(F);
  const Vec6<double> tau = J.transpose().fullPivLu().solve(w);
  for (int j = 0; j < 6; ++j) EXPECT_NEAR(vo[std::size_t(12 + j)], tau(j), 1e-9 * (1 + tau.norm())) << j;
  EXPECT_GT((tau - 2.0 * node.inputs.load).norm(), 1e-3) << "the centre of mass moves the loads";
}

TEST(FormulaCandidate, TheControllerInvertsTheFormulasToTheNominalFk) {
  const ki::Robot r = ki::parse_robot(description(kEffects, R"({"weight": 40, "com": [15, 0, 20]})"), "desc.json");
  ki::EffectValues v;
  v.set(r, "leg_thermal", "a1", 2e-5);
  v.set(r, "leg_thermal", "a2", -1.5e-5);
  v.set(r, "ramp", "g3", 3e-4);
  v.set(r, "ramp", "g6", 2e-4);
  v.set(r, "ramp", "q0", 470);
  for (int j = 1; j <= 6; ++j) v.set(r, "clearance", "c" + std::to_string(j), 0.004 * (j % 2 ? 1 : -1));
  const kincal::EffectParameters<double> e = v.to_core(r);
  const auto table = kincal::nominal_table(r.stewart(), e);
  const ki::HostFormulaEffects formulas(r);
  const kincal::Compensator<kincal::StewartMachine<double>, ki::HostFormulaEffects> c(table, kincal::trust_table_bounds,
                                                                                    formulas);
  ASSERT_EQ(c.status(), kincal::CompensationStatus::Ok);
  auto state = c.start(Vec6<double>::Zero());
  ki::PoseTable t;
  t.has_temp = true;
  int checked = 0;
  for (int k = 0; k < 12; ++k) {
    ki::PoseRow row;
    row.id = "p" + std::to_string(k);
    row.commanded << 30 * std::sin(0.7 * k), 25 * std::cos(0.4 * k), 190 + 3 * k, 0.04 * std::sin(k), 0.03 * std::cos(k), 0.02;
    row.temp = 15 + 1.7 * k;
    t.rows.push_back(row);
    kincal::NcPoint<double> p;
    p.pose = Pose<double>::from_xyz_rpy(row.commanded);
    p.temperature = *row.temp;
    p.has_temperature = true;
    Vec6<double> q;
    ASSERT_EQ(c.compensate(state, p, q), kincal::CompensationStatus::Ok) << k;
    // The machine: the commands plus the effects at those commands (the
    // directions the controller kept, the node's loads at the pose).
    ki::PoseTable one = t;
    one.rows = {row};
    ki::EffectNode node = *ki::effect_nodes(r, one)[0];
    node.inputs.direction = state.direction;
    const Pose<double> at = reached(r, e, node, q);
    EXPECT_LE((at.p - p.pose.p).norm(), 1e-9) << k;
    ++checked;
  }
  EXPECT_EQ(checked, 12);
}

// A pose-kind formula (a sag of the tool growing with its distance from the
// axis) through the command line, noise-free: simulate injects it, identify
// --effects finds its number, compensate takes it off — checked on the
// machine as this test writes it (core's nominal FK, then the twist by hand).
TEST(FormulaCandidate, APoseFormulaIsInjectedIdentifiedAndTakenOff) {
  const std::string dir = "identify_formula_candidate";
  const std::string sag = R"json([{"name": "sag", "kind": "pose", "shared": ["k"],
      "formula": {"dz": "-k * (x^2 + y^2)", "drx": "k * y / 100"}}])json";
  const std::string robot = kincal_test::write_in(dir, "sag_robot.json", description(sag));
  const std::string poses = std::string(KINCAL_SOURCE_DIR) + "/examples/seed001/diagnosis_poses.csv";
  const std::string measured = dir + "/sag_measured.csv", model = dir + "/sag_model.json";
  ASSERT_EQ(kincal_test::run_tool_in(dir, "simulate --robot " + robot + " --poses " + poses +
                                              " --effect sag:k=3e-6 --out " + measured).code, 0);
  const kincal_test::ToolRun id = kincal_test::run_tool_in(
      dir, "identify --robot " + robot + " --data " + measured + " --effects sag --out " + model);
  ASSERT_EQ(id.code, 0) << id.err;
  const nlohmann::json m = nlohmann::json::parse(ki::read_text_file(model));
  EXPECT_NEAR(m.at("effects").at("sag").at("k").get<double>(), 3e-6, 3e-9) << id.out;
  const std::string joints = dir + "/sag_joints.csv";
  const kincal_test::ToolRun comp = kincal_test::run_tool_in(
      dir, "compensate --robot " + robot + " --model " + model + " --poses " + poses + " --out " + joints);
  ASSERT_EQ(comp.code, 0) << comp.err;
  const ki::Robot r = ki::parse_robot(ki::read_text_file(robot), robot);
  const ki::PoseTable out = ki::read_pose_table(joints);
  int checked = 0;
  for (const ki::PoseRow& row : out.rows) {
    if (!row.q) continue;
    Pose<double> p = r.home_pose();
    ASSERT_EQ(kincal::stewart_fk(r.stewart(), Vec6<double>(row.q->head<6>()), p).status, kincal::Status::Ok);
    // The truth's twist where the machine is commanded (the compensated
    // pose, whose x, y the formula reads).
    const double k = 3e-6, x = p.p.x(), y = p.p.y();
    Vec6<double> twist;
    twist << 0, 0, -k * (x * x + y * y), k * y / 100, 0, 0;
    const Pose<double> at = ki::moved_by_twist(p, twist);
    const Pose<double> asked = Pose<double>::from_xyz_rpy(row.commanded);
    EXPECT_LE((at.p - asked.p).norm(), 1e-3) << row.id;  // the identified k's error × r² (≤ 1 µm)
    ++checked;
  }
  EXPECT_GT(checked, 50);
}

TEST(FormulaCandidate, AFormulaNotFiniteAtANodeNamesTheNode) {
  // sqrt(q - 240) is not finite where leg 3 is shorter than 240 mm.
  const std::string root = R"json([{"name": "root", "kind": "joint", "joints": [3], "per_joint": ["r"],
      "formula": "r * sqrt(q - 240)"}])json";
  const std::string dir = "identify_formula_candidate";
  const std::string robot = kincal_test::write_in(dir, "root_robot.json", description(root));
  const std::string poses = std::string(KINCAL_SOURCE_DIR) + "/examples/seed001/diagnosis_poses.csv";
  const std::string measured = dir + "/root_measured.csv";
  ASSERT_EQ(kincal_test::run_tool_in(dir, "simulate --robot stewart-seed001 --poses " + poses + " --out " + measured).code,
            0);
  const kincal_test::ToolRun id =
      kincal_test::run_tool_in(dir, "identify --robot " + robot + " --data " + measured + " --effects root --out " +
                                        dir + "/root_model.json");
  EXPECT_EQ(id.code, 1);
  EXPECT_NE(id.err.find("not finite at node 'N"), std::string::npos) << id.err;
  EXPECT_NE(id.err.find("q3 = "), std::string::npos) << id.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/root_model.json")) << "nothing written";
}

TEST(FormulaCandidate, TheEffectsCommandListsTheDescriptionsFormulas) {
  const std::string dir = "identify_formula_candidate";
  const std::string path = kincal_test::write_in(dir, "robot.json", description(kEffects));
  const kincal_test::ToolRun run = kincal_test::run_tool_in(dir, "effects --robot " + path);
  ASSERT_EQ(run.code, 0) << run.err;
  EXPECT_NE(run.out.find("leg_thermal"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("q0"), std::string::npos) << run.out;
}

}  // namespace
