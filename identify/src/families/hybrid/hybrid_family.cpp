#include "families/hybrid/hybrid_family.hpp"

#include <cmath>
#include <cstdio>

#include "families/description_reader.hpp"
#include "families/table_words.hpp"
#include "kincal/core/compensation.hpp"
#include "kincal/core/hybrid.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/identify/gauge.hpp"
#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/simulate.hpp"
#include "kincal/identify/target_calibration.hpp"

namespace kincal::identify {

// ---------------------------------------------------------------- geometry

HybridGeometry<double> make_hybrid_geometry(const HybridDesign& d) {
  // Same derivation as make_hybrid_seed000 (core/reference_machines.hpp).
  HybridGeometry<double> g;
  g.base_joints = d.base_joints;
  g.platform_joints = d.platform_joints;
  g.platform_to_wrist = d.platform_to_wrist;
  g.wrist_link = d.wrist_link;
  g.tool_length = d.tool_length;
  g.workpiece_rotation = rot_y(pi<double>() - d.beta) * rot_z(pi<double>() / 2.0);  // seed 000 Eq. (8)
  g.home = HybridPassive<double>{};
  g.home.extension = d.reference_extension;
  const HybridFrames<double> ref = hybrid_frames(g, g.home, Vec3<double>(0.0, d.beta, 0.0));
  g.workpiece_origin = ref.P;
  g.tool_offset = ref.F6.transpose() * g.workpiece_rotation.transpose();
  g.min_joint = d.min_joint;
  g.max_joint = d.max_joint;
  g.min_extension = d.min_extension;
  g.max_extension = d.max_extension;
  g.joint_offset = d.joint_offset;
  return g;
}

HybridDesign hybrid_design_of(const HybridGeometry<double>& g) {
  HybridDesign d;
  d.base_joints = g.base_joints;
  d.platform_joints = g.platform_joints;
  d.platform_to_wrist = g.platform_to_wrist;
  d.wrist_link = g.wrist_link;
  d.tool_length = g.tool_length;
  // wR0·Rz(π/2)ᵀ = Rot(y, π − β)
  const Mat3<double> ry = g.workpiece_rotation * rot_z(pi<double>() / 2.0).transpose();
  d.beta = pi<double>() - std::atan2(ry(0, 2), ry(0, 0));
  d.reference_extension = g.home.extension;
  d.min_joint = g.min_joint;
  d.max_joint = g.max_joint;
  d.min_extension = g.min_extension;
  d.max_extension = g.max_extension;
  d.joint_offset = g.joint_offset;
  return d;
}

// ---------------------------------------------------------------- description

Robot HybridFamilyDescription::parse(const nlohmann::json& doc, const detail::DescriptionReader& r) const {
  r.object(doc, "",
           {"format", "version", "family", "name", "units", "base_joints", "platform_joints", "platform_to_wrist",
            "wrist_link", "tool_length", "beta", "reference_extension", "joint_limits", "extension_limits"},
           r.with_common_optional({"joint_offset", "gauge_radius"}));
  Robot robot;
  HybridDesign d;
  d.base_joints = r.points<3>(doc["base_joints"], "/base_joints");
  d.platform_joints = r.points<3>(doc["platform_joints"], "/platform_joints");
  d.platform_to_wrist = r.non_negative(doc["platform_to_wrist"], "/platform_to_wrist");
  d.wrist_link = r.non_negative(doc["wrist_link"], "/wrist_link");
  d.tool_length = r.positive(doc["tool_length"], "/tool_length");
  d.beta = r.number(doc["beta"], "/beta");
  if (!(std::abs(d.beta) < pi<double>() / 2)) r.fail("/beta", "'beta' must lie in (-pi/2, pi/2) rad");
  d.reference_extension = r.positive(doc["reference_extension"], "/reference_extension");
  r.range<6>(doc["joint_limits"], "/joint_limits", d.min_joint, d.max_joint);
  for (int i = 0; i < 3; ++i)
    if (d.min_joint(i) < 0)
      r.fail("/joint_limits/min/" + std::to_string(i), "'joint_limits/min' of a UPS limb is a length and must not be negative");
  const nlohmann::json& ext = r.object(doc["extension_limits"], "/extension_limits", {"min", "max"}, {});
  d.min_extension = r.non_negative(ext["min"], "/extension_limits/min");
  d.max_extension = r.number(ext["max"], "/extension_limits/max");
  if (!(d.min_extension < d.max_extension)) r.fail("/extension_limits", "'extension_limits': min must be below max");
  d.joint_offset = doc.contains("joint_offset") ? r.vector<6>(doc["joint_offset"], "/joint_offset") : Vec6<double>::Zero();
  HybridDescription part;
  part.gauge_radius = doc.contains("gauge_radius") ? r.positive(doc["gauge_radius"], "/gauge_radius")
                                                   : HybridSeed000Dimensions::gauge_radius;
  r.common_optional(doc, robot);
  part.geometry = make_hybrid_geometry(d);
  robot.family_data = part;
  Vec6<double> q;
  // With the Jacobian: degenerate joint layouts (base or platform joints at
  // one point or on one line) are singular at the reference pose.
  Mat6<double> J;
  const Status s = hybrid_ik(robot.hybrid(), robot.home_pose(), q, &J);
  if (s == Status::Singular)
    r.fail("/base_joints", "the geometry is singular at its reference pose: the UPS limbs cannot hold the platform "
                           "(joints at one point or on one line?)");
  if (s != Status::Ok)
    r.fail("/reference_extension", std::string("the reference pose is not reachable: ") + to_string(s));
  return robot;
}

void HybridFamilyDescription::write(const Robot& robot, nlohmann::ordered_json& j) const {
  const HybridDesign d = hybrid_design_of(robot.hybrid());
  j["base_joints"] = detail::points_json<3>(d.base_joints);
  j["platform_joints"] = detail::points_json<3>(d.platform_joints);
  j["platform_to_wrist"] = d.platform_to_wrist;
  j["wrist_link"] = d.wrist_link;
  j["tool_length"] = d.tool_length;
  j["beta"] = d.beta;
  j["reference_extension"] = d.reference_extension;
  j["joint_limits"] = {{"min", detail::vector_json<6>(d.min_joint)}, {"max", detail::vector_json<6>(d.max_joint)}};
  j["extension_limits"] = {{"min", d.min_extension}, {"max", d.max_extension}};
  j["joint_offset"] = detail::vector_json<6>(d.joint_offset);
  j["gauge_radius"] = robot.hybrid_description().gauge_radius;
}

void HybridFamilyDescription::summarize(const Robot& robot, std::ostream& os) const {
  const HybridDesign d = hybrid_design_of(robot.hybrid());
  os << "UPS base joints A1i (mm):\n";
  for (int i = 0; i < 3; ++i) os << "  " << i + 1 << ": " << d.base_joints.col(i).transpose() << "\n";
  os << "UPS platform joints a_i (mm, platform frame):\n";
  for (int i = 0; i < 3; ++i) os << "  " << i + 1 << ": " << d.platform_joints.col(i).transpose() << "\n";
  os << "|A64 Q| = " << d.platform_to_wrist << " mm, |Q P0| = " << d.wrist_link << " mm, |P0 P| = " << d.tool_length
     << " mm, beta = " << d.beta << " rad, reference extension = " << d.reference_extension << " mm\n"
     << "gauge radius |P0 Pj| = " << robot.hybrid_description().gauge_radius << " mm\n";
}

// ---------------------------------------------------------------- kinematics

Pose<double> HybridFamilyKinematics::home_pose(const Robot& robot) const {
  const HybridGeometry<double>& g = robot.hybrid();
  const Vec3<double> ref_angles(0.0, hybrid_design_of(g).beta, 0.0);
  return hybrid_tool_pose(g, hybrid_frames(g, g.home, ref_angles));
}

TableBounds<double> HybridFamilyTable::default_bounds(const Robot& robot) const {
  return kincal::default_bounds(robot.hybrid());
}

void HybridFamilyKinematics::joint_limits(const Robot& robot, Vec6<double>& lo, Vec6<double>& hi) const {
  lo = robot.hybrid().min_joint;
  hi = robot.hybrid().max_joint;
}

std::vector<PassiveLimit> HybridFamilyKinematics::passive_limits(const Robot& robot) const {
  return {{"UP extension c", "mm", robot.hybrid().min_extension, robot.hybrid().max_extension}};
}

Status HybridFamilyKinematics::inverse(const Robot& robot, const Pose<double>& pose, Vec6<double>& q, Mat6<double>* J,
                                       double* passive) const {
  HybridPassive<double> s = robot.hybrid().home;
  const Status status = hybrid_ik(robot.hybrid(), pose, q, J, &s);
  if (passive != nullptr) passive[0] = s.extension;
  return status;
}

bool HybridFamilyKinematics::forward_jacobian(const Robot& robot, const Pose<double>& pose, Vec6<double>& q,
                                              Mat6<double>& J) const {
  const HybridGeometry<double>& g = robot.hybrid();
  HybridPassive<double> passive;
  if (hybrid_ik(g, pose, q, nullptr, &passive) != Status::Ok) return false;
  const Vec3<double> wrist = q.tail<3>() + g.joint_offset.tail<3>();
  return hybrid_forward_jacobian(g, hybrid_frames(g, passive, wrist), J);
}

double HybridFamilyKinematics::reach(const Robot& robot) const {
  return robot.hybrid().base_joints.colwise().norm().maxCoeff() + robot.hybrid().tool_length;
}

void HybridFamilyKinematics::set_effect_frame(const Robot& robot, EffectParameters<double>& e) const {
  // Poses are in the workpiece frame {R}: p_R = wR0·(p_0 − o) (hybrid.hpp).
  const HybridGeometry<double>& g = robot.hybrid();
  e.load_direction = g.workpiece_rotation * Vec3<double>(0, 0, -1);
  e.thermal_origin = -(g.workpiece_rotation * g.workpiece_origin);
}

// ---------------------------------------------------------------- error model

namespace {

const char* const kAxes[3] = {"X", "Y", "Z"};
const char* const kAxesLower[3] = {"x", "y", "z"};

// Hybrid, first subset of seed 000's source errors: encoder offsets Δξ, the
// UPS joint centres, and the three wrist lengths. The full 145-error set of
// seed 000 extends this table.
std::vector<ParameterSpec> hybrid_table() {
  std::vector<ParameterSpec> t;
  for (int i = 0; i < 3; ++i)
    t.push_back({"dq" + std::to_string(i + 1), "mm", "encoder offset of UPS limb " + std::to_string(i + 1),
                 [i](Robot& r, double v) { r.hybrid().joint_offset(i) += v; }});
  for (int i = 3; i < 6; ++i)
    t.push_back({"dtheta" + std::to_string(i + 1), "rad", "encoder offset of wrist joint " + std::to_string(i + 1),
                 [i](Robot& r, double v) { r.hybrid().joint_offset(i) += v; }});
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a)
      t.push_back({std::string("d") + kAxes[a] + "A" + std::to_string(i + 1), "mm",
                   std::string("UPS base joint A1,") + std::to_string(i + 1) + " " + kAxesLower[a] + " (base frame)",
                   [i, a](Robot& r, double v) { r.hybrid().base_joints(a, i) += v; }});
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a)
      t.push_back({std::string("d") + kAxes[a] + "a" + std::to_string(i + 1), "mm",
                   std::string("UPS platform joint a") + std::to_string(i + 1) + " " + kAxesLower[a] +
                       " (platform frame)",
                   [i, a](Robot& r, double v) { r.hybrid().platform_joints(a, i) += v; }});
  t.push_back({"d_platform_to_wrist", "mm", "|A64 Q|", [](Robot& r, double v) { r.hybrid().platform_to_wrist += v; }});
  t.push_back({"d_wrist_link", "mm", "|Q P0|", [](Robot& r, double v) { r.hybrid().wrist_link += v; }});
  t.push_back({"d_tool_length", "mm", "|P0 P|", [](Robot& r, double v) { r.hybrid().tool_length += v; }});
  // seed 000's complete set of joint/link source errors (Appendix A), acting on
  // the machine through the nonlinear chain model of hybrid_error_model.hpp.
  const HybridErrorModel model(make_hybrid_seed000<double>());
  for (const HybridErrorParameter& p : model.parameters()) {
    const int index = model.index_of(p.name);
    t.push_back({p.name, p.unit(), "seed 000 source error " + p.symbol, [index](Robot& r, double v) {
                   Eigen::VectorXd& errors = r.hybrid_description().source_errors;
                   if (errors.size() == 0) errors = Eigen::VectorXd::Zero(HybridErrorModel::kParameterCount);
                   errors(index) += v;
                 }});
  }
  return t;
}

// The erroneous machine: seed 000's source errors (HybridDescription::source_errors) on
// the nonlinear chain when given, else the (possibly modified) ideal chain.
// The passive joints start from the nominal IK's.
class HybridActual final : public ActualMachine {
 public:
  HybridActual(const Robot& nominal, const Robot& actual) : nominal_(nominal.hybrid()), actual_(actual) {
    if (actual.hybrid_description().source_errors.size() > 0)
      sources_ = std::make_unique<HybridErrorModel>(actual.hybrid());
  }
  ReachedPose reach(const PoseRow& row,
                    const std::function<Vec6<double>(const Vec6<double>&)>& joint_error) const override {
    ReachedPose out;
    const Pose<double> commanded = Pose<double>::from_xyz_rpy(row.commanded);
    Vec6<double> q;
    HybridPassive<double> passive = nominal_.home;
    Vec6<double> q_ik;
    const Status ik = hybrid_ik(nominal_, commanded, q_ik, nullptr, &passive);
    if (row.q) {
      q = *row.q;
      if (ik != Status::Ok) passive = nominal_.home;  // no better start available
    } else {
      out.status = ik;
      out.stage = "inverse kinematics of the commanded pose";
      if (ik != Status::Ok) return out;
      q = q_ik;
    }
    if (joint_error) q += joint_error(q);
    out.status = sources_ ? sources_->actual_fk(actual_.hybrid_description().source_errors, q, passive, out.pose).status
                          : hybrid_fk(actual_.hybrid(), q, passive, out.pose).status;
    out.stage = "forward kinematics of the erroneous machine";
    return out;
  }

 private:
  HybridGeometry<double> nominal_;
  Robot actual_;
  std::unique_ptr<HybridErrorModel> sources_;
};

}  // namespace

const std::vector<ParameterSpec>& HybridFamilyErrorModel::parameter_specs(const Robot&) const {
  static const std::vector<ParameterSpec> table = hybrid_table();
  return table;
}

// The hybrid's encoder offsets have two names each: PARAMS.csv's dq1..dq3,
// dtheta4..dtheta6 and seed 000's source errors dxi_3_1 … dxi_6_4.
std::string HybridFamilyErrorModel::alias_of(const std::string& name) const {
  static const char* pairs[][2] = {{"dq1", "dxi_3_1"},     {"dq2", "dxi_3_2"},     {"dq3", "dxi_3_3"},
                                   {"dtheta4", "dxi_4_4"}, {"dtheta5", "dxi_5_4"}, {"dtheta6", "dxi_6_4"}};
  for (const auto& p : pairs) {
    if (name == p[0]) return p[1];
    if (name == p[1]) return p[0];
  }
  return {};
}

AnyCalibrationTable HybridFamilyTable::machine_table(const CalibrationModel& model) const {
  const HybridCompensation c = hybrid_compensation_from_model(model);
  HybridCalibrationTable<double> t{};
  t.machine.nominal = to_table(c.nominal);
  t.machine.up_split = HybridErrorModelOptions().up_split;  // the model B was identified with
  for (int i = 0; i < 6; ++i) t.machine.encoder_offsets[i] = c.encoder_offsets(i);
  for (int k = HybridErrorModel::kEncoderCount; k < kHybridSourceErrorCount; ++k)
    t.machine.source_errors[k] = c.structural.size() > 0 ? c.structural(k) : 0.0;
  t.bounds = kincal::default_bounds(c.nominal);
  return t;
}

std::vector<TableGroup> HybridFamilyTable::machine_groups(const Robot& robot) const {
  std::vector<TableGroup> g;
  for (const auto& [name, n] :
       {std::pair{"base_joints", 9}, {"platform_joints", 9}, {"platform_to_wrist", 1}, {"wrist_link", 1},
        {"tool_length", 1}, {"workpiece_rotation", 9}, {"workpiece_origin", 3}, {"tool_offset", 9},
        {"joint_offset", 6}, {"min_joint", 6}, {"max_joint", 6}, {"min_extension", 1}, {"max_extension", 1},
        {"home", 3}, {"characteristic_length", 1}})
    g.push_back({"machine.nominal." + std::string(name), n, {}, {}});
  g.push_back({"machine.up_split", 1, {}, {}});
  g.push_back({"machine.encoder_offsets", 6, {}, {}});
  TableGroup source{"machine.source_errors", kHybridSourceErrorCount, {},
                    " (Δχ̂ of seed 000 Eq. (7), identify's HybridErrorModel order)"};
  const HybridErrorModel em(robot.hybrid());
  for (const HybridErrorParameter& p : em.parameters()) source.values.push_back(p.name + " " + p.unit());
  g.push_back(std::move(source));
  return g;
}

// The source errors, each against its own cap: the angles against
// max_angle_error, the lengths against max_geometry_error (as core's
// machine_inside).
std::string HybridFamilyTable::machine_limit_violation(const AnyCalibrationTable& table,
                                                       const MachineLimits<double>& l) const {
  const double(&values)[kHybridSourceErrorCount] = std::get<HybridCalibrationTable<double>>(table).machine.source_errors;
  for (int k = 0; k < kHybridSourceErrorCount; ++k) {
    const bool angle = HybridErrorLayout::angular(k);
    const double cap = angle ? l.max_angle_error : l.max_geometry_error;
    const char* key = angle ? "max_angle_error" : "max_geometry_error";
    if (!(std::abs(values[k]) <= cap))
      return "machine.source_errors[" + std::to_string(k) + "] = " + detail::table_number(values[k]) +
             (angle ? " rad" : " mm") + " above " + key + " " + detail::table_number(cap) + detail::key_note(key);
  }
  return {};
}

// The encoder offsets: one correction at every point.
std::string HybridFamilyTable::machine_value_violation(const AnyCalibrationTable& table) const {
  const HybridCalibrationTable<double>& t = std::get<HybridCalibrationTable<double>>(table);
  for (int i = 0; i < 6; ++i)
    if (!(std::abs(t.machine.encoder_offsets[i]) <= t.bounds.max_correction[i]))
      return "encoder offset " + std::to_string(i + 1) + " = " + detail::table_number(t.machine.encoder_offsets[i]) +
             " above its correction bound " + detail::table_number(t.bounds.max_correction[i]) +
             detail::key_note("max_correction");
  return {};
}

std::string HybridFamilyMeasurement::missing_measurement(const Robot& robot, const PoseTable& data) const {
  if (data.target_columns() == 3 || uses_target_model(robot, data)) return {};
  return "needs the gauge target columns t1x..t3z, or measured poses mx..mrz, to diagnose a hybrid";
}

std::unique_ptr<ActualMachine> HybridFamilyKinematics::actual_machine(const Robot& nominal, const Robot& actual) const {
  return std::make_unique<HybridActual>(nominal, actual);
}

const Family& hybrid_family() {
  return family_of_capabilities<HybridFamilyDescription,
                                HybridFamilyKinematics,
                                HybridFamilyErrorModel,
                                HybridFamilyMeasurement,
                                HybridFamilyTable,
                                HybridFamilyPipeline>();
}

}  // namespace kincal::identify
