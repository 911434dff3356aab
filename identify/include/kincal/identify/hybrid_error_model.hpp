// Joint/link-level source errors of the hybrid robot (3-UPS + UP + 3R wrist,
// seed 000): the parametrisation of Appendix A, the nonlinear machine carrying
// every source error (the "truth", like the paper's CAD skeleton), and the
// linearised screw-theory error model $_t = B·Δχ of seed 000 Eqs. (2)–(8).
// Frame placement, names and counts: docs/hybrid-error-model.md.
//
// Every limb is a serial chain of 1-DOF joints (U = 2 R, S = 3 R, P):
//   T_end = T_parent · B0 · E_0 · Π_j ( L_j · E_j · M_j(x_j) ) · L_end
// B0 the base frame {R_0,i}, L_j the nominal link from the previous joint's
// moved frame to joint j's frame {R_j,i} (origin A_j,i on the axis, z_j,i along
// it; fixed on the body that carries the joint), M_j = Rz(x) (R) or Tz(x) (P),
// and E_j = Trans(Δx, Δy, Δz)·Rx(Δα)·Ry(Δβ)·Rz(Δγ) the structural error of
// frame j, in that frame. Δη_0,i has all six components; Δη_j,i omits the
// one along (P: Δz) or about (R: Δγ) the joint axis — it is the joint
// variable's own (the encoder offset Δξ if actuated, absorbed if passive).
//
// Twists are (v at the tool point P, ω), both in the workpiece frame {R}:
// exactly kincal::pose_error(actual, nominal) of core/pose.hpp.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "kincal/core/hybrid.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/core/status.hpp"

namespace kincal::identify {

// One entry of Δχ = (Δξ, Δη) (seed 000 Eq. (7)).
struct HybridErrorParameter {
  std::string name;    // stable: "dxi_3_1" = Δξ_{a,3,1}, "dx_2_1" = Δx_{2,1}, "dalpha_0_4" = Δα_{0,4}
  std::string symbol;  // seed 000's symbol, e.g. "Δx_{2,1}", "Δξ_{a,3,1}"
  int limb = 0;        // i: 1–3 UPS limbs, 4 the UP limb and the wrist
  int frame = 0;       // j: 0 (base frame) … 6, 7 the end frame on the last body
  int component = 0;   // 0..5 = x, y, z, α, β, γ of {R_j,i}; 6 = encoder offset Δξ
  bool encoder() const { return component == 6; }
  bool angular() const { return component == 6 ? limb == 4 : component >= 3; }  // wrist encoders are angles
  const char* unit() const { return angular() ? "rad" : "mm"; }
};

// A serial chain (one limb, or the wrist) in nominal form. Poses are rigid
// transforms; the chain's world frames follow from its parent frame.
struct HybridChain {
  static constexpr int kMaxJoints = 6;
  int first_joint = 1;       // j of the first joint (1 for limbs, 4 for the wrist)
  int joint_count = 0;
  bool base_error = true;    // frame 0 carries Δη_0 (limbs); the wrist has none
  bool centre_on_end = false;  // UPS limbs: the last joint's Δx, Δy displace the S centre on the platform
  Pose<double> base;         // {R_0,i} in the parent frame
  std::array<bool, kMaxJoints> prismatic{};
  std::array<Pose<double>, kMaxJoints> link{};  // L_j: previous moved frame → {R_j,i}
  Pose<double> end;          // L_end: last moved frame → the chain's end frame
  int first_parameter = 0;   // index in Δχ of this chain's first Δη column
  int parameter_count() const;  // 6·base_error + 5·joint_count
};

// World poses ({R0}) of a chain's error frames at one configuration:
// frame[0] = {R_0,i} (if base_error), then {R_j,i} for each joint.
struct HybridChainFrames {
  int count = 0;
  std::array<Pose<double>, HybridChain::kMaxJoints + 1> frame{};  // where Δη_j acts (A_j,i of Eq.)
  std::array<Pose<double>, HybridChain::kMaxJoints + 1> axis{};   // joint j's axis: z through the origin
  std::array<bool, HybridChain::kMaxJoints + 1> prismatic{};  // frame 0: false (all six kept)
  std::array<bool, HybridChain::kMaxJoints + 1> full{};       // true for frame 0: six columns
  std::array<bool, HybridChain::kMaxJoints + 1> centre_on_end{};  // Δx, Δy act on `end` (HybridChain::centre_on_end)
  Pose<double> end;
};

// seed 000 Eq.: A_i = [A_{j_i,i} … A_{n_i,i}], the twists at P ({R0}
// axes) per unit structural error of each kept component of every frame,
// A_{j,i} of Eq. with R_{j,i} the frame's orientation and r_{j,i} = A_{j,i} − P.
// `A` must have 6 rows and the chain's parameter_count() columns.
void chain_error_adjoints(const HybridChainFrames& frames, const Vec3<double>& P, Eigen::Ref<Eigen::MatrixXd> A);

struct HybridErrorModelOptions {
  // e = |A_{4,4} A_{6,4}| (seed 000 Table 1): splits c = q_{3,4} + e and puts
  // the wrist's first frame {R_4,4} at A_{4,4}, e below the platform centre.
  double up_split = 345.0;
  // Where E_j sits relative to joint j's motion M_j. false (default, the
  // convention of this model): T = … L_j·E_j·M_j(x_j) …, so Δη_j is the
  // misplacement of joint j's axis on the body that carries it and there is no
  // error of the last link. true: … L_j·M_j(x_j)·E_j …, Δη_j rides on the body
  // that joint j moves (DH-like link errors; Δη_n is then the platform-side
  // attachment of a UPS limb and the tool frame on the wrist). Same count,
  // different span; docs/hybrid-error-model.md compares the identifiable sets.
  bool errors_move_with_joint = false;
};

struct HybridActualFkReport {
  Status status = Status::NotConverged;
  int iterations = 0;        // outer Newton steps on the UP passive (θ1, θ2, c)
  int inner_iterations = 0;  // largest number of Newton steps of one UPS closure
  double residual = 0;       // largest |prismatic − (command + offset)| at the end, mm
  double closure = 0;        // largest UPS closure pose error at the end (mm, or rad × 1000 mm)
};

class HybridErrorModel {
 public:
  // Column layout of Δχ (seed 000 Eq. (7)): the 6 encoder offsets Δξ first
  // (dxi_3_1, dxi_3_2, dxi_3_3, dxi_4_4, dxi_5_4, dxi_6_4), then Δη limb by
  // limb: UPS limbs 1, 2, 3 (frames 0–6: 6 + 6·5 = 36 each), the UP limb
  // (frames 0–3: 6 + 3·5 = 21), the wrist (frames 4–6: 15) — seed 000's
  // 150 — then the tool frame on joint 6's body, six errors ("frame 7" of
  // limb 4; issue #31: without it nothing after the last joint could be
  // identified). 156 in all. It comes last so that the first 150 keep seed
  // 000's order and a model written before it reads the same. The UPS
  // limbs' S centres on the platform are joint 6's Δx, Δy (after its motion)
  // and Δz (docs/hybrid-error-model.md §1, §3).
  static constexpr int kEncoderCount = 6;
  static constexpr int kSeedParameterCount = 150;
  static constexpr int kEndFrameCount = 6;
  static constexpr int kParameterCount = kSeedParameterCount + kEndFrameCount;
  // Index in Δχ of chain c's end frame errors (4: the tool frame), −1 for a
  // chain without (the UPS limbs and the UP limb).
  static constexpr int end_frame_index(int c) { return c == 4 ? kSeedParameterCount : -1; }

  explicit HybridErrorModel(const HybridGeometry<double>& nominal, const HybridErrorModelOptions& options = {});

  const HybridGeometry<double>& nominal() const { return g_; }
  const HybridErrorModelOptions& options() const { return opt_; }
  const std::vector<HybridErrorParameter>& parameters() const { return params_; }
  int size() const { return kParameterCount; }
  int index_of(std::string_view name) const;  // −1 if unknown
  // Columns the column selection tries after all others and keeps only
  // where the design tells them from those (distance ≥ kTriedLastTolerance):
  // the tool frame, and in each UPS limb Δη_5's translations — offsets
  // between the S joint's axes, which a ball joint does not have, nearly
  // collinear over a workspace with the S centre on the platform (Δz_5,i
  // with Δy_6,i; docs/hybrid-error-model.md §3).
  bool tried_last(int k) const;
  static constexpr double kTriedLastTolerance = 0.03;
  // Whether column k, kept by a selection at `distance` from the span of
  // those before it, is held all the same (tried_last and nearer than
  // kTriedLastTolerance): the rule every hybrid column selection applies.
  bool held_as_tried_last(int k, double distance) const { return tried_last(k) && distance < kTriedLastTolerance; }
  // `columns` (indices into Δχ) with the tried_last ones moved to the end,
  // each group in its own order.
  std::vector<Eigen::Index> selection_order(std::vector<Eigen::Index> columns) const;
  // Chains: 0–2 the UPS limbs, 3 the UP limb, 4 the wrist. Their Δη (the
  // `eta` of chain_frames) start at chain(c).first_parameter; the end frames
  // at end_frame_index(c).
  const HybridChain& chain(int c) const { return chains_[static_cast<std::size_t>(c)]; }
  // The UPS S-joint attachment frame on the platform (platform-frame coordinates).
  const Pose<double>& attachment(int i) const { return attach_[static_cast<std::size_t>(i)]; }

  // The erroneous machine's tool pose in {R} for commanded joints q (physical
  // joint = q + nominal().joint_offset + Δξ): the UP limb's passive (θ1, θ2, c)
  // by an outer Newton so that each UPS prismatic equals its command, each UPS
  // chain closed on its platform attachment frame by an inner 6×6 Newton (2 U,
  // P, 3 S joint variables), the wrist serial from the platform. `errors` has
  // size() entries (Δχ). Writes `tool` / `passive` only on Ok. Status:
  // InvalidInput (non-finite or wrong-size input), Singular, NotConverged.
  HybridActualFkReport actual_fk(const Eigen::Ref<const Eigen::VectorXd>& errors, const Vec6<double>& q,
                                 const HybridPassive<double>& guess, Pose<double>& tool,
                                 HybridPassive<double>* passive = nullptr) const;

  // B (6 × size()) of seed 000 Eq. (8) at the nominal configuration of a
  // commanded tool pose in {R} (nominal IK): $_t = B·Δχ, $_t = (v at P, ω) in
  // {R}. B is resized only if needed. Returns the IK status, or Singular when
  // J_P of Eq. (5) is singular; B is written only on Ok.
  Status error_jacobian(const Pose<double>& nominal_tool, Eigen::MatrixXd& B) const;
  // The same at a given physical configuration: UP passive s and wrist angles.
  Status error_jacobian(const HybridPassive<double>& s, const Vec3<double>& wrist_angles, Eigen::MatrixXd& B) const;

  // Frames of chain c at joint values x (nominal when `eta` is null; else
  // `eta` points at the chain's Δη block of Δχ), with parent pose `parent`.
  // `end_eta` (the wrist only: its six tool-frame errors, end_frame_index(4))
  // moves the end frame on joint 6's body: end = T·L_end·E. A UPS limb's end
  // errors belong to the platform, so they move its closure target
  // (platform·attachment·E), not the chain.
  HybridChainFrames chain_frames(int c, const Pose<double>& parent, const double* x, const double* eta,
                                 const double* end_eta = nullptr) const;
  // Frames of nominal UPS chain i (0–2) closed on the platform pose (in {R0});
  // false if the closure fails.
  bool ups_frames(int i, const Pose<double>& platform, HybridChainFrames& frames) const;

 private:
  HybridGeometry<double> g_;
  HybridErrorModelOptions opt_;
  std::array<HybridChain, 5> chains_{};
  std::array<Pose<double>, 3> attach_{};
  std::array<Vec6<double>, 3> ups_reference_{};  // UPS joint values at the home configuration
  std::array<Mat3<double>, 3> ups_axes_{};       // UPS reference S axes [t, u × t, u] (closed-form closure)
  std::vector<HybridErrorParameter> params_;
};

// Convenience: builds the model for `nominal` and runs actual_fk.
HybridActualFkReport hybrid_actual_fk(const HybridGeometry<double>& nominal, const Eigen::Ref<const Eigen::VectorXd>& errors,
                                      const Vec6<double>& q, const HybridPassive<double>& guess, Pose<double>& tool,
                                      HybridPassive<double>* passive = nullptr);

}  // namespace kincal::identify
