#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/hybrid_error_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/LU>

#include "kincal/identify/input_error.hpp"

#include "families/chain_kinematics.hpp"

namespace kincal::identify {

namespace {

using namespace chain;  // chain_kinematics.hpp

constexpr int kUps = 3;      // chains 0..2
constexpr int kUp = 3;       // chain index of the UP limb
constexpr int kWrist = 4;    // chain index of the wrist
constexpr int kUpsParams = 36, kUpParams = 21, kWristParams = 15;

// Builds a chain's constant links from the world poses of its joint frames at a
// reference configuration (joint values q_ref) and of its end frame there.
void set_links(HybridChain& c, const Pose<double>& parent_ref, const Pose<double>* frames, const double* q_ref,
               const Pose<double>& end_ref) {
  Pose<double> prev = parent_ref * c.base;
  for (int j = 0; j < c.joint_count; ++j) {
    c.link[static_cast<std::size_t>(j)] = prev.inverse() * frames[j];
    prev = frames[j] * joint_motion(c.prismatic[static_cast<std::size_t>(j)], q_ref[j]);
  }
  c.end = prev.inverse() * end_ref;
}

}  // namespace

int HybridChain::parameter_count() const { return (base_error ? 6 : 0) + 5 * joint_count; }

void chain_error_adjoints(const HybridChainFrames& frames, const Vec3<double>& P, Eigen::Ref<Eigen::MatrixXd> A) {
  int col = 0;
  for (int f = 0; f < frames.count; ++f) {
    const Pose<double>& fr = frames.frame[static_cast<std::size_t>(f)];
    const Mat6d adj = adjoint(fr.R, Vec3d(fr.p - P));  // seed 000 Eq.
    if (frames.full[static_cast<std::size_t>(f)]) {
      A.middleCols(col, 6) = adj;
      col += 6;
    } else if (frames.prismatic[static_cast<std::size_t>(f)]) {  // k = 1: (Δx, Δy, Δα, Δβ, Δγ)
      A.middleCols(col, 2) = adj.leftCols<2>();
      A.middleCols(col + 2, 3) = adj.rightCols<3>();
      col += 5;
    } else {  // k = 0: (Δx, Δy, Δz, Δα, Δβ)
      A.middleCols(col, 5) = adj.leftCols<5>();
      // Δx, Δy on the end frame (the S centre on the platform; the chain's
      // end is that frame when it has no error of its own).
      if (frames.centre_on_end[static_cast<std::size_t>(f)])
        A.middleCols(col, 2) = adjoint(frames.end.R, Vec3d(frames.end.p - P)).leftCols<2>();
      col += 5;
    }
  }
}

HybridErrorModel::HybridErrorModel(const HybridGeometry<double>& nominal, const HybridErrorModelOptions& options)
    // The error model describes the machine wherever it was measured: the
    // file's joint limits (the controller's business) do not apply here
    // (joint_limits.hpp).
    : g_(without_limits(nominal)), opt_(options) {
  if (!(std::isfinite(opt_.up_split))) throw InputError("hybrid error model: the UP split e must be finite");
  const Vec3d ex = Vec3d::UnitX(), ey = Vec3d::UnitY(), ez = Vec3d::UnitZ();
  const double c_ref = g_.home.extension, e = opt_.up_split;
  // Reference configuration for the frame definitions: every joint angle zero
  // (limb along z0, Rp = I), c = home extension. The platform frame is at A64.
  const Pose<double> world;
  const Pose<double> platform_ref = make_pose(Mat3d::Identity(), c_ref * ez);

  // UPS limbs 1–3: U at A1i (axes z1 = t ⊥ leg, z2 = u × t), P along the leg u
  // from A1i, S at A6i (z4 = t, z5 = u × t, z6 = u); t = u × z0 / |…| is
  // horizontal and normal to the plane of z0 and the leg. x_j is the common
  // normal z_j × z_{j+1} (docs/hybrid-error-model.md).
  int next_param = kEncoderCount;
  for (int i = 0; i < kUps; ++i) {
    HybridChain& c = chains_[static_cast<std::size_t>(i)];
    c.first_joint = 1;
    c.joint_count = 6;
    c.base_error = true;
    c.centre_on_end = true;
    c.prismatic = {false, false, true, false, false, false};
    const Vec3d A1 = g_.base_joints.col(i);
    const Vec3d A6 = platform_ref.p + g_.platform_joints.col(i);
    const double len = (A6 - A1).norm();
    c.base = make_pose(Mat3d::Identity(), A1);  // {R_0,i}: at A1i, axes of {R0}
    const std::array<Pose<double>, 6> frames = ups_reference_frames(A1, A6);
    const double q_ref[6] = {0, 0, len, 0, 0, 0};
    set_links(c, world, frames.data(), q_ref, frames[5]);  // the chain ends at {R_6,i} (moved)
    attach_[static_cast<std::size_t>(i)] = platform_ref.inverse() * frames[5];
    ups_axes_[static_cast<std::size_t>(i)] = frames[5].R;
    ups_reference_[static_cast<std::size_t>(i)] << 0, 0, len, 0, 0, 0;
    c.first_parameter = next_param;
    next_param += c.parameter_count();
  }
  {  // UP limb: U at A0 = Rx(θ1)·Ry(θ2), P along w with variable q34 = c − e.
    HybridChain& c = chains_[kUp];
    c.first_joint = 1;
    c.joint_count = 3;
    c.base_error = true;
    c.prismatic = {false, false, true, false, false, false};
    c.base = Pose<double>();  // {R_0,4} = {R0} at A0
    const Pose<double> frames[3] = {
        make_pose(columns(ez, -ey, ex), Vec3d::Zero()),  // {R_1,4}: z = x0, x = z0 (= z1 × z2)
        make_pose(columns(ex, -ez, ey), Vec3d::Zero()),  // {R_2,4}: z = y0, x = x0 (= z2 × z3)
        make_pose(Mat3d::Identity(), Vec3d::Zero()),     // {R_3,4}: z = z0 (= w), origin A0
    };
    const double q_ref[3] = {0, 0, c_ref - e};
    set_links(c, world, frames, q_ref, platform_ref);  // ends at the platform frame at A64
    c.first_parameter = next_param;
    next_param += c.parameter_count();
  }
  {  // Wrist (joints 4–6 of limb 4), from the platform frame.
    HybridChain& c = chains_[kWrist];
    c.first_joint = 4;
    c.joint_count = 3;
    c.base_error = false;
    c.prismatic = {false, false, false, false, false, false};
    c.base = Pose<double>();
    const double zq = c_ref + g_.platform_to_wrist, zp0 = zq + g_.wrist_link;
    const Pose<double> frames[3] = {
        make_pose(columns(ey, -ex, ez), (c_ref - e) * ez),  // {R_4,4}: z = w, x = z4 × z5, origin A44
        make_pose(columns(ez, -ey, ex), zq * ez),           // {R_5,4}: z = F4·x through Q, x = link Q→P0
        make_pose(columns(ex, -ez, ey), zp0 * ez),          // {R_6,4}: z = F5·y through P0, x = z6 × tool axis
    };
    const double q_ref[3] = {0, 0, 0};
    set_links(c, platform_ref, frames, q_ref, make_pose(g_.tool_offset, (zp0 + g_.tool_length) * ez));
    c.first_parameter = next_param;
    next_param += c.parameter_count();
  }

  // Names (seed 000 symbols).
  static const char* const kComp[6] = {"x", "y", "z", "alpha", "beta", "gamma"};
  static const char* const kSym[6] = {"Δx", "Δy", "Δz", "Δα", "Δβ", "Δγ"};
  params_.reserve(kParameterCount);
  const int enc_limb[6] = {1, 2, 3, 4, 4, 4}, enc_joint[6] = {3, 3, 3, 4, 5, 6};
  for (int k = 0; k < kEncoderCount; ++k) {
    const std::string ji = std::to_string(enc_joint[k]) + "_" + std::to_string(enc_limb[k]);
    params_.push_back({"dxi_" + ji, "Δξ_{a," + std::to_string(enc_joint[k]) + "," + std::to_string(enc_limb[k]) + "}",
                       enc_limb[k], enc_joint[k], 6});
  }
  for (int ci = 0; ci < 5; ++ci) {
    const HybridChain& c = chains_[static_cast<std::size_t>(ci)];
    const int limb = ci < kUps ? ci + 1 : 4;
    auto add = [&](int frame, int comp) {
      const std::string fj = std::to_string(frame), li = std::to_string(limb);
      params_.push_back({std::string("d") + kComp[comp] + "_" + fj + "_" + li,
                         std::string(kSym[comp]) + "_{" + fj + "," + li + "}", limb, frame, comp});
    };
    if (c.base_error)
      for (int comp = 0; comp < 6; ++comp) add(0, comp);
    for (int j = 0; j < c.joint_count; ++j)
      for (int comp = 0; comp < 6; ++comp) {
        if (c.prismatic[static_cast<std::size_t>(j)] ? comp == 2 : comp == 5) continue;
        add(c.first_joint + j, comp);
      }
  }
  // The end frame on the last body (frame 7; end_frame_index): the tool frame
  // on joint 6's body.
  for (int ci : {kWrist}) {
    if (static_cast<int>(params_.size()) != end_frame_index(ci))
      throw InputError("hybrid error model: internal end-frame layout mismatch");
    for (int comp = 0; comp < 6; ++comp) {
      const std::string li = std::to_string(ci < kUps ? ci + 1 : 4);
      params_.push_back({std::string("d") + kComp[comp] + "_7_" + li, std::string(kSym[comp]) + "_{7," + li + "}",
                         ci < kUps ? ci + 1 : 4, 7, comp});
    }
  }
  if (static_cast<int>(params_.size()) != kParameterCount || next_param != kSeedParameterCount)
    throw InputError("hybrid error model: internal parameter count mismatch");
}

int HybridErrorModel::index_of(std::string_view name) const {
  for (std::size_t k = 0; k < params_.size(); ++k)
    if (params_[k].name == name) return static_cast<int>(k);
  return -1;
}

bool HybridErrorModel::tried_last(int k) const {
  if (k < 0 || k >= kParameterCount) return false;
  if (k >= kSeedParameterCount) return true;  // the tool frame
  const HybridErrorParameter& p = params_[static_cast<std::size_t>(k)];
  return p.limb <= kUps && p.frame == 5 && p.component < 3;
}

std::vector<Eigen::Index> HybridErrorModel::selection_order(std::vector<Eigen::Index> columns) const {
  std::stable_partition(columns.begin(), columns.end(), [this](Eigen::Index k) { return !tried_last(int(k)); });
  return columns;
}

HybridChainFrames HybridErrorModel::chain_frames(int ci, const Pose<double>& parent, const double* x,
                                                 const double* eta, const double* end_eta) const {
  const HybridChain& c = chains_[static_cast<std::size_t>(ci)];
  HybridChainFrames out;
  Pose<double> T = parent * c.base;
  int k = 0;
  if (c.base_error) {
    if (eta != nullptr) T = T * error_transform(Eigen::Map<const Vec6d>(eta));
    k = 6;
    out.frame[0] = T;
    out.axis[0] = T;
    out.full[0] = true;
    out.prismatic[0] = false;
    out.count = 1;
  }
  const bool after = opt_.errors_move_with_joint;
  for (int j = 0; j < c.joint_count; ++j) {
    const bool pr = c.prismatic[static_cast<std::size_t>(j)];
    // A UPS limb's S centre on the platform: the last joint's Δx, Δy act
    // after its motion (core's fold_errors, centre_on_end).
    const bool centre_after = c.centre_on_end && !after && j == c.joint_count - 1;
    Vec6d d = Vec6d::Zero();
    if (eta != nullptr) d = expand_joint_error(eta + k, pr);
    Vec6d d_after = Vec6d::Zero();
    if (centre_after) d_after.head<2>() = d.head<2>(), d.head<2>().setZero();
    T = T * c.link[static_cast<std::size_t>(j)];
    if (eta != nullptr && !after) T = T * error_transform(d);
    const std::size_t f = static_cast<std::size_t>(out.count++);
    out.axis[f] = T;
    out.full[f] = false;
    out.prismatic[f] = pr;
    out.centre_on_end[f] = centre_after;
    T = T * joint_motion(pr, x[j]);
    if (centre_after) T = T * error_transform(d_after);
    if (eta != nullptr && after) T = T * error_transform(d);
    out.frame[f] = after ? T : out.axis[f];
    k += 5;
  }
  out.end = T * c.end;
  if (end_eta != nullptr) out.end = out.end * error_transform(Eigen::Map<const Vec6d>(end_eta));
  return out;
}

namespace {

// Newton on the 6 joint variables of a UPS chain so that its end frame
// coincides with `target` (all six DOF; the S joint is three revolutes).
Closure close_chain(const HybridErrorModel& m, int ci, const double* eta, const Pose<double>& target, Vec6d& x) {
  const HybridChain& c = m.chain(ci);
  return chain::close_chain([&](const double* xs) { return m.chain_frames(ci, Pose<double>(), xs, eta); }, c.prismatic,
                            c.base_error ? 1 : 0, target, x);
}

}  // namespace

bool HybridErrorModel::ups_frames(int i, const Pose<double>& platform, HybridChainFrames& frames) const {
  const std::size_t si = static_cast<std::size_t>(i);
  return close_nominal_ups([&](const double* xs) { return chain_frames(i, Pose<double>(), xs, nullptr); },
                           chains_[si].prismatic, 1, chains_[si].base.p, ups_axes_[si], ups_reference_[si],
                           platform * attach_[si], frames);
}

HybridActualFkReport HybridErrorModel::actual_fk(const Eigen::Ref<const Eigen::VectorXd>& errors, const Vec6<double>& q,
                                                 const HybridPassive<double>& guess, Pose<double>& tool,
                                                 HybridPassive<double>* passive) const {
  HybridActualFkReport report;
  if (errors.size() != kParameterCount || !all_finite(errors) || !all_finite(q) || !std::isfinite(guess.theta1) ||
      !std::isfinite(guess.theta2) || !std::isfinite(guess.extension)) {
    report.status = Status::InvalidInput;
    return report;
  }
  const Vec6d physical = q + g_.joint_offset + errors.head<6>();  // Δξ: seed 000 Eq. (2)
  const double* eta = errors.data();
  const double e = opt_.up_split;
  const double tol = std::max(1e-12, 1e-13 * physical.head<3>().cwiseAbs().maxCoeff());
  HybridPassive<double> s = guess;
  std::array<Vec6d, 3> x = ups_reference_;
  for (int it = 0;; ++it) {
    const double xu[3] = {s.theta1, s.theta2, s.extension - e};
    const HybridChainFrames up = chain_frames(kUp, Pose<double>(), xu, eta + chains_[kUp].first_parameter);
    Vec3d r;
    Mat3d M;
    double closure = 0;
    for (int i = 0; i < kUps; ++i) {
      const Pose<double> target = up.end * attach_[static_cast<std::size_t>(i)];
      const Closure cl = close_chain(*this, i, eta + chains_[static_cast<std::size_t>(i)].first_parameter, target,
                                     x[static_cast<std::size_t>(i)]);
      report.inner_iterations = std::max(report.inner_iterations, cl.iterations);
      closure = std::max(closure, cl.error);
      if (cl.status != Status::Ok) {
        report.status = cl.status;
        return report;
      }
      r(i) = x[static_cast<std::size_t>(i)](2) - physical(i);
      // ∂x3,i/∂s_k: the UP joint k moves the platform (and the attachment
      // frame) by its joint twist; the closed UPS chain follows with δx = J⁻¹·twist.
      for (int k = 0; k < 3; ++k)
        M(i, k) = cl.lu.solve(joint_twist(up.axis[static_cast<std::size_t>(1 + k)],
                                          chains_[kUp].prismatic[static_cast<std::size_t>(k)], target.p))(2);
    }
    report.iterations = it;
    report.residual = r.cwiseAbs().maxCoeff();
    report.closure = closure;
    if (report.residual < tol) {
      const double xw[3] = {physical(3), physical(4), physical(5)};
      const Pose<double> T =
          chain_frames(kWrist, up.end, xw, eta + chains_[kWrist].first_parameter, eta + end_frame_index(kWrist)).end;
      Pose<double> out;
      out.R = g_.workpiece_rotation * T.R;
      out.p = g_.workpiece_rotation * (T.p - g_.workpiece_origin);
      if (!out.finite()) break;
      tool = out;
      if (passive != nullptr) *passive = s;
      report.status = Status::Ok;
      return report;
    }
    if (it == kMaxIterations || !(report.residual == report.residual)) break;
    const Eigen::PartialPivLU<Mat3d> lu(M);
    if (!(std::abs(lu.determinant()) > 1e-12)) {
      report.status = Status::Singular;
      return report;
    }
    const Vec3d step = -lu.solve(r);
    s.theta1 += step(0);
    s.theta2 += step(1);
    s.extension += step(2);
  }
  report.status = Status::NotConverged;
  return report;
}

Status HybridErrorModel::error_jacobian(const Pose<double>& nominal_tool, Eigen::MatrixXd& B) const {
  Vec6<double> q;
  HybridPassive<double> s;
  const Status st = hybrid_ik(g_, nominal_tool, q, nullptr, &s);
  if (st != Status::Ok) return st;
  return error_jacobian(s, Vec3d(q.tail<3>() + g_.joint_offset.tail<3>()), B);
}

Status HybridErrorModel::error_jacobian(const HybridPassive<double>& s, const Vec3<double>& wrist_angles,
                                        Eigen::MatrixXd& B) const {
  const double xu[3] = {s.theta1, s.theta2, s.extension - opt_.up_split};
  const HybridChainFrames up = chain_frames(kUp, Pose<double>(), xu, nullptr);
  const HybridChainFrames wr = chain_frames(kWrist, up.end, wrist_angles.data(), nullptr);
  const Vec3d P = wr.end.p;

  // J_P of seed 000 Eq. (5): rows are wrenches W acting on twists (v at P, ω)
  // as Wᵀ·$ = f·v + m·ω. UPS actuation wrenches: unit force along the leg u_i
  // through the S centre A6i, (u_i, r_i × u_i), r_i = A6i − P (ŝ_wa·ŝ_ta,3 = 1).
  // UP constraint wrenches: forces along w2 and n1 = w2 × w3 through A0 and
  // the couple n3 = w2 × w1 (reciprocal to the U and P twists of the UP limb).
  Mat6d JP;
  std::array<HybridChainFrames, 3> ups;
  for (int i = 0; i < kUps; ++i) {
    if (!ups_frames(i, up.end, ups[static_cast<std::size_t>(i)])) return Status::NotConverged;
    const HybridChainFrames& f = ups[static_cast<std::size_t>(i)];
    const Vec3d u = f.axis[3].R.col(2);  // joint 3 (P) axis
    const Vec3d a6 = f.axis[4].p;        // S centre
    JP.block<1, 3>(i, 0) = u.transpose();
    JP.block<1, 3>(i, 3) = (a6 - P).cross(u).transpose();
  }
  const Vec3d w1 = up.axis[1].R.col(2), w2 = up.axis[2].R.col(2), w3 = up.axis[3].R.col(2);
  const Vec3d r0 = up.axis[1].p - P;
  const Vec3d n1 = w2.cross(w3), n3 = w2.cross(w1);
  Eigen::Matrix<double, 3, 6> Wc;
  Wc << w2.transpose(), r0.cross(w2).transpose(), n1.transpose(), r0.cross(n1).transpose(), 0, 0, 0, n3.transpose();
  JP.bottomRows<3>() = Wc;
  const Eigen::PartialPivLU<Mat6d> lu(JP);
  if (!(lu.rcond() > 1e-12)) return Status::Singular;
  const Mat6d JPinv = inverse_of(lu);

  // Assembled at its fixed size (6 × 150 on the stack: every block product
  // below is then of known shape), copied out once.
  Eigen::Matrix<double, 6, kParameterCount> Bf;
  // B_ξ (Eq. (7)): J_P⁻¹ for the UPS encoders, J_S (Eq. (6)) for the wrist's.
  Bf.leftCols<3>() = JPinv.leftCols<3>();
  for (int k = 0; k < 3; ++k) Bf.col(3 + k) = joint_twist(wr.axis[static_cast<std::size_t>(k)], false, P);
  // B_η: J_P⁻¹·G_P (Eqs. (5), (A-3), (A-4)) and G_S (Eq. ).
  Eigen::Matrix<double, 6, kUpsParams> A;
  for (int i = 0; i < kUps; ++i) {
    chain_error_adjoints(ups[static_cast<std::size_t>(i)], P, A);
    const Eigen::Matrix<double, 1, kUpsParams> G = JP.row(i) * A;  // ŝ_wa,3,iᵀ·A_i
    Bf.middleCols<kUpsParams>(chains_[static_cast<std::size_t>(i)].first_parameter).noalias() = JPinv.col(i) * G;
  }
  Eigen::Matrix<double, 6, kUpParams> A4;
  chain_error_adjoints(up, P, A4);
  const Eigen::Matrix<double, 3, kUpParams> Gc = Wc * A4;
  Bf.middleCols<kUpParams>(chains_[kUp].first_parameter).noalias() = JPinv.rightCols<3>() * Gc;
  chain_error_adjoints(wr, P, Bf.middleCols<kWristParams>(chains_[kWrist].first_parameter));
  // The tool frame (frame 7): its error E (tool = T·L_end·E, at P) is its
  // own adjoint there.
  Bf.middleCols<kEndFrameCount>(end_frame_index(kWrist)) = adjoint(wr.end.R, Vec3d(wr.end.p - P));
  // Eq. (8): into the workpiece frame {R}.
  const Mat3d& Rw = g_.workpiece_rotation;
  Bf.topRows<3>() = (Rw * Bf.topRows<3>()).eval();
  Bf.bottomRows<3>() = (Rw * Bf.bottomRows<3>()).eval();
  B = Bf;
  return Status::Ok;
}

HybridActualFkReport hybrid_actual_fk(const HybridGeometry<double>& nominal, const Eigen::Ref<const Eigen::VectorXd>& errors,
                                      const Vec6<double>& q, const HybridPassive<double>& guess, Pose<double>& tool,
                                      HybridPassive<double>* passive) {
  return HybridErrorModel(nominal).actual_fk(errors, q, guess, tool, passive);
}

}  // namespace kincal::identify
