// A user effect, both halves (docs/effects.md walks through it): the lead of
// each ball screw of a 6-UPS drifts linearly along its stroke, so the
// position error it accumulates grows with the square of the distance from
// mid-stroke:
//
//   Δq_i = w_i · (q_i − m)²,   m = 233.23808 mm (stewart-seed001's nominal leg,
//                              the middle of its ±50 mm stroke), w_i in 1/mm.
//
// None of the library's effects has this shape: `scale` is linear in q,
// `cyclic` periodic. A base model's leg offsets and a scale would absorb the
// mean and the slope of (q − m)² over the measured strokes, but not its
// curvature.
#pragma once

#include "kincal/core/effects.hpp"

namespace quadratic_lead {

inline constexpr double kMidStroke = 233.23808;  // mm

// Controller half: core's UserJointError. Runs on the controller every NC
// point, so only arithmetic (no heap, no exceptions), in any scalar type;
// the numbers u are the identified w_1..w_6 from the table.
template <class Scalar>
Scalar joint_error(const Scalar* u, int joint, const kincal::Vec6<Scalar>& q, const kincal::EffectInputs<Scalar>&) {
  const Scalar d = q(joint) - Scalar(kMidStroke);
  return u[joint] * d * d;
}

}  // namespace quadratic_lead

#ifndef QUADRATIC_LEAD_CONTROLLER_ONLY
// Identification half (host only): the sensitivity columns and where the
// identified values go. Registered with kincal::identify::register_effect.
#include "kincal/identify/effects.hpp"

namespace quadratic_lead {

class Effect final : public kincal::identify::Effect {
 public:
  std::string name() const override { return "quadratic_lead"; }
  std::string description() const override {
    return "ball-screw lead drifting along the stroke, dq_i = w_i (q_i - m)^2";
  }
  std::vector<std::string> parameter_names(const kincal::identify::Robot&) const override {
    return {"w1", "w2", "w3", "w4", "w5", "w6"};
  }
  // Needs only the joint commands, which every data set has (or implies).
  std::string missing_inputs(const kincal::identify::PoseTable&) const override { return {}; }
  // Tool twist per unit w_i: joint i's error twist times ∂Δq_i/∂w_i = (q_i − m)².
  void twist_columns(const kincal::identify::Robot&, const kincal::EffectParameters<double>&,
                     const kincal::identify::EffectNode& node, Eigen::Ref<Eigen::MatrixXd> columns) const override {
    for (int i = 0; i < 6; ++i) {
      const double d = node.q(i) - kMidStroke;
      columns.col(i) = node.joint_twist.col(i) * (d * d);
    }
  }
  // The numbers go to core's user slot, the function with them.
  void apply(const kincal::identify::Robot&, const Eigen::VectorXd& values,
             kincal::EffectParameters<double>& out) const override {
    for (int i = 0; i < 6; ++i) out.user(i) += values(i);
    out.user_error = &joint_error<double>;
  }
};

}  // namespace quadratic_lead
#endif
