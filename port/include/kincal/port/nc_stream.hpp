// The NC stream: the HAL interface between the interpolator and the drives
// (issue #5 item 2).
//
//   in:  nominal poses, one per interpolation period, each with a sequence
//        number given by the producer and optionally the structure temperature
//        (the thermal effect's input, GUIDE "An effect is the unit of physics");
//   out: joint commands with the sequence number of the pose they answer and
//        the status the controller gave it.
//
// Sequence numbers are what makes "no point lost" checkable: the controller
// answers every point it takes exactly once, in order, and counts any gap in
// the numbers it receives (a point the producer lost before the port).
//
// Static polymorphism as for the registers: a backend derives from
// NcStreamPort<Backend, Scalar> and implements
//     PortStatus do_receive(NcInput<Scalar>& point);
//         Ok (point written), Underrun (nothing this period), EndOfStream,
//         Malformed (point written with its sequence number, pose not valid),
//         IoError
//     PortStatus do_send(const JointCommand<Scalar>& command);
//         Ok, Overrun (the consumer has not taken the previous commands:
//         nothing was queued, send it again next period), IoError
// Queues are bounded and fixed-size (no heap on the hot path); a full input
// queue is the producer's overrun, reported to it, and the point stays with it.
#pragma once

#include <cstdint>

#include "kincal/core/scalar.hpp"
#include "kincal/core/compensation_status.hpp"
#include "kincal/core/formula_effects.hpp"
#include "kincal/port/port_status.hpp"

namespace kincal::port {

template <class Scalar> struct NcInput {
  std::uint32_t sequence = 0;
  // Nominal pose (x, y, z, rx, ry, rz): mm and rad, R = Rz·Ry·Rx (GUIDE
  // "Measurement CSV"), in the frame the machine's IK takes.
  Vec6<Scalar> pose = Vec6<Scalar>::Zero();
  Scalar temperature = Scalar(20);  // °C, meaningful when has_temperature
  bool has_temperature = false;
  // For the machine's formula effects (core/formula_effects.hpp): the time
  // stamp, s (0 when the stream has none), and the named inputs in the
  // machine's input order (the generated header's kFormulaInputNames).
  Scalar time = Scalar(0);
  Scalar inputs[kFormulaInputs] = {};
  bool valid = true;  // false: the record was malformed; pose is not usable
  // How often the producer found the input queue full (and kept the point to
  // retry) since the previous point was taken: the controller counts these.
  std::uint16_t producer_overruns = 0;
};

// Per-command flags: why the output is what it is, beyond the status.
enum CommandFlag : std::uint8_t {
  kCommandHeld = 1u << 0,             // the safe hold output, not a new command
  kCommandNominalModel = 1u << 1,     // computed with the nominal model (table rejected)
  kCommandSequenceGap = 1u << 2,      // points before this one never arrived
  kCommandAfterInputOverrun = 1u << 3, // the producer met a full queue before this point
};

template <class Scalar> struct JointCommand {
  std::uint32_t sequence = 0;           // of the NC point this answers
  Vec6<Scalar> q = Vec6<Scalar>::Zero();  // joint command, drive frame (see controller.hpp)
  CompensationStatus status = CompensationStatus::Ok;  // what the compensation made of this point
  // Ok, or the port failure that kept the controller from compensating at all
  // (a register fault at start-up): then `status` is not meaningful and the
  // command is the held one.
  PortStatus port = PortStatus::Ok;
  std::uint8_t flags = 0;  // CommandFlag bits
};

// The one status text of a command (the CSV "status" column): the port
// failure if there was one, else the compensation status.
template <class Scalar> constexpr const char* status_text(const JointCommand<Scalar>& c) {
  return c.port != PortStatus::Ok ? to_string(c.port) : to_string(c.status);
}

template <class Backend, class Scalar> class NcStreamPort {
 public:
  PortStatus receive(NcInput<Scalar>& point) { return backend().do_receive(point); }
  PortStatus send(const JointCommand<Scalar>& command) { return backend().do_send(command); }

 private:
  Backend& backend() { return static_cast<Backend&>(*this); }
};

}  // namespace kincal::port
