// Physical effects, controller half (GUIDE "An effect is the unit of physics").
// Each effect is a named error source with (a) sensitivity columns for
// identification (identify/effects.hpp) and (b) the allocation-free
// correction below, which the controller evaluates every NC point. The two
// halves share the definitions here, so what is identified is what is
// compensated:
//
//   joint-space effects (actual joint = command + Δq, per actuated joint i)
//     scale       Δq_i = s_i · q_i
//     backlash    Δq_i = b_i · dir_i                       (dir_i = ±1, approach direction)
//     compliance  Δq_i = k_i · τ_i                         (τ = static joint load of a unit
//                                                           weight along −z of the base frame at the tool point)
//     cyclic      Δq_i = a_i sin(2π q_i / p) + b_i cos(2π q_i / p)   (screw-driven joints only, p = lead)
//   pose-space effect
//     thermal     every length of structure and actuators × (1 + c·(T − T0)), T0 = 20 °C:
//                 the reached tool point moves away from the base origin o by that factor,
//                 p' = o + (1 + ε)(p − o), ε = c·(T − T0); orientation is unchanged
//                 (a uniform scaling of a mechanism preserves its angles).
//   user joint effect (one plug-in slot, docs/effects.md)
//     user        Δq_i = f(u, i, q, inputs): the user's function f, compiled
//                 into the controller, of up to kUserEffectParameters
//                 identified numbers u (from the table like every other value)
//
// Correction (compensation): the pose is pre-scaled by 1/(1 + ε) before the
// IK, and the IK's ideal joints q* are turned into commands q with
// q + Δq(q) = q* by a fixed-point iteration (Δq is a small, slowly varying
// function of q: |∂Δq/∂q| ≤ |s| + 2π·|(a, b)|/p ≪ 1, so each pass gains that
// factor; kEffectIterations passes reach rounding).
#pragma once

#include <cstdint>

#include "kincal/core/pose.hpp"
#include "kincal/core/small_lu.hpp"
#include "kincal/core/status.hpp"

namespace kincal {

template <class Scalar> struct EffectInputs;

// KINCAL_CORE_USER_EFFECT (default 1): whether the compensation calls the user
// joint effect's function. It is an indirect call, which a static worst-case
// stack analysis cannot bound; firmware without a user effect builds with 0
// (port/baremetal/CMakeLists.txt), and a table that carries user numbers is
// then refused (the model has physics this build has no code for).
#ifndef KINCAL_CORE_USER_EFFECT
#define KINCAL_CORE_USER_EFFECT 1
#endif

// The user joint effect's plug-in point: Δq of joint `joint` (0..5) at
// command q from the identified numbers `u` (kUserEffectParameters of them).
// It runs on the controller every NC point: no heap, no exceptions, bounded
// time; whatever it returns is checked (a non-finite Δq is a status, a large
// one is caught by the correction bound).
// The same slot holds the numbers of a machine's formula effects
// (formula_effects.hpp): a model has either.
constexpr int kUserEffectParameters = 16;
template <class Scalar>
using UserJointError = Scalar (*)(const Scalar* u, int joint, const Vec6<Scalar>& q, const EffectInputs<Scalar>& in);

// Identified effect parameters of one machine (immutable on the controller;
// zero = effect absent). Units: joint units (mm for prismatic, rad for
// revolute joints) per unit of the effect's input.
template <class Scalar> struct EffectParameters {
  Vec6<Scalar> scale = Vec6<Scalar>::Zero();       // s_i, dimensionless
  Vec6<Scalar> backlash = Vec6<Scalar>::Zero();    // b_i, joint units
  Vec6<Scalar> compliance = Vec6<Scalar>::Zero();  // k_i, joint units per unit load τ_i
  Vec6<Scalar> cyclic_sin = Vec6<Scalar>::Zero();  // a_i, joint units
  Vec6<Scalar> cyclic_cos = Vec6<Scalar>::Zero();  // b_i (of the cyclic term), joint units
  Scalar thermal = Scalar(0);                      // c, 1/°C
  Eigen::Matrix<Scalar, kUserEffectParameters, 1> user =
      Eigen::Matrix<Scalar, kUserEffectParameters, 1>::Zero();  // u of the user joint effect
  // The user joint effect's function: code, not data, so not in the table;
  // the controller sets it (Compensator::set_user_effect). Null: no user effect.
  UserJointError<Scalar> user_error = nullptr;

  // Machine data the corrections need (fixed by the robot description).
  Scalar screw_lead = Scalar(5);  // p, mm per revolution
  std::uint8_t screw_joints = 0;  // bit i: joint i is screw driven (cyclic applies)
  Vec3<Scalar> load_direction = -Vec3<Scalar>::UnitZ();  // unit weight direction in the pose frame
  Vec3<Scalar> thermal_origin = Vec3<Scalar>::Zero();    // base origin o in the pose frame
  Scalar reference_temperature = Scalar(20);             // T0, °C

  bool joint_effects_present() const {
    return !(scale.isZero() && backlash.isZero() && compliance.isZero() && cyclic_sin.isZero() &&
             cyclic_cos.isZero() && (user_error == nullptr || user.isZero()));
  }
  bool finite() const {
    return all_finite(scale) && all_finite(backlash) && all_finite(compliance) && all_finite(cyclic_sin) &&
           all_finite(cyclic_cos) && all_finite(user) && is_finite(thermal) && is_finite(screw_lead) && screw_lead > Scalar(0) &&
           all_finite(load_direction) && all_finite(thermal_origin) && is_finite(reference_temperature);
  }

  template <class Other> EffectParameters<Other> cast() const {
    EffectParameters<Other> e;
    e.scale = scale.template cast<Other>();
    e.backlash = backlash.template cast<Other>();
    e.compliance = compliance.template cast<Other>();
    e.cyclic_sin = cyclic_sin.template cast<Other>();
    e.cyclic_cos = cyclic_cos.template cast<Other>();
    e.thermal = Other(thermal);
    e.user = user.template cast<Other>();  // user_error stays null: a function is per scalar type
    e.screw_lead = Other(screw_lead);
    e.screw_joints = screw_joints;
    e.load_direction = load_direction.template cast<Other>();
    e.thermal_origin = thermal_origin.template cast<Other>();
    e.reference_temperature = Other(reference_temperature);
    return e;
  }
};
using EffectParametersd = EffectParameters<double>;
using EffectParametersf = EffectParameters<float>;

// What the joint-space effects depend on at one NC point besides q.
template <class Scalar> struct EffectInputs {
  Vec6<Scalar> direction = Vec6<Scalar>::Ones();  // dir_i = ±1 (backlash)
  Vec6<Scalar> load = Vec6<Scalar>::Zero();       // τ_i (compliance)
};

// Δq of the joint-space effects at command q (the error the machine adds).
template <class Scalar>
Vec6<Scalar> effect_joint_error(const EffectParameters<Scalar>& e, const Vec6<Scalar>& q,
                                const EffectInputs<Scalar>& in) {
  Vec6<Scalar> dq = e.scale.cwiseProduct(q) + e.backlash.cwiseProduct(in.direction) +
                    e.compliance.cwiseProduct(in.load);
  const Scalar k = Scalar(2) * pi<Scalar>() / e.screw_lead;
  // sin_and_cos: libm-free for float and double (core/sin_cos.hpp);
  // identify's automatic-differentiation scalar (Eigen's AutoDiffScalar)
  // uses its own, so the identification columns are this function's
  // derivative (identify/effects.hpp, JointSpaceEffect).
  for (int i = 0; i < 6; ++i) {
    if ((e.screw_joints & (1u << i)) == 0) continue;
    Scalar sine, cosine;
    sin_and_cos(Scalar(k * q(i)), sine, cosine);
    dq(i) += e.cyclic_sin(i) * sine + e.cyclic_cos(i) * cosine;
  }
#if KINCAL_CORE_USER_EFFECT
  if (e.user_error != nullptr)
    for (int i = 0; i < 6; ++i) dq(i) += e.user_error(e.user.data(), i, q, in);
#endif
  return dq;
}

// Static joint load τ of a unit weight at the tool point from the forward
// Jacobian (twist = J_f·q̇): virtual work gives τ = J_fᵀ·(F, 0) with F the
// weight direction (seed 000's actuation wrenches carry it; passive
// constraints do no work).
template <class Scalar>
Vec6<Scalar> static_load_forward(const Mat6<Scalar>& forward_jacobian, const Vec3<Scalar>& weight) {
  return forward_jacobian.template topRows<3>().transpose() * weight;
}

// The same from the IK Jacobian (q̇ = J·twist, as stewart_ik returns it):
// Jᵀ·τ = (F, 0). false if J is singular.


// The static joint load τ of a wrench (F, M) on the pose's reference point
// (a payload's weight at its centre of mass: M = r × F) from the IK Jacobian
// (q̇ = J·twist, as stewart_ik returns it): Jᵀ·τ = (F, M). false if J is
// singular. static_load_inverse: a weight at the reference point (M = 0).
template <class Scalar>
bool static_load_of_wrench(const Mat6<Scalar>& ik_jacobian, const Vec6<Scalar>& wrench, Vec6<Scalar>& load) {
  SmallLu<Scalar, 6> lu;
  if (!factor_regular(lu, Mat6<Scalar>(ik_jacobian.transpose()))) return false;
  load = lu.solve(wrench);
  return all_finite(load);
}
template <class Scalar>
bool static_load_inverse(const Mat6<Scalar>& ik_jacobian, const Vec3<Scalar>& weight, Vec6<Scalar>& load) {
  Vec6<Scalar> wrench;
  wrench << weight, Vec3<Scalar>::Zero();
  return static_load_of_wrench(ik_jacobian, wrench, load);
}

// ε = c·(T − T0).
template <class Scalar> Scalar thermal_strain(const EffectParameters<Scalar>& e, Scalar temperature) {
  return e.thermal * (temperature - e.reference_temperature);
}

// The pose the warm machine reaches when the cold model says `pose` (used by
// the simulator and to predict the error).
template <class Scalar>
Pose<Scalar> thermal_reached(const EffectParameters<Scalar>& e, const Pose<Scalar>& pose, Scalar temperature) {
  Pose<Scalar> out = pose;
  out.p = e.thermal_origin + (Scalar(1) + thermal_strain(e, temperature)) * (pose.p - e.thermal_origin);
  return out;
}

// The pose to hand to the IK so that the warm machine reaches `pose`.
template <class Scalar>
Pose<Scalar> thermal_precorrect(const EffectParameters<Scalar>& e, const Pose<Scalar>& pose, Scalar temperature) {
  Pose<Scalar> out = pose;
  out.p = e.thermal_origin + (pose.p - e.thermal_origin) / (Scalar(1) + thermal_strain(e, temperature));
  return out;
}

constexpr int kEffectIterations = 4;

// Joint commands q with q + Δq(q) = ideal (fixed point, see the header
// comment). Writes `commands` only on Ok; InvalidInput for non-finite input
// or parameters.
// `extra(q, dq)`, if given, adds the Δq of effects outside this table at
// command q (a machine's formula effects, formula_effects.hpp).
template <class Scalar, class Extra>
Status effect_correct_joints(const EffectParameters<Scalar>& e, const Vec6<Scalar>& ideal,
                             const EffectInputs<Scalar>& in, Vec6<Scalar>& commands, Extra extra) {
  if (!all_finite(ideal) || !all_finite(in.direction) || !all_finite(in.load)) return Status::InvalidInput;
  Vec6<Scalar> q = ideal;
  for (int it = 0; it < kEffectIterations; ++it) {
    Vec6<Scalar> dq = effect_joint_error(e, q, in);
    extra(q, dq);
    q = ideal - dq;
  }
  if (!all_finite(q)) return Status::InvalidInput;
  commands = q;
  return Status::Ok;
}
template <class Scalar>
Status effect_correct_joints(const EffectParameters<Scalar>& e, const Vec6<Scalar>& ideal,
                             const EffectInputs<Scalar>& in, Vec6<Scalar>& commands) {
  return effect_correct_joints(e, ideal, in, commands, [](const Vec6<Scalar>&, Vec6<Scalar>&) {});
}

}  // namespace kincal
