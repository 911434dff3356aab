// Compensation on the controller: one NC point at a time, allocation-free,
// the same routine for the firmware and for `kincal compensate` on the host.
//
// Model and workspace apart (pinocchio's Model/Data): a Compensator is built
// once from an immutable CalibrationTable (core/calibration_table.hpp, checked
// by validate_table) and never changes; the caller owns a CompensatorState
// with what the controller remembers between points (the last safe command,
// each joint's approach direction, event counters per status).
//
// Per NC point (docs/compensation.md):
//   1. the nominal pose (and temperature, if given) must be finite, its
//      rotation orthonormal (a skewed matrix is a corrupt NC point, not a
//      pose), explicit approach directions exactly ±1;
//   2. the nominal configuration of that pose: its nominal IK command q_nom
//      (the reference of the correction bound), the singularity test (6-UPS:
//      the IK Jacobian; hybrid: hybrid_wrenches, det J_f = det(W_c·J_S)/det J_P)
//      and, where needed, the static joint load of a unit weight (compliance)
//      — evaluated there, like identify's effect nodes;
//   3. thermal: the pose is pre-scaled about the base origin by 1/(1 + ε),
//      ε = c·(T − T0) (core/effects.hpp);
//   4. geometry:
//        hybrid: q* = the exact IK of the identified machine (hybrid_exact.hpp:
//          the chains with ξ̂ and Δχ̂ folded, a serial Newton for the UP limb
//          and the wrist, a closure per UPS limb; issue #31 — seed 000 Eq.
//          (16)'s first-order twist left micrometres at 1 mm errors); with
//          Δχ̂ = 0, the ideal IK with the encoder offsets ξ̂ (Fig. 4);
//        6-UPS (seed 001): q* = IK of the calibrated geometry;
//   5. joint-space effects (scale, backlash, compliance, cyclic): the command q
//      with q + Δq(q) = q* (effect_correct_joints); the backlash direction of
//      joint i is the sign of the change of q*_i from the last accepted point,
//      kept while the joint stands still (or the NC point's explicit
//      directions);
//   6. checks: |q − q_nom| ≤ bounds.max_correction (else OversizedCorrection),
//      bounds.min_joint ≤ q ≤ bounds.max_joint (else OutOfLimits). With
//      machine limits (machine_limits.hpp, compiled in apart from the table)
//      the table was refused unless those bounds lie inside them, so no
//      command outside the drives' range can leave.
// On Ok the command is written and remembered. On any failure the command
// output is the last safe command (held), the state's counter of that status
// is incremented, and nothing else changes; no NaN ever leaves.
#pragma once

#include <cstdint>

#include "kincal/core/calibration_table.hpp"
#include "kincal/core/compensation_status.hpp"
#include "kincal/core/effects.hpp"
#include "kincal/core/formula_effects.hpp"
#include "kincal/core/hybrid.hpp"
#include "kincal/core/hybrid_exact.hpp"
#include "kincal/core/machine_limits.hpp"
#include "kincal/core/stewart.hpp"

// Whether the hybrid compensator stores the identified machine's chains
// (3.5 KiB in double, built once when the table is loaded) or builds each
// chain per point from the table's numbers (no RAM beyond the stack). On by
// default on the host, off in firmware (port/baremetal defines
// KINCAL_FIRMWARE); a controller with the RAM to spare may define it to 1.
#ifndef KINCAL_HYBRID_STORED_CHAINS
#if defined(KINCAL_FIRMWARE) && KINCAL_FIRMWARE
#define KINCAL_HYBRID_STORED_CHAINS 0
#else
#define KINCAL_HYBRID_STORED_CHAINS 1
#endif
#endif

namespace kincal {

// One NC point.
template <class Scalar> struct NcPoint {
  Pose<Scalar> pose;                 // nominal pose, in the machine's pose frame
  Scalar temperature = Scalar(0);    // structure temperature, °C (thermal effect)
  bool has_temperature = false;      // false: the table's T0 (no thermal correction)
  // Explicit approach directions (±1) for the backlash effect; null: derived
  // from the command sequence. Must stay valid during the call only.
  const Vec6<Scalar>* direction = nullptr;
  // For the machine's formula effects (formula_effects.hpp): the time
  // stamp, s (0 if not given), and the named inputs, kFormulaInputs values in
  // the machine's input order (the robot description's); null: none, which
  // a machine whose formulas read inputs refuses (InvalidInput). Must stay
  // valid during the call only.
  Scalar time = Scalar(0);
  const Scalar* inputs = nullptr;
};

// What the controller remembers between points (the workspace).
#if KINCAL_HYBRID_STORED_CHAINS
template <class S> using CompensatorWarmStart = HybridExactWarmStart<S>;
#else
template <class S> struct CompensatorWarmStart {};  // a controller builds each chain per point, from cold
#endif

template <class Scalar> struct CompensatorState {
  // The last safe joint command: the output of every failed point.
  Vec6<Scalar> command = Vec6<Scalar>::Zero();
  // Effect-free joint values q* of the last accepted point: the reference the
  // approach directions are judged against.
  Vec6<Scalar> reference = Vec6<Scalar>::Zero();
  // The controller's record of each joint's approach direction (±1).
  Vec6<Scalar> direction = Vec6<Scalar>::Ones();
  // Events per status (index = static_cast<int>(CompensationStatus)); [Ok]
  // counts accepted points.
  std::uint32_t events[kCompensationStatusCount] = {};
  CompensationStatus last = CompensationStatus::Ok;
#if KINCAL_HYBRID_STORED_CHAINS
  // The hybrid's exact IK starts each point from the last one's solution
  // where it is near (hybrid_exact.hpp HybridExactWarmStart; ~2.5 KiB in
  // double, host only like the stored chains it belongs to).
  CompensatorWarmStart<Scalar> hybrid_start;
#endif

  std::uint32_t count(CompensationStatus s) const { return events[static_cast<int>(s)]; }
  std::uint32_t failures() const {
    std::uint32_t n = 0;
    for (int k = 1; k < kCompensationStatusCount; ++k) n += events[k];
    return n;
  }
};
using CompensatorStated = CompensatorState<double>;
using CompensatorStatef = CompensatorState<float>;

// A joint "stands still" when its change is below this × (1 + |q|) (identify's
// direction rule uses 1e-12 in double).
template <class Scalar> struct StillTolerance;
template <> struct StillTolerance<double> {
  static constexpr double value = 1e-12;
};
template <> struct StillTolerance<float> {
  static constexpr float value = 1e-6f;
};

// |RᵀR − I| allowed in an NC pose: rounding of a rotation built in the
// scalar (a matrix ×1.001 is not a rotation and is refused).
template <class Scalar> struct RotationTolerance;
template <> struct RotationTolerance<double> {
  static constexpr double value = 1e-9;
};
template <> struct RotationTolerance<float> {
  static constexpr float value = 1e-5f;
};

template <class Scalar> bool orthonormal(const Mat3<Scalar>& R) {
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b) {
      const Scalar d = R.col(a).dot(R.col(b)) - (a == b ? Scalar(1) : Scalar(0));
      if (!((d < Scalar(0) ? -d : d) <= RotationTolerance<Scalar>::value)) return false;
    }
  return true;
}

namespace compensation_detail {

// The machine-specific half of the compensator, one specialisation per
// family: the Compensator reaches a machine only through it (issue #33: no
// if/else over families). Each holds the controller's copies of the table's
// geometry and provides
//   bool load(const Machine&)         — the copies (false: unusable values);
//   Pose home_pose() const            — the pose home_command() compensates;
//   Status nominal_configuration(pose, q_nom, need_load, g, load,
//       payload_weight, payload_com, payload_load, family_values) const
//                                     — step 2: q_nom, the singularity test,
//                                       the static load of a unit weight
//                                       along g (if need_load) and of the
//                                       formulas' payload (if payload_load),
//                                       and what the family offers formulas
//                                       per joint there (if family_values:
//                                       FormulaSlot::family_joint, only for
//                                       a policy that reads_family; a family
//                                       that offers nothing ignores it);
//   bool exact() const, Status solve_exact(target, q*, warm) const,
//   Status solve_closed_form(target, q*) const
//                                     — step 4: the geometry's IK, by an
//                                       iterative exact model where the
//                                       family has one and the table needs
//                                       it, else in closed form (apart, so
//                                       that the two are never on the
//                                       controller's stack together);
// Step 2's payload is a weight and a centre of mass in the platform frame
// (formula_effects.hpp); a family that takes it elsewhere says so.
template <class Machine> struct Model;

// Step 2's static loads for a family whose nominal IK gives J = ∂q/∂twist
// at the platform origin (6-UPS, 6-RUS): J_ikᵀ·τ = wrench, as identify's
// nodes. The load of a unit weight along g at the origin (if need_load), and
// the payload's: force F = w·g and moment r × F, r the centre of mass in the
// base frame (written out by component: Eigen's vectorized cross of two
// float Vec3 reads 16 bytes of a 12-byte vector, GCC 12's -Warray-bounds on
// x86). Singular where J_ik cannot carry the wrench.
template <bool kPayload, class S>
Status ik_jacobian_loads(const Mat6<S>& J, const Pose<S>& pose, bool need_load, const Vec3<S>& g, Vec6<S>& load,
                         [[maybe_unused]] S payload_weight, [[maybe_unused]] const Vec3<S>& payload_com,
                         [[maybe_unused]] Vec6<S>* payload_load) {
  if (need_load && !static_load_inverse(J, g, load)) return Status::Singular;
  if constexpr (kPayload) {
    const S w = payload_weight;
    const Vec3<S> r = pose.R * payload_com;
    Vec6<S> wrench;
    wrench << w * g(0), w * g(1), w * g(2), w * (r(1) * g(2) - r(2) * g(1)), w * (r(2) * g(0) - r(0) * g(2)),
        w * (r(0) * g(1) - r(1) * g(0));
    if (!static_load_of_wrench(J, wrench, *payload_load)) return Status::Singular;
  }
  return Status::Ok;
}

template <class S> struct Model<StewartMachine<S>> {
  StewartGeometry<S> nominal;
  StewartGeometry<S> calibrated;
  bool load(const StewartMachine<S>& m) {
    nominal = to_core(m.nominal);
    calibrated = to_core(m.calibrated);
    return true;
  }
  Pose<S> home_pose() const { return nominal.home; }

  // The nominal IK with its Jacobian: the singularity test of the NC point,
  // q_nom, and the static load (J_ikᵀ·τ = (F, 0), as identify's nodes).
  template <bool kPayload>
  Status nominal_configuration(const Pose<S>& pose, Vec6<S>& nominal_q, bool need_load, const Vec3<S>& g, Vec6<S>& load,
                               S payload_weight, const Vec3<S>& payload_com, Vec6<S>* payload_load, S*) const {
    Mat6<S> J;
    const Status s = stewart_ik(nominal, pose, nominal_q, &J);
    if (s != Status::Ok) return s;
    return ik_jacobian_loads<kPayload>(J, pose, need_load, g, load, payload_weight, payload_com, payload_load);
  }

  // seed 001: the IK of the calibrated geometry is the compensation; there
  // is no iterative model (exact() is false at compile time, so solve_exact
  // is never called and only keeps Compensator::solve one form).
  static constexpr bool exact() { return false; }
  template <class Warm> Status solve_exact(const Pose<S>& target, Vec6<S>& ideal, Warm*) const {
    return solve_closed_form(target, ideal);
  }
  Status solve_closed_form(const Pose<S>& target, Vec6<S>& ideal) const { return stewart_ik(calibrated, target, ideal); }
};

template <class S> struct Model<HybridMachine<S>> {
  HybridGeometry<S> nominal;     // q_nom, the singularity test; the exact IK's start
  HybridGeometry<S> controller;  // nominal with joint_offset += ξ̂: the ideal IK when Δχ̂ = 0
  // The identified machine's numbers, read in place from the table (which
  // outlives the compensator): a controller's exact IK builds each chain
  // from them where it needs it (hybrid_exact.hpp; stored, the chains are
  // 3.5 KiB of doubles its static RAM does not have). A host build stores
  // them once here instead (KINCAL_HYBRID_STORED_CHAINS), which takes the
  // building — two fifths of a point's instructions — off every point.
  const S* source_errors = nullptr;    // Δχ̂
  const S* encoder_offsets = nullptr;  // ξ̂
  S up_split = S(345);
  bool structural = false;  // any Δχ̂ ≠ 0: the exact IK
#if KINCAL_HYBRID_STORED_CHAINS
  HybridChains<S> chains;
#endif
  bool load(const HybridMachine<S>& m) {
    nominal = to_core(m.nominal);
    controller = nominal;
    for (int i = 0; i < 6; ++i) controller.joint_offset(i) += m.encoder_offsets[i];
    source_errors = m.source_errors;
    encoder_offsets = m.encoder_offsets;
    up_split = m.up_split;
    structural = false;
    for (int k = 0; k < kHybridSourceErrorCount; ++k) structural = structural || m.source_errors[k] != S(0);
    if (!finite_source_errors(m.source_errors, m.encoder_offsets)) return false;
#if KINCAL_HYBRID_STORED_CHAINS
    if (structural && hybrid_exact_chains(nominal, up_split, source_errors, chains, encoder_offsets) != Status::Ok)
      return false;
#endif
    return true;
  }
  // The reference pose: the origin of {R} with the tool aligned to it.
  Pose<S> home_pose() const { return Pose<S>(); }

  // q_nom from the nominal closed form; the singularity test (parallel,
  // constraint and wrist: hybrid_wrenches), with J_P factorised once; the
  // static loads. The payload acts at the tool point (identify refuses a
  // centre of mass elsewhere), so `payload_com` is not read.
  template <bool kPayload>
  Status nominal_configuration(const Pose<S>& pose, Vec6<S>& nominal_q, bool need_load, const Vec3<S>& g, Vec6<S>& load,
                               [[maybe_unused]] S payload_weight, const Vec3<S>&,
                               [[maybe_unused]] Vec6<S>* payload_load, S*) const {
    HybridFrames<S> f;
    Vec3<S> angles;
    Status s = hybrid_frames_at_pose(nominal, pose, f, angles);
    if (s != Status::Ok) return s;
    nominal_q.template head<3>() = f.legs.colwise().norm().transpose();
    nominal_q.template tail<3>() = angles;
    nominal_q -= nominal.joint_offset;
    HybridWrenches<S> w;
    s = hybrid_wrenches(nominal, f, w);
    if (s != Status::Ok) return s;
    if (need_load) load = hybrid_static_load(nominal, f, w, g);
    if constexpr (kPayload) *payload_load = payload_weight * hybrid_static_load(nominal, f, w, g);
    return Status::Ok;
  }

  // The identified machine's exact IK (issue #31); with no structural
  // error it is seed 000 Fig. 4's ideal IK with ξ̂.
  bool exact() const { return structural; }
  template <class Warm> Status solve_exact(const Pose<S>& target, Vec6<S>& ideal, [[maybe_unused]] Warm* warm) const {
#if KINCAL_HYBRID_STORED_CHAINS
    return hybrid_exact_ik(nominal, chains, target, ideal, nullptr, warm);
#else
    return hybrid_exact_ik(nominal, up_split, source_errors, encoder_offsets, target, ideal);
#endif
  }
  Status solve_closed_form(const Pose<S>& target, Vec6<S>& ideal) const { return hybrid_ik(controller, target, ideal); }
};

}  // namespace compensation_detail

// The tag of Compensator's trusting form, Compensator(table,
// trust_table_bounds): the table's own bounds serve as the machine's limits,
// with the default caps (limits_from_bounds). A table checked against itself
// proves nothing about the machine, so this form is for host tools that built
// the table from a robot description they trust, never a firmware's choice by
// accident: there is no one-argument constructor, and the tag's explicit
// default constructor makes `Compensator(table, {})` ambiguous, so that does
// not compile either.
struct TrustTableBounds {
  explicit constexpr TrustTableBounds() = default;
};
inline constexpr TrustTableBounds trust_table_bounds{};

// `Formulas`: the machine's formula effects (formula_effects.hpp; none by
// default, and then no code for them).
template <class Machine, class Formulas = NoFormulaEffects> class Compensator {
 public:
  using Scalar = typename Machine::Scalar;
  using Table = CalibrationTable<Machine>;
  using State = CompensatorState<Scalar>;
  static constexpr MachineFamily family = Machine::family;

  // Checks the table (validate_table) and prepares the controller's copies of
  // its geometry and effects. The table must outlive the compensator (the
  // hybrid's Δχ̂ is read in place, so a table in flash stays there). If the
  // check fails, status() says why and every compensate() returns that status
  // and holds its output: the caller falls back to a nominal table. A
  // temporary table is refused at compile time (deleted overload below): it
  // would dangle.
  //
  // `limits` are the machine's limits known apart from the table
  // (machine_limits.hpp): the table is refused (TableLimits) unless its
  // bounds, corrections and effect values lie inside them. With
  // `trust_table_bounds` instead, the table's own bounds serve (host tools
  // that built the table from a robot description they trust; see
  // TrustTableBounds).
  Compensator(const Table&& table, TrustTableBounds, const Formulas& = Formulas()) = delete;
  Compensator(const Table&& table, const MachineLimits<Scalar>& limits, const Formulas& = Formulas()) = delete;
  Compensator(const Table& table, TrustTableBounds, const Formulas& formulas = Formulas())
      : Compensator(table, limits_from_bounds(table.bounds), formulas) {}
  Compensator(const Table& table, const MachineLimits<Scalar>& limits, const Formulas& formulas = Formulas())
      : table_(&table), status_(validate_table(table, limits)), formulas_(formulas) {
    if (status_ != CompensationStatus::Ok) return;
    if (!model_.load(table.machine)) {
      status_ = CompensationStatus::TableValues;
      return;
    }
    effects_ = to_core(table.effects);
#if !KINCAL_CORE_USER_EFFECT
    // User numbers without the code to use them: refuse rather than drop
    // part of the model (effects.hpp, KINCAL_CORE_USER_EFFECT).
    if (!Formulas::present && !effects_.user.isZero()) {  // (the user slot holds the formulas' numbers)
      status_ = CompensationStatus::TableValues;
      return;
    }
#endif
    for (int i = 0; i < 6; ++i) {
      max_correction_(i) = table.bounds.max_correction[i];
      min_joint_(i) = table.bounds.min_joint[i];
      max_joint_(i) = table.bounds.max_joint[i];
    }
    joint_effects_ = effects_.joint_effects_present() || Formulas::present;
    compliance_ = !effects_.compliance.isZero();
    thermal_ = effects_.thermal != Scalar(0);
  }

  // The user joint effect's function (core/effects.hpp UserJointError): the
  // table holds its identified numbers (effects.user), the firmware supplies
  // the code, once at start-up before the first point. Null removes it.
  void set_user_effect(UserJointError<Scalar> function) {
    effects_.user_error = function;
    joint_effects_ = effects_.joint_effects_present() || Formulas::present;
  }

  CompensationStatus status() const { return status_; }
  const Table& table() const { return *table_; }
  const EffectParameters<Scalar>& effects() const { return effects_; }

  // The compensated command at the machine's home pose (6-UPS: the
  // geometry's home; hybrid: the reference pose, the origin of {R} with the
  // tool aligned to it), for start().
  CompensationStatus home_command(Vec6<Scalar>& q) const {
    State scratch;
    NcPoint<Scalar> p;
    p.pose = home_pose();
    Vec6<Scalar> ideal, dir;
    return evaluate(scratch, p, q, ideal, dir);
  }

  Pose<Scalar> home_pose() const { return model_.home_pose(); }

  // The state at the start of a stream with the machine at joint command
  // `current` (held until the first accepted point, and the reference of the
  // first approach directions) and the given approach directions.
  State start(const Vec6<Scalar>& current, const Vec6<Scalar>& direction = Vec6<Scalar>::Ones()) const {
    State s;
    s.command = current;
    s.reference = current;
    s.direction = direction;
    return s;
  }

  // One NC point (see the file comment). `command` is always written: the new
  // command on Ok, state.command (held) otherwise.
  CompensationStatus compensate(State& state, const NcPoint<Scalar>& point, Vec6<Scalar>& command) const {
    Vec6<Scalar> q, ideal, dir;
#if KINCAL_HYBRID_STORED_CHAINS
    CompensatorWarmStart<Scalar>* warm = &state.hybrid_start;  // an IK's solution, whatever the later checks say
#else
    CompensatorWarmStart<Scalar>* warm = nullptr;
#endif
    const CompensationStatus st = evaluate(state, point, q, ideal, dir, warm);
    state.last = st;
    ++state.events[static_cast<int>(st)];
    if (st != CompensationStatus::Ok) {
      command = state.command;
      return st;
    }
    state.command = q;
    state.reference = ideal;
    state.direction = dir;
    command = q;
    return st;
  }

  CompensationStatus compensate(State& state, const Pose<Scalar>& pose, Vec6<Scalar>& command) const {
    NcPoint<Scalar> p;
    p.pose = pose;
    return compensate(state, p, command);
  }

  CompensationStatus compensate(State& state, const Pose<Scalar>& pose, Scalar temperature,
                                Vec6<Scalar>& command) const {
    NcPoint<Scalar> p;
    p.pose = pose;
    p.temperature = temperature;
    p.has_temperature = true;
    return compensate(state, p, command);
  }

 private:
  // The pipeline without touching the state; outputs written only on Ok.
  // `warm`: the stream's starts for the hybrid's exact IK (host), or null.
  CompensationStatus evaluate(const State& state, const NcPoint<Scalar>& point, Vec6<Scalar>& command,
                              Vec6<Scalar>& ideal_out, Vec6<Scalar>& direction_out,
                              CompensatorWarmStart<Scalar>* warm = nullptr) const {
    using CS = CompensationStatus;
    if (status_ != CS::Ok) return status_;
    if (!point.pose.finite() || (point.has_temperature && !is_finite(point.temperature)) ||
        !orthonormal(point.pose.R))
      return CS::InvalidInput;
    const Scalar temperature = point.has_temperature ? point.temperature : effects_.reference_temperature;
    EffectInputs<Scalar> inputs;
    inputs.load.setZero();
    Vec6<Scalar> nominal_q, ideal;
    FormulaVariables<Scalar, Formulas::reads_family> vars;
    if constexpr (Formulas::present) {
      vars.v[FormulaSlot::temp] = temperature;
      if constexpr (Formulas::reads_pose) vars.set_pose(point.pose);
      if constexpr (Formulas::reads_stream) {  // the time stamp and the named inputs
        if (!is_finite(point.time)) return CS::InvalidInput;
        vars.v[FormulaSlot::time] = point.time;
        const int n = formulas_.input_count();
        if (n > 0 && point.inputs == nullptr) return CS::InvalidInput;
        for (int i = 0; i < n; ++i) {
          if (!is_finite(point.inputs[i])) return CS::InvalidInput;
          vars.v[FormulaSlot::input + i] = point.inputs[i];
        }
      }
    }
    const CS st = geometry(point.pose, temperature, nominal_q, ideal, inputs.load, warm, vars);
    if (st != CS::Ok) return st;

    // Approach directions (backlash): explicit, or the sign of the change of
    // q* since the last accepted point, kept while a joint stands still.
    Vec6<Scalar> dir = state.direction;
    if (point.direction != nullptr) {
      dir = *point.direction;
      // An approach direction is −1 or +1; anything else (0, −5, 1e30) is a
      // corrupt input, not a direction to scale the backlash by.
      for (int i = 0; i < 6; ++i)
        if (!(dir(i) == Scalar(1) || dir(i) == Scalar(-1))) return CS::InvalidInput;
    } else {
      for (int i = 0; i < 6; ++i) {
        const Scalar d = ideal(i) - state.reference(i);
        const Scalar abs_q = ideal(i) < Scalar(0) ? -ideal(i) : ideal(i);
        if ((d < Scalar(0) ? -d : d) > StillTolerance<Scalar>::value * (Scalar(1) + abs_q))
          dir(i) = d > Scalar(0) ? Scalar(1) : Scalar(-1);
      }
    }
    inputs.direction = dir;

    Vec6<Scalar> q = ideal;
    if constexpr (Formulas::present) {
      // The formulas' Δq at each iterate of the fixed point, with the
      // built-in effects' (their numbers: the table's user slot).
      vars.set_directions(dir);
      const Status es = effect_correct_joints(effects_, ideal, inputs, q, [&](const Vec6<Scalar>& at, Vec6<Scalar>& dq) {
        vars.set_joints(at);
        formulas_.add_joint_error(effects_.user.data(), vars.v, dq.data());
      });
      if (es != Status::Ok) return to_compensation_status(es);
    } else if (joint_effects_) {
      const Status es = effect_correct_joints(effects_, ideal, inputs, q);
      if (es != Status::Ok) return to_compensation_status(es);
    }
    if (!all_finite(q)) return CS::InvalidInput;
    if (((q - nominal_q).cwiseAbs().array() > max_correction_.array()).any()) return CS::OversizedCorrection;
    if ((q.array() < min_joint_.array()).any() || (q.array() > max_joint_.array()).any()) return CS::OutOfLimits;
    command = q;
    ideal_out = ideal;
    direction_out = dir;
    return CS::Ok;
  }

  // Steps 2–4: q_nom, the static load (if compliance is present) and q*. The
  // work before the IK is a separate, non-inlined call so that its frames,
  // wrenches and Jacobians are off the stack when the IK runs: the
  // controller's worst-case stack is the deeper of the two, not their sum.
  // `vars`: the formulas' variables (formula effects only): the static
  // loads under the payload are set here; a pose-kind formula's twist,
  // evaluated at the nominal joints, is taken off the pose before the
  // thermal pre-scaling (the machine's tool lands that twist away from where
  // its kinematics put it; formula_pose_precorrect).
  CompensationStatus geometry(const Pose<Scalar>& pose, Scalar temperature, Vec6<Scalar>& nominal_q,
                              Vec6<Scalar>& ideal, Vec6<Scalar>& load, CompensatorWarmStart<Scalar>* warm,
                              [[maybe_unused]] FormulaVariables<Scalar, Formulas::reads_family>& vars) const {
    Pose<Scalar> target;
    if constexpr (Formulas::present) {
      // Only what the machine's formulas read is computed (the policy's
      // compile-time flags: a generated policy knows; the host's says all).
      Vec6<Scalar> payload_load = Vec6<Scalar>::Zero();
      Scalar* family_values = nullptr;
      if constexpr (Formulas::reads_family) family_values = vars.v + FormulaSlot::family_joint;
      const CompensationStatus st =
          prepare(pose, temperature, nominal_q, load, target, &payload_load, family_values);
      if (st != CompensationStatus::Ok) return st;
      if constexpr (Formulas::reads_load) vars.set_loads(payload_load);
      if constexpr (Formulas::pose_twist) {
        if (formulas_.has_pose()) {
          vars.set_joints(nominal_q);
          target = formula_pose_precorrect(pose, [&](const Pose<Scalar>& at, Vec6<Scalar>& twist) {
            vars.set_pose(at);
            twist.setZero();
            formulas_.add_pose_twist(effects_.user.data(), vars.v, twist.data());
          });
          vars.set_pose(pose);
          if (!target.finite()) return CompensationStatus::InvalidInput;
          if (thermal_) target = thermal_precorrect(effects_, target, temperature);
        }
      }
    } else {
      const CompensationStatus st = prepare(pose, temperature, nominal_q, load, target);
      if (st != CompensationStatus::Ok) return st;
    }
    return solve(target, ideal, warm);
  }

  // The IK of the pose handed on by prepare(), non-inlined for the same
  // reason: its locals are not on the stack while prepare() runs. The
  // hybrid's two IKs are separate calls for the same reason: the exact IK's
  // chains and the closed form's frames are never on the stack together.
  KINCAL_NOINLINE CompensationStatus solve(const Pose<Scalar>& target, Vec6<Scalar>& ideal,
                                           [[maybe_unused]] CompensatorWarmStart<Scalar>* warm) const {
    // (hybrid: the identified machine's exact IK, issue #31; with no
    // structural error, seed 000 Fig. 4's ideal IK with ξ̂ in closed form)
    if (model_.exact()) return to_compensation_status(model_.solve_exact(target, ideal, warm));
    return solve_closed_form(target, ideal);
  }

  // The closed-form IK (6-UPS: the calibrated geometry's, seed 001; hybrid:
  // the nominal one with ξ̂, seed 000 Fig. 4).
  KINCAL_NOINLINE_FLATTEN CompensationStatus solve_closed_form(const Pose<Scalar>& target, Vec6<Scalar>& ideal) const {
    return to_compensation_status(model_.solve_closed_form(target, ideal));
  }

  // At the nominal configuration of `pose`: q_nom, the singularity test, the
  // static load; then the pose handed to the IK (thermal pre-scaling).
  // `payload_load` (formula effects that read `load`, and then not null):
  // the static joint loads under the formulas' payload (its weight at its
  // centre of mass; the hybrid's at the tool point). With a pose-kind formula, its twist comes
  // before the thermal pre-scaling, which geometry() then applies.
  KINCAL_NOINLINE CompensationStatus prepare(const Pose<Scalar>& pose, Scalar temperature, Vec6<Scalar>& nominal_q,
                                             Vec6<Scalar>& load, Pose<Scalar>& target,
                                             Vec6<Scalar>* payload_load = nullptr,
                                             Scalar* family_values = nullptr) const {
    const bool thermal_here = thermal_ && !(Formulas::pose_twist && formulas_.has_pose());
    Scalar payload_weight = Scalar(0);
    Vec3<Scalar> payload_com = Vec3<Scalar>::Zero();
    if constexpr (Formulas::reads_load) payload_weight = formulas_.payload_weight(), payload_com = formulas_.payload_com();
    const Status s = model_.template nominal_configuration<Formulas::reads_load>(
        pose, nominal_q, compliance_, effects_.load_direction, load, payload_weight, payload_com, payload_load,
        family_values);
    if (s != Status::Ok) return to_compensation_status(s);
    target = thermal_here ? thermal_precorrect(effects_, pose, temperature) : pose;
    return CompensationStatus::Ok;
  }

  const Table* table_;
  CompensationStatus status_;
  Formulas formulas_;
  compensation_detail::Model<Machine> model_;
  EffectParameters<Scalar> effects_;
  Vec6<Scalar> max_correction_ = Vec6<Scalar>::Zero();
  Vec6<Scalar> min_joint_ = Vec6<Scalar>::Zero();
  Vec6<Scalar> max_joint_ = Vec6<Scalar>::Zero();
  bool joint_effects_ = false, compliance_ = false, thermal_ = false;
};

template <class S> using StewartCompensator = Compensator<StewartMachine<S>>;
template <class S> using HybridCompensator = Compensator<HybridMachine<S>>;

// ---- building tables on the controller (fallback) and on the host ------------

// Default bound of the correction per joint: prismatic joints 5 mm, revolute
// joints 0.02 rad (~1.1°) — a few times the largest source error a calibrated
// machine of this size is expected to have (seed 000 Table 3, seed 001 Table
// 3), so a wrong model or input stands out. The host generator may choose others.
template <class Scalar> TableBounds<Scalar> default_bounds(const StewartGeometry<Scalar>& g) {
  TableBounds<Scalar> b{};
  for (int i = 0; i < 6; ++i) {
    b.max_correction[i] = Scalar(5);
    b.min_joint[i] = g.min_length(i);
    b.max_joint[i] = g.max_length(i);
  }
  return b;
}
template <class Scalar> TableBounds<Scalar> default_bounds(const HybridGeometry<Scalar>& g) {
  TableBounds<Scalar> b{};
  for (int i = 0; i < 6; ++i) {
    b.max_correction[i] = i < 3 ? Scalar(5) : Scalar(0.02);
    b.min_joint[i] = g.min_joint(i);
    b.max_joint[i] = g.max_joint(i);
  }
  return b;
}

// The nominal model as a (sealed) table: the firmware's fallback when its
// calibration table fails validate_table. Built in the return slot (NRVO) and
// sealed in place; still ~1–2 KiB of geometry temporaries in double, so a
// controller builds it once at start-up into static storage. `effects` carries the machine data
// (screw lead, weight direction, …) with every effect value zero by default.
template <class Scalar>
StewartCalibrationTable<Scalar> nominal_table(const StewartGeometry<Scalar>& g,
                                              const EffectParameters<Scalar>& effects = EffectParameters<Scalar>()) {
  StewartCalibrationTable<Scalar> t{};
  t.machine.nominal = to_table(g);
  t.machine.calibrated = to_table(g);
  t.effects = to_table(effects);
  t.bounds = default_bounds(g);
  seal(t);
  return t;
}

template <class Scalar>
HybridCalibrationTable<Scalar> nominal_table(const HybridGeometry<Scalar>& g, Scalar up_split = Scalar(345),
                                             const EffectParameters<Scalar>& effects = EffectParameters<Scalar>()) {
  HybridCalibrationTable<Scalar> t{};
  t.machine.nominal = to_table(g);
  t.machine.up_split = up_split;
  t.effects = to_table(effects);
  t.bounds = default_bounds(g);
  seal(t);
  return t;
}

// The nominal table of the machine a calibrated table describes (its
// nominal geometry, the machine data of `effects`): the firmware's fallback,
// as `kincal table` writes it beside the calibration.
template <class S>
StewartCalibrationTable<S> nominal_table_of(const StewartMachine<S>& m, const EffectParameters<S>& effects) {
  return nominal_table(to_core(m.nominal), effects);
}
template <class S>
HybridCalibrationTable<S> nominal_table_of(const HybridMachine<S>& m, const EffectParameters<S>& effects) {
  return nominal_table(to_core(m.nominal), m.up_split, effects);
}

}  // namespace kincal
