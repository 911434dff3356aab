// Status codes of the HAL port layer (encoder-offset registers, NC stream).
// One code per failure, like core's Status (Ruckig's Result): the controller
// loop turns each into a counted event, never into an exception or a silent
// retry. Kinematic failures keep core's kincal::Status; these are the
// failures of the hardware around the kinematics.
#pragma once

#include <cstdint>

// Keeps a function out of its callers, so its locals do not add to the frame
// of a caller that goes on to call deeper (the controller's stack budget).
#if defined(__GNUC__)
#define KINCAL_PORT_NOINLINE __attribute__((noinline))
#else
#define KINCAL_PORT_NOINLINE
#endif

namespace kincal::port {

enum class PortStatus : std::uint8_t {
  Ok = 0,
  InvalidChannel,    // register channel outside [0, channels)
  OutOfRange,        // an offset does not fit the register's count range
  WriteFailed,       // the register rejected the write (bus error, NACK, timeout)
  ReadFailed,        // the register could not be read
  ReadBackMismatch,  // written, but read back as another value (stuck bit, lost write)
  Underrun,          // no NC point available in this period (the interpolator is late)
  Overrun,           // a queue is full: the point / command was not taken (retry later)
  EndOfStream,       // the NC program has ended
  Malformed,         // an NC record could not be parsed (the point is still delivered, flagged)
  IoError,           // the stream's medium failed (file, bus)
  SequenceError,     // a duplicate point or a step back in the sequence: held, not executed
};

constexpr const char* to_string(PortStatus s) {
  switch (s) {
    case PortStatus::Ok: return "ok";
    case PortStatus::InvalidChannel: return "invalid channel";
    case PortStatus::OutOfRange: return "offset out of register range";
    case PortStatus::WriteFailed: return "register write failed";
    case PortStatus::ReadFailed: return "register read failed";
    case PortStatus::ReadBackMismatch: return "register read-back mismatch";
    case PortStatus::Underrun: return "stream underrun";
    case PortStatus::Overrun: return "stream overrun";
    case PortStatus::EndOfStream: return "end of stream";
    case PortStatus::Malformed: return "malformed record";
    case PortStatus::IoError: return "stream i/o error";
    case PortStatus::SequenceError: return "sequence step back or duplicate";
  }
  return "unknown";
}

}  // namespace kincal::port
