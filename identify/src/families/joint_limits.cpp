#include "kincal/identify/joint_limits.hpp"

#include <cmath>
#include <sstream>

#include "families/family.hpp"

namespace kincal::identify {

namespace {

constexpr double kOpen = 1e9;  // hybrid.hpp's default "no limit"

std::string amount(double v, const char* unit) {
  std::ostringstream s;
  s.precision(6);
  s << v << " " << unit;
  return s.str();
}

// "q3 = 286.6 mm is 3.36 mm above its limit 283.24 mm", or "" inside.
std::string outside(const std::string& name, double v, double lo, double hi, const char* unit) {
  if (v >= lo && v <= hi) return {};
  const bool above = v > hi;
  return name + " = " + amount(v, unit) + " is " + amount(above ? v - hi : lo - v, unit) +
         (above ? " above its limit " : " below its limit ") + amount(above ? hi : lo, unit);
}

}  // namespace

StewartGeometry<double> without_limits(StewartGeometry<double> g) {
  g.min_length.setConstant(-kOpen);
  g.max_length.setConstant(kOpen);
  return g;
}

HybridGeometry<double> without_limits(HybridGeometry<double> g) {
  g.min_joint.setConstant(-kOpen);
  g.max_joint.setConstant(kOpen);
  g.min_extension = 0;  // c = |A0 A64| > 0: a geometric floor, not a stroke
  g.max_extension = kOpen;
  return g;
}

Rus6Geometry<double> without_limits(Rus6Geometry<double> g) {
  const double half_turn = pi<double>() * (1 - 1e-12);  // strictly narrower than a turn (rus6_valid_geometry)
  for (int i = 0; i < 6; ++i) {
    const double mid = 0.5 * (g.min_joint(i) + g.max_joint(i));
    g.min_joint(i) = mid - half_turn;
    g.max_joint(i) = mid + half_turn;
  }
  return g;
}

Robot without_limits(Robot robot) {
  std::visit([](auto& part) { part.geometry = without_limits(part.geometry); }, robot.family_data);
  return robot;
}

std::vector<std::string> joint_limit_warnings(const Robot& robot, const PoseTable& data) {
  const Robot open = without_limits(robot);
  const Family& family = family_of(robot);
  const std::vector<PassiveLimit> passive = family.kinematics().passive_limits(robot);
  std::vector<std::string> out;
  for (const PoseRow& r : data.rows) {
    Vec6<double> q;
    if (r.q && r.q->size() >= 6) {
      q = r.q->head<6>();
    } else if (open.inverse(Pose<double>::from_xyz_rpy(r.commanded), q) != Status::Ok) {
      continue;
    }
    const std::string where = data.file + ":" + std::to_string(r.line) + ": warning: row '" + r.id + "': ";
    const char* tail = " (the row is used: limits bound the controller, not the measurement)";
    Vec6<double> lo, hi;
    robot.joint_limits(lo, hi);
    for (int i = 0; i < 6; ++i) {
      const std::string msg = outside("q" + std::to_string(i + 1), q(i), lo(i), hi(i), robot.revolute(i) ? "rad" : "mm");
      if (!msg.empty()) out.push_back(where + msg + tail);
    }
    if (passive.empty()) continue;
    std::vector<double> value(passive.size());
    Vec6<double> q_ik;
    if (family.kinematics().inverse(open, Pose<double>::from_xyz_rpy(r.commanded), q_ik, nullptr, value.data()) != Status::Ok)
      continue;
    for (std::size_t k = 0; k < passive.size(); ++k) {
      const std::string msg = outside(passive[k].name, value[k], passive[k].lo, passive[k].hi, passive[k].unit);
      if (!msg.empty()) out.push_back(where + msg + tail);
    }
  }
  return out;
}

}  // namespace kincal::identify
