// What the generated-table checks share (generated_formula_table_check.cpp,
// generated_rus6_formula_table_check.cpp): an NC stream of poses with a
// temperature, a time stamp and named inputs; the same stream as the pose
// table `kincal compensate` reads; a generated compensator run over it; and
// its commands against the host's.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "kincal/core/compensation.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/csv.hpp"

namespace kincal_test {

struct StreamPoint {
  kincal::Vec6<double> pose;  // x y z rx ry rz
  double temp = 20, time = 0;
  std::vector<double> inputs;  // the named inputs, in the machine's order
};

using StreamCommands = std::vector<std::pair<kincal::CompensationStatus, kincal::Vec6<double>>>;

// The stream as `kincal compensate`'s pose table, the inputs under `input_names`.
inline kincal::identify::PoseTable stream_pose_table(const std::vector<StreamPoint>& points,
                                                     const std::vector<std::string>& input_names = {}) {
  std::string csv = "id,x,y,z,rx,ry,rz,temp,time";
  for (const std::string& n : input_names) csv += "," + n;
  csv += "\n";
  char number[40];
  for (std::size_t k = 0; k < points.size(); ++k) {
    const StreamPoint& p = points[k];
    std::snprintf(number, sizeof number, "P%03zu", k);
    csv += number;
    std::vector<double> row(p.pose.data(), p.pose.data() + 6);
    row.push_back(p.temp);
    row.push_back(p.time);
    row.insert(row.end(), p.inputs.begin(), p.inputs.end());
    for (const double v : row) {
      std::snprintf(number, sizeof number, ",%.17g", v);
      csv += number;
    }
    csv += "\n";
  }
  kincal::identify::PoseTableOptions options;
  options.input_columns = input_names;
  return kincal::identify::parse_pose_table(csv, "random_poses.csv", options);
}

// A compensator over the stream as `kincal compensate` runs it: from the
// home command, or from zero where the home pose cannot be compensated (a
// formula that reads a named input has none there).
template <class Compensator> StreamCommands stream_commands(const Compensator& c, const std::vector<StreamPoint>& points) {
  using Scalar = typename Compensator::Scalar;
  EXPECT_EQ(c.status(), kincal::CompensationStatus::Ok);
  kincal::Vec6<Scalar> home = kincal::Vec6<Scalar>::Zero();
  if (c.home_command(home) != kincal::CompensationStatus::Ok) home.setZero();
  auto state = c.start(home);
  StreamCommands out;
  for (const StreamPoint& p : points) {
    kincal::NcPoint<Scalar> point;
    point.pose = kincal::Pose<Scalar>::from_xyz_rpy(p.pose.cast<Scalar>());
    point.temperature = Scalar(p.temp);
    point.has_temperature = true;
    point.time = Scalar(p.time);
    Scalar inputs[kincal::kFormulaInputs] = {};
    for (std::size_t i = 0; i < p.inputs.size() && i < std::size_t(kincal::kFormulaInputs); ++i)
      inputs[i] = Scalar(p.inputs[i]);
    point.inputs = inputs;
    kincal::Vec6<Scalar> q = kincal::Vec6<Scalar>::Zero();
    const kincal::CompensationStatus st = c.compensate(state, point, q);
    out.emplace_back(st, st == kincal::CompensationStatus::Ok ? kincal::Vec6<double>(q.template cast<double>())
                                                             : kincal::Vec6<double>::Zero());
  }
  return out;
}

// The largest |generated − host| command where both compensated, the
// statuses compared point by point; `compensated` counts those points.
inline double largest_difference(const kincal::identify::CompensatedStream& host, const StreamCommands& generated,
                                 int& compensated) {
  double worst = 0;
  compensated = 0;
  EXPECT_EQ(host.rows.size(), generated.size());
  for (std::size_t k = 0; k < generated.size() && k < host.rows.size(); ++k) {
    EXPECT_EQ(generated[k].first, host.rows[k].status) << "pose " << k;
    if (host.rows[k].status != kincal::CompensationStatus::Ok ||
        generated[k].first != kincal::CompensationStatus::Ok)
      continue;
    ++compensated;
    worst = std::max(worst, (generated[k].second - host.rows[k].q).cwiseAbs().maxCoeff());
  }
  return worst;
}

}  // namespace kincal_test
