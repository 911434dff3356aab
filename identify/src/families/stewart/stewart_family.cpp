#include "families/stewart/stewart_family.hpp"

#include "families/description_reader.hpp"
#include "families/table_words.hpp"
#include "kincal/core/compensation.hpp"
#include "kincal/core/stewart.hpp"
#include "kincal/identify/stewart_calibration.hpp"

namespace kincal::identify {

// ---------------------------------------------------------------- description

Robot StewartFamilyDescription::parse(const nlohmann::json& doc, const detail::DescriptionReader& r) const {
  r.object(doc, "",
           {"format", "version", "family", "name", "units", "base_joints", "platform_joints", "stroke", "home"},
           r.with_common_optional({"length_offset", "leg_offset_sq"}));
  Robot robot;
  StewartGeometry<double> g;
  g.base = r.points<6>(doc["base_joints"], "/base_joints");
  g.platform = r.points<6>(doc["platform_joints"], "/platform_joints");
  r.range<6>(doc["stroke"], "/stroke", g.min_length, g.max_length);
  for (int i = 0; i < 6; ++i)
    if (g.min_length(i) < 0) r.fail("/stroke/min/" + std::to_string(i), "'stroke/min' is a leg length and must not be negative");
  g.length_offset = doc.contains("length_offset") ? r.vector<6>(doc["length_offset"], "/length_offset") : Vec6<double>::Zero();
  // Leg lines beside their U centres (core/stewart.hpp): the key's presence
  // is the choice to model them.
  const bool models_leg_offsets = doc.contains("leg_offset_sq");
  if (models_leg_offsets) g.leg_offset_sq = r.vector<6>(doc["leg_offset_sq"], "/leg_offset_sq");
  const nlohmann::json& home = r.object(doc["home"], "/home", {"x", "y", "z", "rx", "ry", "rz"}, {});
  g.home = Pose<double>::from_xyz_rpy(r.number(home["x"], "/home/x"), r.number(home["y"], "/home/y"),
                                      r.number(home["z"], "/home/z"), r.angle(home["rx"], "/home/rx"),
                                      r.angle(home["ry"], "/home/ry"), r.angle(home["rz"], "/home/rz"));
  r.common_optional(doc, robot);
  robot.family_data = StewartDescription{g, models_leg_offsets};
  Vec6<double> q;
  // With the Jacobian: a geometry whose legs cannot hold the platform (six
  // base joints at one point, collinear platform joints, …) is singular at
  // every pose, and simulate would otherwise report measured == commanded.
  Mat6<double> J;
  const Status s = stewart_ik(g, g.home, q, &J);
  if (s == Status::Singular)
    r.fail("/base_joints", "the geometry is singular at its home pose: the legs cannot hold the platform (joints "
                           "at one point or on one line?)");
  if (s != Status::Ok) r.fail("/home", std::string("the home pose is not reachable: ") + to_string(s));
  return robot;
}

void StewartFamilyDescription::write(const Robot& robot, nlohmann::ordered_json& j) const {
  const StewartGeometry<double>& g = robot.stewart();
  j["base_joints"] = detail::points_json<6>(g.base);
  j["platform_joints"] = detail::points_json<6>(g.platform);
  j["stroke"] = {{"min", detail::vector_json<6>(g.min_length)}, {"max", detail::vector_json<6>(g.max_length)}};
  j["length_offset"] = detail::vector_json<6>(g.length_offset);
  if (robot.stewart_description().models_leg_offsets) j["leg_offset_sq"] = detail::vector_json<6>(g.leg_offset_sq);
  const Vec6<double> h = g.home.to_xyz_rpy() + Vec6<double>::Zero();
  j["home"] = {{"x", h(0)}, {"y", h(1)}, {"z", h(2)}, {"rx", h(3)}, {"ry", h(4)}, {"rz", h(5)}};
}

void StewartFamilyDescription::summarize(const Robot& robot, std::ostream& os) const {
  const StewartGeometry<double>& g = robot.stewart();
  os << "base joints B_i (mm):\n";
  for (int i = 0; i < 6; ++i) os << "  " << i + 1 << ": " << g.base.col(i).transpose() << "\n";
  os << "platform joints P_i (mm, platform frame):\n";
  for (int i = 0; i < 6; ++i) os << "  " << i + 1 << ": " << g.platform.col(i).transpose() << "\n";
  os << "stroke q (mm): [" << g.min_length.minCoeff() << ", " << g.max_length.maxCoeff() << "]\n";
}

// ---------------------------------------------------------------- kinematics

TableBounds<double> StewartFamilyTable::default_bounds(const Robot& robot) const {
  return kincal::default_bounds(robot.stewart());
}

void StewartFamilyKinematics::joint_limits(const Robot& robot, Vec6<double>& lo, Vec6<double>& hi) const {
  lo = robot.stewart().min_length;
  hi = robot.stewart().max_length;
}

Status StewartFamilyKinematics::inverse(const Robot& robot, const Pose<double>& pose, Vec6<double>& q, Mat6<double>* J,
                                        double*) const {
  return stewart_ik(robot.stewart(), pose, q, J);
}

bool StewartFamilyKinematics::forward_jacobian(const Robot& robot, const Pose<double>& pose, Vec6<double>& q,
                                               Mat6<double>& J) const {
  Mat6<double> Jik;
  if (stewart_ik(robot.stewart(), pose, q, &Jik) != Status::Ok) return false;
  J = Jik.inverse();  // q̇ = J_ik·twist (stewart.hpp); the error model's dl columns are J_ik⁻¹
  return all_finite(J);
}

double StewartFamilyKinematics::reach(const Robot& robot) const { return robot.stewart().base.colwise().norm().maxCoeff(); }
                                      
                                      // ---------------------------------------------------------------- error model
                                      
                                      namespace {

const char* const kAxes[3] = {"X", "Y", "Z"};
const char* const kAxesLower[3] = {"x", "y", "z"};

// seed 001 Table 3: per leg dXBi, dYBi, dZBi, dli, dXPi, dYPi, dZPi (mm).
std::vector<ParameterSpec> stewart_table() {
  std::vector<ParameterSpec> t;
  for (int i = 0; i < 6; ++i) {
    const std::string leg = std::to_string(i + 1);
    for (int a = 0; a < 3; ++a)
      t.push_back({std::string("d") + kAxes[a] + "B" + leg, "mm",
                   std::string("base hinge B") + leg + " " + kAxesLower[a] + " (base frame)",
                   [i, a](Robot& r, double v) { r.stewart().base(a, i) += v; }});
    // The physical leg is the command plus dl (verified against seed 001 Table 4).
    t.push_back({"dl" + leg, "mm", "leg " + leg + " length offset (physical length = q + dl)",
                 [i](Robot& r, double v) { r.stewart().length_offset(i) += v; }});
    for (int a = 0; a < 3; ++a)
      t.push_back({std::string("d") + kAxes[a] + "P" + leg, "mm",
                   std::string("platform hinge P") + leg + " " + kAxesLower[a] + " (platform frame)",
                   [i, a](Robot& r, double v) { r.stewart().platform(a, i) += v; }});
  }
  return t;
}

// seed 001's 42, then the six squared leg-line offsets (robots with the key
// leg_offset_sq; core/stewart.hpp).
std::vector<ParameterSpec> stewart_table_with_leg_offsets() {
  std::vector<ParameterSpec> t = stewart_table();
  for (int i = 0; i < 6; ++i) {
    const std::string leg = std::to_string(i + 1);
    t.push_back({"dsq" + leg, "mm2",
                 "leg " + leg + " prismatic line's squared distance from its U centre (U-S distance = sqrt(l^2 + this))",
                 [i](Robot& r, double v) { r.stewart().leg_offset_sq(i) += v; }});
  }
  return t;
}

// seed 001 §5.2: the error-free commands drive the error-containing FK.
Status stewart_commands(const StewartGeometry<double>& g, const Pose<double>& pose, Vec6<double>& q) {
  return stewart_ik(g, pose, q);
}
FkReport<double> stewart_reached(const StewartGeometry<double>& g, const Vec6<double>& q, const Pose<double>& guess,
                                 Pose<double>& pose) {
  return stewart_fk(g, q, guess, pose);
}

}  // namespace

const std::vector<ParameterSpec>& StewartFamilyErrorModel::parameter_specs(const Robot& robot) const {
  static const std::vector<ParameterSpec> table = stewart_table();
  static const std::vector<ParameterSpec> with_leg_offsets = stewart_table_with_leg_offsets();
  return robot.stewart_description().models_leg_offsets ? with_leg_offsets : table;
}

AnyCalibrationTable StewartFamilyTable::machine_table(const CalibrationModel& model) const {
  const StewartGeometry<double>& nominal = model.nominal.stewart();
  StewartCalibrationTable<double> t{};
  t.machine.nominal = to_table(nominal);
  t.machine.calibrated = to_table(calibrated_robot(model).stewart());  // seed 001: IK of the calibrated geometry
  t.bounds = kincal::default_bounds(nominal);
  return t;
}

std::vector<TableGroup> StewartFamilyTable::machine_groups(const Robot&) const {
  std::vector<TableGroup> g;
  for (const char* part : {"machine.nominal.", "machine.calibrated."})
    for (const auto& [name, n] : {std::pair{"base", 18}, {"platform", 18}, {"length_offset", 6}, {"leg_offset_sq", 6},
                                  {"min_length", 6}, {"max_length", 6}, {"home_rotation", 9}, {"home_position", 3},
                                  {"characteristic_length", 1}})
      g.push_back({part + std::string(name), n, {}, {}});
  return g;
}

std::string StewartFamilyTable::machine_limit_violation(const AnyCalibrationTable& table,
                                                        const MachineLimits<double>& l) const {
  using detail::first_above;
  using detail::key_note;
  using detail::table_number;
  const StewartMachine<double>& m = std::get<StewartCalibrationTable<double>>(table).machine;
  const double* cap = std::get<StewartCalibrationTable<double>>(table).bounds.max_correction;
  std::string why = first_above("machine.calibrated.base - nominal", m.calibrated.base, l.max_geometry_error,
                                "max_geometry_error", m.nominal.base);
  if (why.empty())
    why = first_above("machine.calibrated.platform - nominal", m.calibrated.platform, l.max_geometry_error,
                      "max_geometry_error", m.nominal.platform);
  for (int i = 0; i < 6 && why.empty(); ++i) {
    const double dl = m.calibrated.length_offset[i] - m.nominal.length_offset[i];
    if (!(std::abs(dl) <= cap[i]))
      why = "leg offset dl" + std::to_string(i + 1) + " = " + table_number(dl) + " above the correction bound " +
            table_number(cap[i]) + key_note("max_correction");
  }
  for (int i = 0; i < 6 && why.empty(); ++i) {
    const double ds = m.calibrated.leg_offset_sq[i] - m.nominal.leg_offset_sq[i];
    if (!(std::abs(ds) <= l.max_geometry_error * l.max_geometry_error))
      why = "squared leg line offset dsq" + std::to_string(i + 1) + " = " + table_number(ds) +
            " mm2 above max_geometry_error^2 " + table_number(l.max_geometry_error * l.max_geometry_error) +
            key_note("max_geometry_error");
  }
  return why;
}

std::unique_ptr<ActualMachine> StewartFamilyKinematics::actual_machine(const Robot& nominal, const Robot& actual) const {
  return std::make_unique<CommandsThenFk<StewartGeometry<double>, stewart_commands, stewart_reached>>(
      nominal.stewart(), actual.stewart());
}

const Family& stewart_family() {
  return family_of_capabilities<StewartFamilyDescription,
                                StewartFamilyKinematics,
                                StewartFamilyErrorModel,
                                StewartFamilyMeasurement,
                                StewartFamilyTable,
                                StewartFamilyPipeline>();
}

}  // namespace kincal::identify
