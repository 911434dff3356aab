// A user effect (docs/effects.md walks through it): one templated function,
// which the controller runs and the identification differentiates, and its
// registration. The physics: the lead of
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
// Identification half (host only): the same function, registered. Its
// identification columns are its derivative (automatic differentiation at
// kincal::identify::EffectDual), so nothing else is written.
#include <memory>

#include "kincal/identify/effects.hpp"

namespace quadratic_lead {

inline std::shared_ptr<const kincal::identify::Effect> effect() {
  return std::make_shared<kincal::identify::UserJointEffect>(
      "quadratic_lead", "ball-screw lead drifting along the stroke, dq_i = w_i (q_i - m)^2",
      std::vector<std::string>{"w1", "w2", "w3", "w4", "w5", "w6"}, &joint_error<double>,
      &joint_error<kincal::identify::EffectDual>);
}

}  // namespace quadratic_lead
#endif
