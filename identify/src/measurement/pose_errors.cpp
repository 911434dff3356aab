#include "kincal/identify/pose_errors.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <unordered_map>

#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

namespace {

Pose<double> pose_of(const Vec6<double>& v) { return Pose<double>::from_xyz_rpy(v); }

std::string group_of(const PoseTable& t, const PoseRow& r) {
  return t.has_layer && r.layer ? "layer " + std::to_string(*r.layer) : std::string();
}

void require_measured(const PoseTable& t) {
  if (!t.has_measured)
    throw InputError(t.file, 1, 0,
                     "needs the measured pose columns mx,my,mz,mrx,mry,mrz (gauge-only data is handled by identify)");
}

PoseErrorReport finish(PoseErrorReport report) {
  report.all = summarize(report.rows);
  std::map<std::string, std::vector<PoseErrorRow>> by;
  for (const PoseErrorRow& r : report.rows) {
    const std::string role = r.role == Role::Cal ? "cal" : "test";
    by[role].push_back(r);
    if (!r.group.empty()) by[r.group + " (" + role + ")"].push_back(r);
  }
  for (const auto& [name, rows] : by) report.groups[name] = summarize(rows);
  return report;
}

}  // namespace

PoseErrorReport make_pose_error_report(std::vector<PoseErrorRow> rows, std::size_t skipped) {
  PoseErrorReport report;
  report.rows = std::move(rows);
  report.skipped = skipped;
  return finish(std::move(report));
}

PoseErrorStats summarize(const std::vector<PoseErrorRow>& rows) {
  PoseErrorStats s;
  s.count = rows.size();
  if (rows.empty()) return s;
  double sum_p = 0, sum_p2 = 0, sum_o = 0;
  for (const PoseErrorRow& r : rows) {
    const double p = r.error.head<3>().norm(), o = r.error.tail<3>().norm();
    s.max_position_mm = std::max(s.max_position_mm, p);
    s.max_orientation_rad = std::max(s.max_orientation_rad, o);
    sum_p += p;
    sum_p2 += p * p;
    sum_o += o;
  }
  const double n = double(rows.size());
  s.mean_position_mm = sum_p / n;
  s.rms_position_mm = std::sqrt(sum_p2 / n);
  s.mean_orientation_rad = sum_o / n;
  return s;
}

PoseErrorReport pose_errors(const PoseTable& table) {
  require_measured(table);
  PoseErrorReport report;
  for (const PoseRow& r : table.rows) {
    if (!r.measured) {
      ++report.skipped;
      continue;
    }
    report.rows.push_back({r.id, group_of(table, r), r.role, pose_error(pose_of(*r.measured), pose_of(r.commanded))});
  }
  return finish(std::move(report));
}

PoseErrorReport pose_differences(const PoseTable& a, const PoseTable& b) {
  require_measured(a);
  require_measured(b);
  std::unordered_map<std::string, const PoseRow*> in_b;
  for (const PoseRow& r : b.rows) in_b[r.id] = &r;
  PoseErrorReport report;
  std::size_t matched = 0;
  for (const PoseRow& r : a.rows) {
    const auto it = in_b.find(r.id);
    if (it == in_b.end()) throw InputError(b.file, 0, 0, "has no row '" + r.id + "' (present in " + a.file + ")");
    ++matched;
    if (!r.measured || !it->second->measured) {
      ++report.skipped;
      continue;
    }
    report.rows.push_back(
        {r.id, group_of(a, r), r.role, pose_error(pose_of(*r.measured), pose_of(*it->second->measured))});
  }
  if (matched != b.rows.size())
    for (const PoseRow& r : b.rows)
      if (std::none_of(a.rows.begin(), a.rows.end(), [&](const PoseRow& x) { return x.id == r.id; }))
        throw InputError(a.file, 0, 0, "has no row '" + r.id + "' (present in " + b.file + ")");
  return finish(std::move(report));
}

void print_pose_error_report(const PoseErrorReport& report, std::ostream& out, bool per_row) {
  char line[256];
  if (per_row) {
    std::snprintf(line, sizeof line, "%-10s %11s %11s %11s %11s %11s %11s %11s\n", "id", "dx um", "dy um", "dz um",
                  "dthx urad", "dthy urad", "dthz urad", "|dp| um");
    out << line;
    for (const PoseErrorRow& r : report.rows) {
      const Twist<double>& e = r.error;
      std::snprintf(line, sizeof line, "%-10s %11.3f %11.3f %11.3f %11.3f %11.3f %11.3f %11.3f\n", r.id.c_str(),
                    1e3 * e(0), 1e3 * e(1), 1e3 * e(2), 1e6 * e(3), 1e6 * e(4), 1e6 * e(5), 1e3 * e.head<3>().norm());
      out << line;
    }
    out << "\n";
  }
  if (report.target_points) {
    std::snprintf(line, sizeof line, "%-18s %7s %12s %12s %12s\n", "group", "targets", "max |dp| um", "mean |dp| um",
                  "rms |dp| um");
  } else {
    std::snprintf(line, sizeof line, "%-18s %6s %12s %12s %12s %14s %14s\n", "group", "nodes", "max |dp| um",
                  "mean |dp| um", "rms |dp| um", "max |dth| urad", "mean |dth| urad");
  }
  out << line;
  auto row = [&](const std::string& name, const PoseErrorStats& s) {
    if (report.target_points)
      std::snprintf(line, sizeof line, "%-18s %7zu %12.3f %12.3f %12.3f\n", name.c_str(), s.count,
                    1e3 * s.max_position_mm, 1e3 * s.mean_position_mm, 1e3 * s.rms_position_mm);
    else
      std::snprintf(line, sizeof line, "%-18s %6zu %12.3f %12.3f %12.3f %14.3f %14.3f\n", name.c_str(), s.count,
                    1e3 * s.max_position_mm, 1e3 * s.mean_position_mm, 1e3 * s.rms_position_mm,
                    1e6 * s.max_orientation_rad, 1e6 * s.mean_orientation_rad);
    out << line;
  };
  row("all", report.all);
  for (const auto& [name, s] : report.groups) row(name, s);
  if (report.skipped > 0) out << report.skipped << " row(s) without a measurement were skipped\n";
  if (!report.unevaluated.empty())
    out << report.unevaluated.size() << " measured row(s) could not be evaluated (each named in a warning)\n";
}

}  // namespace kincal::identify
