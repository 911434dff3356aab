#include "families/rus6/rus6_family.hpp"

#include <cmath>
#include <string>

#include "families/description_reader.hpp"
#include "families/table_words.hpp"
#include "kincal/identify/joint_limits.hpp"
#include "kincal/core/rus6_machine.hpp"
#include "kincal/identify/rus6_error_model.hpp"

namespace kincal::identify {

// ---------------------------------------------------------------- description

namespace {

// One number for all six or six numbers (crank_length, rod_length).
Vec6<double> per_leg_length(const detail::DescriptionReader& r, const nlohmann::json& j, const std::string& path) {
  return r.per_joint_positive(j, path);
}

// Unit to the last digits where a hand-written file rounded (6 digits), so
// the kinematics' rules hold exactly; a vector already unit to 1e-12 (as
// this tool writes it) is kept as it is, so a description round-trips.
Vec3<double> tidy(const Vec3<double>& v) {
  return std::abs(v.norm() - 1.0) < 1e-12 ? v : Vec3<double>(v.normalized());
}

nlohmann::json per_leg_json(const Vec6<double>& v) {
  if ((v.array() == v(0)).all()) return v(0) + 0.0;
  return detail::vector_json<6>(v);
}

}  // namespace

Robot Rus6FamilyDescription::parse(const nlohmann::json& doc, const detail::DescriptionReader& r) const {
  r.object(doc, "",
           {"format", "version", "family", "name", "units", "motor_axes", "crank_zero", "crank_length", "rod_length",
            "platform_joints", "joint_limits", "home"},
           r.with_common_optional({"joint_offset"}));
  Robot robot;
  // A motor turns its crank through a gearbox or directly: the `cyclic`
  // effect's default period is one crank turn (a description of a geared
  // motor gives `screw_lead` = 2π / ratio).
  robot.screw_lead = 2 * pi<double>();
  Rus6Geometry<double> g;
  r.array_of(doc["motor_axes"], "/motor_axes", 6);
  for (int i = 0; i < 6; ++i) {
    const std::string at = "/motor_axes/" + std::to_string(i);
    const nlohmann::json& m = r.object(doc["motor_axes"][std::size_t(i)], at, {"point", "axis"}, {});
    g.shaft_points.col(i) = r.vector<3>(m["point"], at + "/point");
    const Vec3<double> a = r.vector<3>(m["axis"], at + "/axis");
    if (!(std::abs(a.norm() - 1.0) < 1e-6)) r.fail(at + "/axis", "'axis' must be a unit vector (|axis| = " + std::to_string(a.norm()) + ")");
    g.shaft_axes.col(i) = tidy(a);
  }
  const Eigen::Matrix<double, 3, 6> zero = r.points<6>(doc["crank_zero"], "/crank_zero");
  for (int i = 0; i < 6; ++i) {
    const std::string at = "/crank_zero/" + std::to_string(i);
    const Vec3<double> z = zero.col(i);
    if (!(std::abs(z.norm() - 1.0) < 1e-6)) r.fail(at, "'crank_zero' entries must be unit vectors (|z| = " + std::to_string(z.norm()) + ")");
    if (!(std::abs(z.dot(g.shaft_axes.col(i))) < 1e-6))
      r.fail(at, "'crank_zero' " + std::to_string(i + 1) + " must be perpendicular to its motor's axis (z . axis = " +
                     std::to_string(z.dot(g.shaft_axes.col(i))) + ")");
    const Vec3<double> a = g.shaft_axes.col(i);
    g.crank_zero.col(i) = tidy(std::abs(a.dot(z)) < 1e-12 ? z : Vec3<double>(z - a * a.dot(z)));
  }
  g.crank_length = per_leg_length(r, doc["crank_length"], "/crank_length");
  g.rod_length = per_leg_length(r, doc["rod_length"], "/rod_length");
  g.platform_joints = r.points<6>(doc["platform_joints"], "/platform_joints");
  r.range<6>(doc["joint_limits"], "/joint_limits", g.min_joint, g.max_joint);
  for (int i = 0; i < 6; ++i)
    if (!(g.max_joint(i) - g.min_joint(i) < 2 * pi<double>()))
      r.fail("/joint_limits", "joint " + std::to_string(i + 1) +
                                  "'s range is a turn or more: the limits must hold one IK branch (narrower than 2 pi rad)");
  if (doc.contains("joint_offset")) g.joint_offset = r.vector<6>(doc["joint_offset"], "/joint_offset");
  const nlohmann::json& home = r.object(doc["home"], "/home", {"x", "y", "z", "rx", "ry", "rz"}, {});
  g.home = Pose<double>::from_xyz_rpy(r.number(home["x"], "/home/x"), r.number(home["y"], "/home/y"),
                                      r.number(home["z"], "/home/z"), r.angle(home["rx"], "/home/rx"),
                                      r.angle(home["ry"], "/home/ry"), r.angle(home["rz"], "/home/rz"));
  // Radians → mm in singularity tests: the platform's size.
  g.characteristic_length = std::max(1.0, g.platform_joints.colwise().norm().maxCoeff());
  r.common_optional(doc, robot);
  // The home assembly: the branch the IK takes at home decides when both
  // fit the limits elsewhere (core/rus6.hpp rule 3).
  Vec6<double> branches;
  const Status hb = rus6_home_branches(g, branches);
  if (hb != Status::Ok) r.fail("/home", std::string("the home pose is not reachable within joint_limits: ") + to_string(hb));
  g.home_branch = branches;
  Vec6<double> q;
  Mat6<double> J;
  const Status s = rus6_ik(g, g.home, q, &J);
  if (s == Status::Singular)
    r.fail("/platform_joints", "the geometry is singular at its home pose (a rod in line with its crank, or rods that "
                               "cannot hold the platform)");
  if (s != Status::Ok) r.fail("/home", std::string("the home pose is not reachable: ") + to_string(s));
  robot.family_data = Rus6Description{g};
  return robot;
}

void Rus6FamilyDescription::write(const Robot& robot, nlohmann::ordered_json& j) const {
  const Rus6Geometry<double>& g = robot.rus6();
  nlohmann::ordered_json motors = nlohmann::ordered_json::array();
  for (int i = 0; i < 6; ++i)
    motors.push_back({{"point", detail::vector_json<3>(g.shaft_points.col(i))},
                      {"axis", detail::vector_json<3>(g.shaft_axes.col(i))}});
  j["motor_axes"] = motors;
  j["crank_zero"] = detail::points_json<6>(g.crank_zero);
  j["crank_length"] = per_leg_json(g.crank_length);
  j["rod_length"] = per_leg_json(g.rod_length);
  j["platform_joints"] = detail::points_json<6>(g.platform_joints);
  j["joint_limits"] = {{"min", detail::vector_json<6>(g.min_joint)}, {"max", detail::vector_json<6>(g.max_joint)}};
  if (!g.joint_offset.isZero()) j["joint_offset"] = detail::vector_json<6>(g.joint_offset);
  const Vec6<double> h = g.home.to_xyz_rpy() + Vec6<double>::Zero();
  j["home"] = {{"x", h(0)}, {"y", h(1)}, {"z", h(2)}, {"rx", h(3)}, {"ry", h(4)}, {"rz", h(5)}};
}

void Rus6FamilyDescription::summarize(const Robot& robot, std::ostream& os) const {
  const Rus6Geometry<double>& g = robot.rus6();
  os << "motors: shaft point s_i (mm), axis a_i, crank zero z_i:\n";
  for (int i = 0; i < 6; ++i)
    os << "  " << i + 1 << ": s " << g.shaft_points.col(i).transpose() << "  a " << g.shaft_axes.col(i).transpose()
       << "  z " << g.crank_zero.col(i).transpose() << "\n";
  os << "crank length (mm): " << g.crank_length.transpose() << "\nrod length (mm):   " << g.rod_length.transpose()
     << "\nplatform joints p_i (mm, platform frame):\n";
  for (int i = 0; i < 6; ++i) os << "  " << i + 1 << ": " << g.platform_joints.col(i).transpose() << "\n";
  os << "joint limits (rad): [" << g.min_joint.minCoeff() << ", " << g.max_joint.maxCoeff() << "]\n";
}

// ---------------------------------------------------------------- kinematics

TableBounds<double> Rus6FamilyTable::default_bounds(const Robot& robot) const {
  return kincal::default_bounds(robot.rus6());
}

void Rus6FamilyKinematics::joint_limits(const Robot& robot, Vec6<double>& lo, Vec6<double>& hi) const {
  lo = robot.rus6().min_joint;
  hi = robot.rus6().max_joint;
}

Status Rus6FamilyKinematics::inverse(const Robot& robot, const Pose<double>& pose, Vec6<double>& q, Mat6<double>* J,
                                     double*) const {
  return rus6_ik(robot.rus6(), pose, q, J);
}

bool Rus6FamilyKinematics::forward_jacobian(const Robot& robot, const Pose<double>& pose, Vec6<double>& q,
                                            Mat6<double>& J) const {
  Rus6Legs<double> legs;
  if (rus6_ik(robot.rus6(), pose, q, nullptr, &legs) != Status::Ok) return false;
  return rus6_forward_jacobian(robot.rus6(), legs, J) == Status::Ok && all_finite(J);
}

// core's rus6_formula_joint_values, which the controller evaluates too.
std::vector<FamilyFormulaVariable> Rus6FamilyKinematics::formula_joint_variables() const {
  return {{"rod", "the joint's rod length, mm (the nominal geometry's)"},
          {"lever", "mm of rod per rad of crank at the commanded pose, u . (a x (C - s)) (rods longer by dl act as "
                    "a joint error dl / lever)"}};
}

bool Rus6FamilyKinematics::formula_joint_values(const Robot& robot, const Pose<double>& pose, double* values) const {
  // The commanded pose may lie past the limits (a measured row): the values
  // are read on the geometry with its limits opened, as the node's own IK.
  return rus6_formula_joint_values(without_limits(robot.rus6()), pose, values) == Status::Ok;
}

double Rus6FamilyKinematics::reach(const Robot& robot) const {
  const Rus6Geometry<double>& g = robot.rus6();
  return g.shaft_points.colwise().norm().maxCoeff() + g.crank_length.maxCoeff();
}

// ---------------------------------------------------------------- the table

AnyCalibrationTable Rus6FamilyTable::machine_table(const CalibrationModel& model) const {
  const Rus6Geometry<double>& nominal = model.nominal.rus6();
  Rus6CalibrationTable<double> t{};
  t.machine.nominal = to_table(nominal);
  t.machine.calibrated = to_table(calibrated_robot(model).rus6());  // its IK is the compensation
  t.bounds = kincal::default_bounds(nominal);
  return t;
}

std::vector<TableGroup> Rus6FamilyTable::machine_groups(const Robot&) const {
  std::vector<TableGroup> g;
  for (const char* part : {"machine.nominal.", "machine.calibrated."})
    for (const auto& [name, n] :
         {std::pair{"shaft_points", 18}, {"shaft_axes", 18}, {"crank_zero", 18}, {"crank_length", 6},
          {"rod_length", 6}, {"platform_joints", 18}, {"joint_offset", 6}, {"min_joint", 6}, {"max_joint", 6},
          {"home_branch", 6}, {"home_rotation", 9}, {"home_position", 3}, {"characteristic_length", 1}})
      g.push_back({part + std::string(name), n, {}, {}});
  return g;
}

std::string Rus6FamilyTable::machine_limit_violation(const AnyCalibrationTable& table, const MachineLimits<double>& l) const {
  using detail::first_above;
  const Rus6Machine<double>& m = std::get<Rus6CalibrationTable<double>>(table).machine;
  const auto& c = m.calibrated;
  const auto& n = m.nominal;
  std::string why = first_above("machine.calibrated.shaft_points - nominal", c.shaft_points, l.max_geometry_error,
                                "max_geometry_error", n.shaft_points);
  if (why.empty())
    why = first_above("machine.calibrated.platform_joints - nominal", c.platform_joints, l.max_geometry_error,
                      "max_geometry_error", n.platform_joints);
  if (why.empty())
    why = first_above("machine.calibrated.crank_length - nominal", c.crank_length, l.max_geometry_error,
                      "max_geometry_error", n.crank_length);
  if (why.empty())
    why = first_above("machine.calibrated.rod_length - nominal", c.rod_length, l.max_geometry_error,
                      "max_geometry_error", n.rod_length);
  if (why.empty())
    why = first_above("machine.calibrated.shaft_axes - nominal", c.shaft_axes, l.max_angle_error, "max_angle_error",
                      n.shaft_axes);
  if (why.empty())
    why = first_above("machine.calibrated.crank_zero - nominal", c.crank_zero, l.max_angle_error, "max_angle_error",
                      n.crank_zero);
  return why;
}

// The encoder offsets (the cranks' zeros): one correction at every point.
std::string Rus6FamilyTable::machine_value_violation(const AnyCalibrationTable& table) const {
  const Rus6CalibrationTable<double>& t = std::get<Rus6CalibrationTable<double>>(table);
  for (int i = 0; i < 6; ++i)
    if (!(std::abs(t.machine.encoder_offset(i)) <= t.bounds.max_correction[i]))
      return "crank zero dtheta" + std::to_string(i + 1) + " = " + detail::table_number(t.machine.encoder_offset(i)) +
             " rad above its correction bound " + detail::table_number(t.bounds.max_correction[i]) +
             detail::key_note("max_correction");
  return {};
}

// ---------------------------------------------------------------- simulation

namespace {
Status rus6_commands(const Rus6Geometry<double>& g, const Pose<double>& pose, Vec6<double>& q) { return rus6_ik(g, pose, q); }
FkReport<double> rus6_reached(const Rus6Geometry<double>& g, const Vec6<double>& q, const Pose<double>& guess,
                              Pose<double>& pose) {
  return rus6_fk(g, q, guess, pose);
}
}  // namespace

std::unique_ptr<ActualMachine> Rus6FamilyKinematics::actual_machine(const Robot& nominal, const Robot& actual) const {
  return std::make_unique<CommandsThenFk<Rus6Geometry<double>, rus6_commands, rus6_reached>>(nominal.rus6(),
                                                                                              actual.rus6());
}

const Family& rus6_family() {
  return family_of_capabilities<Rus6FamilyDescription,
                                Rus6FamilyKinematics,
                                Rus6FamilyErrorModel,
                                Rus6FamilyMeasurement,
                                Rus6FamilyTable>();
}

}  // namespace kincal::identify
