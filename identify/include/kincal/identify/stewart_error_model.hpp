// Joint-level source errors of the 6-UPS `stewart-seed001` (issue #3 item 1),
// modelled exactly like the hybrid's UPS limbs (identify/hybrid_error_model.hpp,
// seed 000 Appendix A): every leg i is a serial chain
//   base → {R_0,i} → U (joints 1, 2: R) → P (joint 3, actuated) → S (4–6: R) → platform attachment
// with E_j = Trans(Δx,Δy,Δz)·Rx(Δα)·Ry(Δβ)·Rz(Δγ) placed before joint j's
// motion; frame 0 carries all six components, joint frames five (Δz of the P
// joint is its encoder offset Δξ_3,i, Δγ of an R joint its own variable).
// 6 encoder offsets + 6 × (6 + 6·5) = 222 parameters. docs/stewart-error-model.md.
//
// Twists are (v at the platform origin OP, ω), base-frame axes: exactly
// kincal::pose_error(actual, nominal) of core/pose.hpp on platform poses.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "kincal/core/stewart.hpp"
#include "kincal/identify/hybrid_error_model.hpp"

namespace kincal::identify {

struct StewartActualFkReport {
  Status status = Status::NotConverged;
  int iterations = 0;        // outer Newton steps on the platform pose
  int inner_iterations = 0;  // largest number of Newton steps of one leg closure
  double residual = 0;       // largest |prismatic − (command + offset + Δξ)| at the end, mm
  double closure = 0;        // largest leg closure error at the end (mm, or rad × 1000 mm)
};

class StewartErrorModel {
 public:
  // Column layout of Δχ: dxi_3_1 … dxi_3_6 (leg-length encoder offsets), then
  // leg by leg (i = 1..6) frame 0 (dx_0_i … dgamma_0_i) and frames 1–6 (five each).
  static constexpr int kEncoderCount = 6;
  static constexpr int kLegParameters = 36;
  static constexpr int kParameterCount = kEncoderCount + 6 * kLegParameters;  // 222

  explicit StewartErrorModel(const StewartGeometry<double>& nominal);

  const StewartGeometry<double>& nominal() const { return g_; }
  // The same HybridErrorParameter record as the hybrid (limb = leg i, 1..6).
  const std::vector<HybridErrorParameter>& parameters() const { return params_; }
  int size() const { return kParameterCount; }
  int index_of(std::string_view name) const;  // −1 if unknown
  const HybridChain& chain(int i) const { return chains_[static_cast<std::size_t>(i)]; }
  const Pose<double>& attachment(int i) const { return attach_[static_cast<std::size_t>(i)]; }

  // Frames of leg i (0..5) at joint values x; `eta` points at the leg's Δη
  // block (36 values) or is null for the nominal chain.
  HybridChainFrames chain_frames(int i, const double* x, const double* eta) const;
  // Frames of nominal leg i closed on the platform pose; false on failure.
  bool leg_frames(int i, const Pose<double>& platform, HybridChainFrames& frames) const;

  // Platform pose of the erroneous machine for commands q (physical leg
  // variable = q + length_offset + Δξ): outer Newton on the pose from `guess`,
  // each leg closed on its attachment frame by an inner 6×6 Newton. Writes
  // `pose` only on Ok. Status: InvalidInput, Singular, NotConverged.
  StewartActualFkReport actual_fk(const Eigen::Ref<const Eigen::VectorXd>& errors, const Vec6<double>& q,
                                  const Pose<double>& guess, Pose<double>& pose) const;

  // B (6 × 222) at a nominal platform pose: $ = J⁻¹(Δξ + G·Δη), J the rows of
  // unit actuation wrenches (core's stewart_jacobian), G_i = ŝ_wa,iᵀ·A_i.
  // Status: Singular / NotConverged; B written only on Ok.
  Status error_jacobian(const Pose<double>& platform, Eigen::MatrixXd& B) const;

 private:
  StewartGeometry<double> g_;
  std::array<HybridChain, 6> chains_{};
  std::array<Pose<double>, 6> attach_{};
  std::array<Vec6<double>, 6> reference_{};
  std::array<Mat3<double>, 6> leg_axes_{};  // reference S axes [t, u × t, u] (closed-form closure)
  std::vector<HybridErrorParameter> params_;
};

}  // namespace kincal::identify
