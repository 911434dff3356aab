// Effects written as formulas, controller half (GUIDE "Effects written as
// formulas", robot description key `effects`; issue #32). The host half —
// parsing, exact derivatives, the identification columns and the C++ the
// table generator prints — is identify/formula_effect.hpp.
//
// A machine's formula effects reach the compensator through a policy type,
// Compensator<Machine, Formulas> (compensation.hpp):
//
//   struct Formulas {
//     static constexpr bool present;  // any formula effect at all
//     // What the formulas may need, at compile time (false: not computed,
//     // no code): a pose-kind effect, the pose variables x..rz, the static
//     // loads `load`, the NC stream's time or named inputs. A generated
//     // policy knows exactly; the host's says true and decides at run time.
//     static constexpr bool pose_twist, reads_pose, reads_load, reads_stream,
//                           reads_family;  // the family's per-joint numbers
//     // Δq of every joint-kind effect, added to dq[0..5], at the variables
//     // `vars` (FormulaVariables' layout) and the numbers `params`
//     // (EffectParameters::user: the table's numbers of the formulas).
//     void add_joint_error(const S* params, const S* vars, S* dq) const;
//     // The twist (dx dy dz drx dry drz; mm, rad, base frame) of every
//     // pose-kind effect, added to twist[0..5].
//     void add_pose_twist(const S* params, const S* vars, S* twist) const;
//     bool has_pose() const;          // any pose-kind effect
//     int input_count() const;        // named inputs the NC point must carry
//     S payload_weight() const;       // the payload `load` is the static load of
//     Vec3<S> payload_com() const;    // its centre of mass, in the pose's body frame
//   };
//
// NoFormulaEffects (the default) has none and compiles to nothing. The host
// (`kincal compensate`) passes the robot description's compiled formulas;
// `kincal table` writes a policy into the generated header whose members
// call the generated functions directly — no function pointer, so the
// firmware's worst-case stack stays statically bounded.
//
// The numbers live in the table's user slot (EffectParameters::user): a
// model carries either a C++ user effect's numbers or its formula effects'
// (identify refuses both in one model), the formulas' in the order of the
// robot description.
#pragma once

#include "kincal/core/pose.hpp"
#include "kincal/core/sin_cos.hpp"

namespace kincal {

// Named measurement inputs a machine's formulas may read (the robot
// description's `inputs`, every effect's together): an NC point carries them
// in that order (NcPoint::inputs).
constexpr int kFormulaInputs = 4;

// Numbers a family offers its formulas per joint (GUIDE "Effects written as
// formulas": "what the family offers"; the 6-RUS's `rod` and `lever`,
// rus6.hpp rus6_formula_joint_values), at most this many.
constexpr int kFormulaFamilyJointVariables = 2;

// The variables of one NC point, in identify's FormulaLayout order for six
// joints (identify/formula_effect.hpp): what the generated functions index.
struct FormulaSlot {
  static constexpr int q = 0;      // q1..q6: the joint commands
  static constexpr int dir = 6;    // dir1..dir6: approach directions, ±1
  static constexpr int load = 12;  // load1..load6: static joint loads under the payload
  static constexpr int temp = 18;  // °C
  static constexpr int time = 19;  // s
  static constexpr int pose = 20;  // x y z rx ry rz of the commanded pose
  static constexpr int input = 26; // the named inputs
  // The family's per-joint numbers, six per variable (identify's
  // FormulaLayout::family_joint with kFormulaInputs input slots).
  static constexpr int family_joint = input + kFormulaInputs;
  static constexpr int count = family_joint + 6 * kFormulaFamilyJointVariables;
};

// `kFamily`: with the family's per-joint slots (a policy that reads them);
// without, 12 numbers fewer on the controller's stack (a generated policy
// whose formulas do not read them never indexes past FormulaSlot::family_joint).
template <class S, bool kFamily = true> struct FormulaVariables {
  static constexpr int size = kFamily ? FormulaSlot::count : FormulaSlot::family_joint;
  S v[size] = {};
  void set_joints(const Vec6<S>& q) {
    for (int i = 0; i < 6; ++i) v[FormulaSlot::q + i] = q(i);
  }
  void set_directions(const Vec6<S>& d) {
    for (int i = 0; i < 6; ++i) v[FormulaSlot::dir + i] = d(i);
  }
  void set_loads(const Vec6<S>& l) {
    for (int i = 0; i < 6; ++i) v[FormulaSlot::load + i] = l(i);
  }
  void set_pose(const Pose<S>& p) {
    const Vec6<S> x = p.to_xyz_rpy();
    for (int i = 0; i < 6; ++i) v[FormulaSlot::pose + i] = x(i);
  }
};

// No formula effect (the default policy): nothing to evaluate, no code.
struct NoFormulaEffects {
  static constexpr bool present = false;
  static constexpr bool pose_twist = false, reads_pose = false, reads_load = false, reads_stream = false,
                        reads_family = false;
  template <class S> void add_joint_error(const S*, const S*, S*) const {}
  template <class S> void add_pose_twist(const S*, const S*, S*) const {}
  bool has_pose() const { return false; }
  int input_count() const { return 0; }
};

// The pose to command so that a machine whose tool lands `twist(pose)` away
// from the command reaches `pose`: p' = p − d, R' = exp(−ω)·R, iterated (the
// twist is a slowly varying function of the pose, like the joint effects'
// fixed point, effects.hpp). `twist_at(pose, twist)` evaluates the twist.
template <class S, class TwistAt> Pose<S> formula_pose_precorrect(const Pose<S>& pose, TwistAt twist_at) {
  Pose<S> command = pose;
  for (int it = 0; it < 3; ++it) {
    Vec6<S> t;
    twist_at(command, t);
    command.p = pose.p - t.template head<3>();
    const Vec3<S> w = -t.template tail<3>();
    const S angle = w.norm();
    Mat3<S> E = Mat3<S>::Identity();
    if (angle > S(0)) {
      // Rodrigues: exp([w]×) = I + sin θ [k]× + (1 − cos θ) [k]×².
      const Vec3<S> k = w / angle;
      Mat3<S> K;
      K << S(0), -k(2), k(1), k(2), S(0), -k(0), -k(1), k(0), S(0);
      S sine, cosine;
      sin_and_cos(angle, sine, cosine);
      E += sine * K + (S(1) - cosine) * K * K;
    }
    command.R = E * pose.R;
  }
  return command;
}

}  // namespace kincal
