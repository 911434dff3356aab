#include "kincal/identify/stewart_error_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/LU>

#include "kincal/identify/input_error.hpp"

#include "families/chain_kinematics.hpp"

namespace kincal::identify {

namespace {

using namespace chain;  // chain_kinematics.hpp

Closure close_leg(const StewartErrorModel& m, int i, const double* eta, const Pose<double>& target, Vec6d& x) {
  return chain::close_chain([&](const double* xs) { return m.chain_frames(i, xs, eta); }, m.chain(i).prismatic, 1,
                            target, x);
}

}  // namespace

StewartErrorModel::StewartErrorModel(const StewartGeometry<double>& nominal) : g_(nominal) {
  if (!g_.home.finite() || !all_finite(g_.base) || !all_finite(g_.platform))
    throw InputError("stewart error model: non-finite geometry");
  // Reference configuration: the home pose; U and S angles zero there, frames
  // as the hybrid's UPS limbs (docs/hybrid-error-model.md).
  const Pose<double> world;
  int next_param = kEncoderCount;
  for (int i = 0; i < 6; ++i) {
    HybridChain& c = chains_[static_cast<std::size_t>(i)];
    c.first_joint = 1;
    c.joint_count = 6;
    c.base_error = true;
    c.prismatic = {false, false, true, false, false, false};
    const Vec3d A1 = g_.base.col(i);
    const Vec3d A6 = g_.home.transform(Vec3d(g_.platform.col(i)));
    const double len = (A6 - A1).norm();
    if (!(len > 0)) throw InputError("stewart error model: zero leg length at home");
    c.base = make_pose(Mat3d::Identity(), A1);
    const std::array<Pose<double>, 6> frames = ups_reference_frames(A1, A6);
    const double q_ref[6] = {0, 0, len, 0, 0, 0};
    Pose<double> prev = world * c.base;
    for (int j = 0; j < 6; ++j) {
      c.link[static_cast<std::size_t>(j)] = prev.inverse() * frames[j];
      prev = frames[j] * joint_motion(c.prismatic[static_cast<std::size_t>(j)], q_ref[j]);
    }
    c.end = prev.inverse() * frames[5];
    attach_[static_cast<std::size_t>(i)] = g_.home.inverse() * frames[5];
    leg_axes_[static_cast<std::size_t>(i)] = frames[5].R;
    reference_[static_cast<std::size_t>(i)] << 0, 0, len, 0, 0, 0;
    c.first_parameter = next_param;
    next_param += c.parameter_count();
  }
  static const char* const kComp[6] = {"x", "y", "z", "alpha", "beta", "gamma"};
  static const char* const kSym[6] = {"Δx", "Δy", "Δz", "Δα", "Δβ", "Δγ"};
  params_.reserve(kParameterCount);
  for (int i = 1; i <= 6; ++i)
    params_.push_back({"dxi_3_" + std::to_string(i), "Δξ_{a,3," + std::to_string(i) + "}", i, 3, 6});
  for (int i = 1; i <= 6; ++i) {
    const HybridChain& c = chains_[static_cast<std::size_t>(i - 1)];
    auto add = [&](int frame, int comp) {
      const std::string fj = std::to_string(frame), li = std::to_string(i);
      params_.push_back({std::string("d") + kComp[comp] + "_" + fj + "_" + li,
                         std::string(kSym[comp]) + "_{" + fj + "," + li + "}", i, frame, comp});
    };
    for (int comp = 0; comp < 6; ++comp) add(0, comp);
    for (int j = 0; j < 6; ++j)
      for (int comp = 0; comp < 6; ++comp) {
        if (c.prismatic[static_cast<std::size_t>(j)] ? comp == 2 : comp == 5) continue;
        add(1 + j, comp);
      }
  }
  if (static_cast<int>(params_.size()) != kParameterCount || next_param != kParameterCount)
    throw InputError("stewart error model: internal parameter count mismatch");
}

int StewartErrorModel::index_of(std::string_view name) const {
  for (std::size_t k = 0; k < params_.size(); ++k)
    if (params_[k].name == name) return static_cast<int>(k);
  return -1;
}

HybridChainFrames StewartErrorModel::chain_frames(int i, const double* x, const double* eta) const {
  const HybridChain& c = chains_[static_cast<std::size_t>(i)];
  HybridChainFrames out;
  Pose<double> T = c.base;
  if (eta != nullptr) T = T * error_transform(Eigen::Map<const Vec6d>(eta));
  out.frame[0] = T;
  out.axis[0] = T;
  out.full[0] = true;
  out.prismatic[0] = false;
  out.count = 1;
  int k = 6;
  for (int j = 0; j < c.joint_count; ++j) {
    const bool pr = c.prismatic[static_cast<std::size_t>(j)];
    T = T * c.link[static_cast<std::size_t>(j)];
    if (eta != nullptr) T = T * error_transform(expand_joint_error(eta + k, pr));
    const std::size_t f = static_cast<std::size_t>(out.count++);
    out.axis[f] = T;
    out.frame[f] = T;
    out.full[f] = false;
    out.prismatic[f] = pr;
    T = T * joint_motion(pr, x[j]);
    k += 5;
  }
  out.end = T * c.end;
  return out;
}

bool StewartErrorModel::leg_frames(int i, const Pose<double>& platform, HybridChainFrames& frames) const {
  const std::size_t si = static_cast<std::size_t>(i);
  return close_nominal_ups([&](const double* xs) { return chain_frames(i, xs, nullptr); }, chains_[si].prismatic, 1,
                           chains_[si].base.p, leg_axes_[si], reference_[si], platform * attach_[si], frames);
}

StewartActualFkReport StewartErrorModel::actual_fk(const Eigen::Ref<const Eigen::VectorXd>& errors, const Vec6<double>& q,
                                                   const Pose<double>& guess, Pose<double>& pose) const {
  StewartActualFkReport report;
  if (errors.size() != kParameterCount || !all_finite(errors) || !all_finite(q) || !guess.finite()) {
    report.status = Status::InvalidInput;
    return report;
  }
  const Vec6d physical = q + g_.length_offset + errors.head<6>();
  const double tol = std::max(1e-12, 1e-13 * physical.cwiseAbs().maxCoeff());
  Pose<double> X = guess;
  std::array<Vec6d, 6> x = reference_;
  for (int it = 0;; ++it) {
    Vec6d r;
    Mat6d M;
    double closure = 0;
    for (int i = 0; i < 6; ++i) {
      const std::size_t si = static_cast<std::size_t>(i);
      const Pose<double> target = X * attach_[si];
      const Closure cl = close_leg(*this, i, errors.data() + chains_[si].first_parameter, target, x[si]);
      report.inner_iterations = std::max(report.inner_iterations, cl.iterations);
      closure = std::max(closure, cl.error);
      if (cl.status != Status::Ok) {
        report.status = cl.status;
        return report;
      }
      r(i) = x[si](2) - physical(i);
      // A platform twist (v at OP, ω) moves the attachment frame by the twist
      // (v + ω × (A − OP), ω) at its origin; the closed leg follows with J⁻¹ of that.
      for (int k = 0; k < 6; ++k) {
        Vec6d tw = Vec6d::Zero();
        if (k < 3) {
          tw(k) = 1;
        } else {
          const Vec3d w = Vec3d::Unit(k - 3);
          tw.head<3>() = w.cross(Vec3d(target.p - X.p));
          tw.tail<3>() = w;
        }
        M(i, k) = cl.lu.solve(tw)(2);
      }
    }
    report.iterations = it;
    report.residual = r.cwiseAbs().maxCoeff();
    report.closure = closure;
    if (report.residual < tol) {
      pose = X;
      report.status = Status::Ok;
      return report;
    }
    if (it == kMaxIterations || !(report.residual == report.residual)) break;
    const Eigen::PartialPivLU<Mat6d> lu(M);
    if (!(lu.rcond() > 1e-12)) {
      report.status = Status::Singular;
      return report;
    }
    const Twist<double> step = -lu.solve(r);
    X = apply_twist(X, step);
  }
  report.status = Status::NotConverged;
  return report;
}

Status StewartErrorModel::error_jacobian(const Pose<double>& platform, Eigen::MatrixXd& B) const {
  if (!platform.finite()) return Status::InvalidInput;
  const Vec3d P = platform.p;
  Mat6d J;
  std::array<HybridChainFrames, 6> legs;
  for (int i = 0; i < 6; ++i) {
    const std::size_t si = static_cast<std::size_t>(i);
    if (!leg_frames(i, platform, legs[si])) return Status::NotConverged;
    const Vec3d u = legs[si].axis[3].R.col(2);  // P axis
    const Vec3d a6 = legs[si].axis[4].p;        // S centre
    J.block<1, 3>(i, 0) = u.transpose();
    J.block<1, 3>(i, 3) = (a6 - P).cross(u).transpose();
  }
  const Eigen::PartialPivLU<Mat6d> lu(J);
  if (!(lu.rcond() > 1e-12)) return Status::Singular;
  const Mat6d Jinv = inverse_of(lu);
  if (B.rows() != 6 || B.cols() != kParameterCount) B.resize(6, kParameterCount);
  B.leftCols<6>() = Jinv;
  Eigen::Matrix<double, 6, kLegParameters> A;
  for (int i = 0; i < 6; ++i) {
    const std::size_t si = static_cast<std::size_t>(i);
    chain_error_adjoints(legs[si], P, A);
    const Eigen::Matrix<double, 1, kLegParameters> G = J.row(i) * A;  // ŝ_wa,iᵀ·A_i
    B.middleCols<kLegParameters>(chains_[si].first_parameter).noalias() = Jinv.col(i) * G;
  }
  return Status::Ok;
}

}  // namespace kincal::identify
