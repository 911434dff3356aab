// The controller loop, generic over the port's backends (issue #5 items 2–4).
//
//   Controller<Machine, Registers, Stream>
//     Machine    StewartMachine<S> or HybridMachine<S> (core/calibration_table.hpp):
//                one machine family per image, so nothing of the other is linked
//     Registers  an EncoderOffsetPort backend (encoder_registers.hpp)
//     Stream     an NcStreamPort backend (nc_stream.hpp)
//     Formulas   the machine's formula effects (core/formula_effects.hpp):
//                the generated header's Formulas<Scalar>, called directly;
//                none by default. The stream then carries each point's
//                time and named inputs (NcInput::time, ::inputs).
//
// Start-up (constructor + start()):
//   1. the calibration table is checked (validate_table against the machine
//      limits compiled in apart from it, core/machine_limits.hpp: version,
//      family, CRC, values, bounds and limits). If it fails, the controller falls back to the
//      nominal table (the machine's nominal model, generated next to it) and
//      says so: StartReport::table holds the failure, every command carries
//      kCommandNominalModel. If the nominal table fails too, the compensator
//      refuses every point with the table's status and holds its output.
//   2. the coarse calibration's encoder offsets (hybrid: ξ̂ of seed 000 Eq.
//      (15); 6-UPS: the leg offsets dl_i of seed 001 Table 3) are written to
//      the encoder-offset registers in counts and verified by read-back, each
//      with a bounded number of attempts. If a channel cannot be verified the
//      drives' zero is not the one the model assumes, so the controller
//      refuses motion: every point is answered with the held output and the
//      register failure as its port status (counted once per channel at
//      start-up, and per point as a held command).
//   3. the held output — what every refused point is answered with until a
//      point is accepted — is verified: the configured initial command (where
//      the machine stands at power-up) or else the compensated command at the
//      home pose, finite and inside the machine limits. Without such a
//      command there is nothing safe to hold (both tables rejected, the home
//      pose not compensable, a NaN initial command): the controller is not
//      ready (StartReport::hold), and step() sends nothing at all
//      (Cycle::NoSafeHold, counted) — never a zero or NaN command, which
//      would drive a joint outside its stroke.
//
// Per interpolation period, step():
//   - a command the drives refused last period (output overrun) is sent
//     again first, and no new point is taken until it is gone: back-pressure
//     instead of loss;
//   - otherwise one NC point is taken: none available is an underrun (the
//     drives hold their last command); its sequence number is checked against
//     the previous one: a gap is counted and flagged (points lost before the
//     port; missing_points saturates rather than wraps), a step back or a
//     duplicate is answered with the held output (PortStatus::SequenceError:
//     a producer that repeats or reorders points must not move the machine
//     back along the path) and the count goes on from it (a producer that
//     restarted its numbering holds one point, not the rest of the program);
//     producer overruns reported with it are counted;
//   - the point is compensated (core/compensation.hpp: status per failure,
//     held output, events counted in the compensator state) and its command
//     sent with the point's sequence number, status and flags. Every point
//     taken is answered exactly once, in order.
//
// Frames. The compensator computes the command q in the joint frame of the
// model (`kincal compensate`'s numbers: the physical joint is q + ξ̂). A
// drive with its offset register set to R counts positions as raw encoder
// + R, so it is sent q_drive = q + R (R in joint units, as read back), and
// servos its raw encoder to q_drive − R = q: the register makes the drive's
// own frame the calibrated one (its position feedback, its limits), and the
// motion is exactly the model's whatever R holds, as long as R is what the
// read-back said. This is why an unverified register stops the machine.
#pragma once

#include <cstdint>
#include <limits>
#include <new>

#include "kincal/core/calibration_table.hpp"
#include "kincal/core/compensation.hpp"
#include "kincal/port/encoder_registers.hpp"
#include "kincal/port/nc_stream.hpp"
#include "kincal/port/port_status.hpp"

namespace kincal::port {

template <class Scalar> struct ControllerConfig {
  EncoderOffsetScaling<Scalar> scaling;  // counts of the offset registers
  int register_attempts = 3;             // write + read-back tries per channel
  // Only read by the constructor (not kept):
  // Where the machine is at power-up (a real port reads it from the drives);
  // the held output until the first accepted point. Without it: the
  // compensated command at the machine's home pose.
  bool has_initial_command = false;
  Vec6<Scalar> initial_command = Vec6<Scalar>::Zero();
  // The user joint effect's code (core/effects.hpp UserJointError), if the
  // machine's model has one; its numbers come with the table.
  UserJointError<Scalar> user_effect = nullptr;
};

struct ControllerCounters {
  std::uint32_t points = 0;             // NC points answered (one command each)
  std::uint32_t compensated = 0;        // ... with a new command (status Ok, not held)
  std::uint32_t held = 0;               // ... with the held output
  std::uint32_t sequence_errors = 0;    // gaps or steps back in the sequence numbers
  std::uint32_t missing_points = 0;     // points missing in those gaps
  std::uint32_t producer_overruns = 0;  // input queue full (reported with the points)
  std::uint32_t underruns = 0;          // periods without an NC point
  std::uint32_t output_overruns = 0;    // sends refused by the drives (command kept, resent)
  std::uint32_t malformed = 0;          // records that could not be parsed
  std::uint32_t io_errors = 0;          // stream failures
  std::uint32_t register_failures = 0;  // channels whose offset could not be verified
  std::uint32_t register_retries = 0;   // failed attempts that a later attempt repaired
  std::uint32_t table_failures = 0;     // tables rejected at start-up
  std::uint32_t no_safe_hold = 0;       // periods refused: no verified command to hold, nothing sent
};

struct StartReport {
  CompensationStatus table = CompensationStatus::Ok;     // validate_table of the calibration table
  CompensationStatus fallback = CompensationStatus::Ok;  // of the nominal table, if it was needed
  bool nominal = false;                                  // running on the nominal table
  PortStatus registers = PortStatus::Ok;                 // Ok or the first register failure
  int register_channel = -1;                             // the channel that failed
  std::int32_t counts[kEncoderChannels] = {};            // what the registers hold (read back)
  bool hold = false;  // a verified held output exists (finite, inside the machine limits)
  bool ready() const {
    return hold && registers == PortStatus::Ok &&
           (table == CompensationStatus::Ok || fallback == CompensationStatus::Ok);
  }
};

// What one period did.
enum class Cycle : std::uint8_t {
  Command,        // a point was answered (or a refused command finally sent)
  Underrun,       // no point this period
  OutputBlocked,  // the drives refused the command: it is kept for the next period
  End,            // the NC program has ended and every command is out
  Error,          // the stream failed
  NoSafeHold,     // no verified command to hold (StartReport::hold): nothing taken, nothing sent
};

template <class Machine, class Registers, class Stream, class Formulas = NoFormulaEffects> class Controller {
 public:
  using Scalar = typename Machine::Scalar;
  using Table = CalibrationTable<Machine>;

  // `limits`: the machine limits compiled in apart from the tables
  // (core/machine_limits.hpp); like the tables, read in place, so they must
  // outlive the controller (a temporary is refused at compile time).
  Controller(Registers& registers, Stream& stream, const Table& calibration, const Table& nominal,
             const MachineLimits<Scalar>& limits, const ControllerConfig<Scalar>& config = ControllerConfig<Scalar>())
      : registers_(registers),
        stream_(stream),
        limits_(&limits),
        scaling_(config.scaling),
        register_attempts_(config.register_attempts),
        report_(check_tables(calibration, nominal, limits)),
        compensator_(report_.table == CompensationStatus::Ok ? calibration : nominal, limits, Formulas()) {
    counters_.table_failures =
        (report_.table != CompensationStatus::Ok ? 1u : 0u) + (report_.fallback != CompensationStatus::Ok ? 1u : 0u);
    initial_ = config.initial_command;
    has_initial_ = config.has_initial_command;
    compensator_.set_user_effect(config.user_effect);
  }
  Controller(Registers&, Stream&, const Table&, const Table&, const MachineLimits<Scalar>&&,
             const ControllerConfig<Scalar>& = ControllerConfig<Scalar>()) = delete;

  // Writes and verifies the encoder offsets (see the file comment) and sets
  // the held output to the machine's initial command.
  const StartReport& start() {
    reset_state();
    write_offsets();
    started_ = true;
    return report_;
  }

  // One interpolation period (see the file comment).
  Cycle step() {
    if (!started_) start();
    if (!report_.hold) {
      ++counters_.no_safe_hold;
      return Cycle::NoSafeHold;
    }
    if (has_pending_) {
      const PortStatus s = stream_.send(pending_);
      if (s == PortStatus::Overrun) {
        ++counters_.output_overruns;
        return Cycle::OutputBlocked;
      }
      if (s != PortStatus::Ok) {
        ++counters_.io_errors;
        return Cycle::Error;
      }
      has_pending_ = false;
      return Cycle::Command;
    }
    const PortStatus r = stream_.receive(input_);
    switch (r) {
      case PortStatus::Ok:
      case PortStatus::Malformed: break;
      case PortStatus::Underrun: ++counters_.underruns; return Cycle::Underrun;
      case PortStatus::EndOfStream: return Cycle::End;
      default: ++counters_.io_errors; return Cycle::Error;
    }
    // The point, the compensator's input and the command live in the
    // controller object, not on the stack: the stack under the compensation
    // is the firmware's scarcest resource (docs/benchmarks.md). The command
    // stays in pending_ if the drives refuse it.
    answer(r == PortStatus::Malformed);
    const PortStatus s = stream_.send(pending_);
    if (s == PortStatus::Overrun) {
      ++counters_.output_overruns;
      has_pending_ = true;
      return Cycle::OutputBlocked;
    }
    if (s != PortStatus::Ok) {
      ++counters_.io_errors;
      return Cycle::Error;
    }
    return Cycle::Command;
  }

  // Runs step() until the stream ends or fails, at most `max_periods` times.
  Cycle run(std::uint32_t max_periods = 0xFFFFFFFFu) {
    Cycle c = Cycle::Command;
    for (std::uint32_t k = 0; k < max_periods; ++k) {
      c = step();
      if (c == Cycle::End || c == Cycle::Error || c == Cycle::NoSafeHold) break;
    }
    return c;
  }

  const StartReport& report() const { return report_; }
  const ControllerCounters& counters() const { return counters_; }
  const CompensatorState<Scalar>& state() const { return state_; }
  const Compensator<Machine, Formulas>& compensator() const { return compensator_; }
  // The register offsets in joint units, as read back (the drive frame's shift).
  const Vec6<Scalar>& drive_offset() const { return drive_offset_; }

  // The coarse calibration's encoder offsets of a table, in joint units.
  static Vec6<Scalar> encoder_offsets(const Table& t) {
    Vec6<Scalar> o;
    for (int i = 0; i < 6; ++i) o(i) = t.machine.encoder_offset(i);
    return o;
  }

 private:
  static StartReport check_tables(const Table& calibration, const Table& nominal, const MachineLimits<Scalar>& limits) {
    StartReport r;
    r.table = validate_table(calibration, limits);
    if (r.table != CompensationStatus::Ok) {
      r.nominal = true;
      r.fallback = validate_table(nominal, limits);
    }
    return r;
  }

  void answer(bool malformed) {
    const NcInput<Scalar>& in = input_;
    JointCommand<Scalar>& cmd = pending_;
    cmd.sequence = in.sequence;
    cmd.status = CompensationStatus::Ok;
    cmd.port = PortStatus::Ok;
    cmd.flags = 0;
    ++counters_.points;
    // Sequence numbers: each point should follow the previous one. A gap
    // (points lost before the port) is flagged and the point executed; a
    // duplicate or a step back is held (see the file comment).
    bool replayed = false;
    if (have_last_sequence_ && in.sequence != last_sequence_ + 1u) {
      ++counters_.sequence_errors;
      cmd.flags |= kCommandSequenceGap;
      if (in.sequence > last_sequence_) {
        const std::uint32_t missing = in.sequence - last_sequence_ - 1u;
        const std::uint32_t room = 0xFFFFFFFFu - counters_.missing_points;
        counters_.missing_points += missing < room ? missing : room;  // saturates
      } else {
        replayed = true;
      }
    }
    have_last_sequence_ = true;
    last_sequence_ = in.sequence;  // resynchronised: a producer that restarted its count goes on from here
    if (in.producer_overruns > 0) {
      counters_.producer_overruns += in.producer_overruns;
      cmd.flags |= kCommandAfterInputOverrun;
    }
    if (report_.nominal) cmd.flags |= kCommandNominalModel;

    Vec6<Scalar>& q = cmd.q;
    if (report_.registers != PortStatus::Ok || replayed) {
      // No verified encoder zero, or a point that does not move forward
      // along the program: no motion (see the file comment).
      cmd.port = replayed ? PortStatus::SequenceError : report_.registers;
      q = state_.command;
      cmd.flags |= kCommandHeld;
    } else {
      kincal::NcPoint<Scalar>& p = point_;
      p.direction = nullptr;  // backlash directions from the command sequence
      p.temperature = in.temperature;
      p.has_temperature = in.has_temperature;
      if constexpr (Formulas::reads_stream) {
        p.time = in.time;
        p.inputs = in.inputs;  // the controller's own input_: valid for the call
      }
      if (malformed || !in.valid) {
        // An unparsable record is an invalid input like a NaN: the
        // compensator counts it and holds.
        ++counters_.malformed;
        p.pose.p.setConstant(std::numeric_limits<Scalar>::quiet_NaN());
      } else {
        to_pose(in.pose, p.pose);
      }
      cmd.status = compensator_.compensate(state_, p, q);
      if (cmd.status != CompensationStatus::Ok) cmd.flags |= kCommandHeld;
    }
    if ((cmd.flags & kCommandHeld) != 0)
      ++counters_.held;
    else
      ++counters_.compensated;
    q += drive_offset_;  // to the drive frame (see the file comment)
  }

  // The held output and the backlash reference at the start of a stream:
  // the configured initial command, or the compensated command at the home
  // pose (what `kincal compensate` starts from). The home pose is compensated
  // like any point, from a fresh state (as Compensator::home_command does),
  // through the members rather than a scratch state on the stack.
  KINCAL_PORT_NOINLINE void reset_state() {
    Vec6<Scalar>& q = pending_.q;  // scratch until the first point
    q = initial_;
    bool have = has_initial_;
    if (!has_initial_) {
      new (&state_) CompensatorState<Scalar>();
      home_point();
      have = compensator_.compensate(state_, point_, q) == CompensationStatus::Ok;
    }
    // Only a verified command may be held (see the file comment): finite and
    // inside the machine limits. Otherwise the state keeps a command that is
    // never sent (step() refuses every period).
    report_.hold = have && command_inside(q, *limits_);
    restart(q);
  }
  KINCAL_PORT_NOINLINE void home_point() {
    new (&point_) kincal::NcPoint<Scalar>();
    point_.pose = compensator_.home_pose();
  }
  KINCAL_PORT_NOINLINE void restart(const Vec6<Scalar>& initial) { state_ = compensator_.start(initial); }

  KINCAL_PORT_NOINLINE void write_offsets() {
    const Vec6<Scalar> offsets = encoder_offsets(compensator_.table());
    for (int ch = 0; ch < kEncoderChannels; ++ch) {
      PortStatus st = scaling_.to_counts(ch, offsets(ch), report_.counts[ch]);
      const std::int32_t want = report_.counts[ch];
      int failed_attempts = 0;
      if (st == PortStatus::Ok) {
        for (int attempt = 0; attempt < register_attempts_; ++attempt) {
          std::int32_t back = 0;
          st = registers_.write_verified(ch, want, back);
          if (st == PortStatus::Ok) break;
          ++failed_attempts;
        }
      }
      std::int32_t held = 0;
      if (registers_.read(ch, held) == PortStatus::Ok) {
        report_.counts[ch] = held;
        drive_offset_(ch) = scaling_.to_joint(ch, held);
      }
      if (st != PortStatus::Ok) {
        ++counters_.register_failures;
        if (report_.registers == PortStatus::Ok) {
          report_.registers = st;
          report_.register_channel = ch;
        }
      } else {
        counters_.register_retries += static_cast<std::uint32_t>(failed_attempts);
      }
    }
  }

  // Out of line: the rotation's temporaries get their own frame, which is
  // gone before the compensation runs (worst-case stack, docs/benchmarks.md).
  KINCAL_PORT_NOINLINE static void to_pose(const Vec6<Scalar>& xyz_rpy, Pose<Scalar>& pose) {
    pose = Pose<Scalar>::from_xyz_rpy(xyz_rpy);
  }

  Registers& registers_;
  Stream& stream_;
  const MachineLimits<Scalar>* limits_;
  EncoderOffsetScaling<Scalar> scaling_;
  int register_attempts_;
  StartReport report_;
  ControllerCounters counters_;
  Compensator<Machine, Formulas> compensator_;
  CompensatorState<Scalar> state_;
  Vec6<Scalar> drive_offset_ = Vec6<Scalar>::Zero();
  Vec6<Scalar> initial_ = Vec6<Scalar>::Zero();
  bool has_initial_ = false;
  JointCommand<Scalar> pending_;
  NcInput<Scalar> input_;
  kincal::NcPoint<Scalar> point_;
  std::uint32_t last_sequence_ = 0;
  bool have_last_sequence_ = false, has_pending_ = false, started_ = false;
};

}  // namespace kincal::port
