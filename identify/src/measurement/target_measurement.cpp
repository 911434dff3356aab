#include "kincal/identify/target_measurement.hpp"

#include "kincal/identify/decompositions.hpp"

namespace kincal::identify {

TargetPoints predicted_targets(const Pose<double>& registration, const Pose<double>& platform,
                               const std::vector<Vec3<double>>& targets) {
  const Pose<double> T = registration * platform;
  TargetPoints y(3, Eigen::Index(targets.size()));
  for (std::size_t k = 0; k < targets.size(); ++k) y.col(Eigen::Index(k)) = T.transform(targets[k]);
  return y;
}

Eigen::MatrixXd target_map(const Pose<double>& registration, const Pose<double>& platform,
                           const std::vector<Vec3<double>>& targets) {
  Eigen::MatrixXd M(3 * Eigen::Index(targets.size()), 6);
  for (std::size_t k = 0; k < targets.size(); ++k) {
    const Eigen::Index r = 3 * Eigen::Index(k);
    M.block<3, 3>(r, 0) = registration.R;
    // ω × a = −[a]×·ω, a the target's arm from the platform origin (base axes).
    M.block<3, 3>(r, 3) = -registration.R * skew<double>(platform.R * targets[k]);
  }
  return M;
}

Eigen::MatrixXd instrument_columns(const Pose<double>& registration, const Pose<double>& platform,
                                   const std::vector<Vec3<double>>& targets) {
  const Eigen::Index k = Eigen::Index(targets.size());
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(3 * k, 6 + 3 * k);
  const TargetPoints y = predicted_targets(registration, platform, targets);
  const Mat3<double> to_instrument = registration.R * platform.R;
  for (Eigen::Index j = 0; j < k; ++j) {
    C.block<3, 3>(3 * j, 0).setIdentity();
    C.block<3, 3>(3 * j, 3) = -skew<double>(y.col(j));
    C.block<3, 3>(3 * j, 6 + 3 * j) = to_instrument;
  }
  return C;
}

Pose<double> moved_registration(const Pose<double>& registration, const Vec6<double>& twist) {
  const Mat3<double> dR = exp_so3(Vec3<double>(twist.tail<3>()));
  Pose<double> out;
  out.R = dR * registration.R;
  out.p = dR * registration.p + twist.head<3>();
  return out;
}

Pose<double> rigid_fit(const TargetPoints& from, const TargetPoints& to) {
  const Vec3<double> cf = from.rowwise().mean(), ct = to.rowwise().mean();
  const Mat3<double> S = (to.colwise() - ct) * (from.colwise() - cf).transpose();
  const Eigen::JacobiSVD<Mat3<double>> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3<double> D = Mat3<double>::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;  // a rotation, not a mirror
  Pose<double> T;
  T.R = svd.matrixU() * D * svd.matrixV().transpose();
  T.p = ct - T.R * cf;
  return T;
}

Eigen::Matrix<double, 6, Eigen::Dynamic> rigid_motion_rows(const TargetPoints& points) {
  Eigen::Matrix<double, 6, Eigen::Dynamic> C(6, 3 * points.cols());
  for (Eigen::Index j = 0; j < points.cols(); ++j) {
    C.block<3, 3>(0, 3 * j).setIdentity();
    // e_a · (p_j × d_j) for a = x, y, z: the rows of [p_j]×.
    C.block<3, 3>(3, 3 * j) = skew<double>(points.col(j));
  }
  return C;
}

}  // namespace kincal::identify
