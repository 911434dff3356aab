#include "kincal/identify/gauge.hpp"

#include <cmath>
#include <sstream>
#include <string>

#include "kincal/identify/input_error.hpp"
#include "kincal/identify/measurement_model.hpp"
#include "kincal/identify/simulate.hpp"

namespace kincal::identify {

Eigen::Matrix<double, 9, 6> gauge_map(const HybridGeometry<double>& g, double radius, const Pose<double>& nominal_tool) {
  const Eigen::Matrix<double, 3, 3> t = gauge_targets(g, radius, nominal_tool);
  Eigen::Matrix<double, 9, 6> M;
  for (int j = 0; j < 3; ++j) {
    // Δp_j = v + ω × (P_j − P) = v + [p̂_j×]·ω with p̂_j = P − P_j (P_j → P).
    const Vec3<double> p_hat = nominal_tool.p - t.col(j);
    M.block<3, 3>(3 * j, 0).setIdentity();
    M.block<3, 3>(3 * j, 3) = skew(p_hat);
  }
  return M;
}

// The three kinds are instances of the one measurement model: the gauge, the
// full pose, and a single target at the tool point P.
MeasurementModel measurement_model(MeasurementKind kind, const HybridGeometry<double>& g, double radius) {
  switch (kind) {
    case MeasurementKind::GaugeTargets: return MeasurementModel::gauge(g, radius);
    case MeasurementKind::FullPose: return MeasurementModel::full_pose();
    case MeasurementKind::Position: break;
  }
  return MeasurementModel::targets({Vec3<double>::Zero()});
}

void measurement_map(MeasurementKind kind, const HybridGeometry<double>& g, double radius,
                     const Pose<double>& nominal_tool, Eigen::MatrixXd& M) {
  M = measurement_model(kind, g, radius).map(nominal_tool);
}

Eigen::VectorXd measurement_deviation(MeasurementKind kind, const HybridGeometry<double>& g, double radius,
                                      const Pose<double>& actual_tool, const Pose<double>& nominal_tool) {
  switch (kind) {
    case MeasurementKind::GaugeTargets: {
      const Eigen::Matrix<double, 3, 3> d =
          gauge_targets(g, radius, actual_tool) - gauge_targets(g, radius, nominal_tool);
      return Eigen::Map<const Eigen::Matrix<double, 9, 1>>(d.data());  // column-major: P1, P2, P3
    }
    case MeasurementKind::FullPose: return pose_error(actual_tool, nominal_tool);
    case MeasurementKind::Position: return actual_tool.p - nominal_tool.p;
  }
  return {};
}

void identification_jacobian(const HybridErrorModel& model, MeasurementKind kind, double radius,
                             const std::vector<Pose<double>>& nodes, Eigen::MatrixXd& H) {
  const Eigen::Index r = measurement_rows(kind);
  const Eigen::Index n = static_cast<Eigen::Index>(nodes.size());
  if (H.rows() != r * n || H.cols() != model.size()) H.resize(r * n, model.size());
  const MeasurementModel measurement = measurement_model(kind, model.nominal(), radius);
  Eigen::MatrixXd B(6, model.size());
  for (Eigen::Index k = 0; k < n; ++k) {
    const Pose<double>& node = nodes[static_cast<std::size_t>(k)];
    const Status st = model.error_jacobian(node, B);
    if (st != Status::Ok)
      throw InputError("identification Jacobian: node " + std::to_string(k) + ": error model failed (" + to_string(st) +
                       ")");
    measurement.design_into(node, B, H.middleRows(k * r, r));
  }
}

Eigen::MatrixXd identification_jacobian(const HybridErrorModel& model, MeasurementKind kind, double radius,
                                        const std::vector<Pose<double>>& nodes) {
  Eigen::MatrixXd H;
  identification_jacobian(model, kind, radius, nodes, H);
  return H;
}

void require_gauge_triangles(const PoseTable& data, double radius) {
  if (data.has_targets && data.target_columns() != 3)
    throw InputError(data.file, 1, 0,
                     "the hybrid is measured by seed 000's three-target gauge: t1x..t3z (the table has " +
                         std::to_string(data.target_columns()) + " target(s))");
  const double side = std::sqrt(3.0) * radius;
  for (const PoseRow& row : data.rows) {
    if (!row.targets) continue;
    const Eigen::Matrix<double, 3, 3>& t = *row.targets;
    for (int a = 0; a < 3; ++a) {
      const int b = (a + 1) % 3;
      const double d = (t.col(a) - t.col(b)).norm();
      if (!(std::abs(d - side) <= 0.1 * side)) {
        std::ostringstream msg;
        msg << "row '" << row.id << "': measured targets t" << a + 1 << " and t" << b + 1 << " are " << d
            << " mm apart, the gauge's are " << side << " mm (radius " << radius
            << " mm in the robot description): a blunder in t" << a + 1 << " or t" << b + 1
            << " (correct it or drop the row)";
        throw InputError(data.file, row.line, 0, msg.str());
      }
    }
  }
}

std::vector<Pose<double>> translation_grid(const std::vector<double>& layers, int L, double half_width,
                                           const Mat3<double>& R) {
  if (L < 1) throw InputError("translation grid: L must be at least 1");
  std::vector<Pose<double>> out;
  out.reserve(layers.size() * static_cast<std::size_t>(L * L));
  for (double z : layers)
    for (int iy = 0; iy < L; ++iy)
      for (int ix = 0; ix < L; ++ix) {
        const double sx = L == 1 ? 0.0 : -half_width + 2.0 * half_width * ix / (L - 1);
        const double sy = L == 1 ? 0.0 : -half_width + 2.0 * half_width * iy / (L - 1);
        Pose<double> p;
        p.R = R;
        p.p = Vec3<double>(sx, sy, z);
        out.push_back(p);
      }
  return out;
}

}  // namespace kincal::identify
