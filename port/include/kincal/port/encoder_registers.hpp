// Encoder-offset registers: the HAL interface (issue #5 item 4).
//
// The coarse calibration (seed 000 Eq. (15)) identifies the encoder offsets
// Δξ: the physical joint is the encoder's value plus Δξ. A drive corrects
// that in hardware with a zero-offset register per axis, so the controller
// writes Δξ there at start-up and must prove the write took: a register that
// silently holds another value moves the machine by the difference, which no
// kinematic model can see. Hence write, then read back and compare.
//
// Static polymorphism (modm's driver style): a backend derives from
// EncoderOffsetPort<Backend> and implements
//     PortStatus do_read(int channel, std::int32_t& counts);
//     PortStatus do_write(int channel, std::int32_t counts);
// and the facade adds the checks and the verified write. No virtual calls:
// the controller is a template over the backend, so the hot path inlines.
// Backends: port/emulator (host tests, failures on demand) and port/baremetal
// (a RAM block standing in for the drive registers under qemu).
#pragma once

#include <cmath>
#include <cstdint>

#include "kincal/core/scalar.hpp"
#include "kincal/port/port_status.hpp"

namespace kincal::port {

constexpr int kEncoderChannels = 6;

template <class Backend> class EncoderOffsetPort {
 public:
  static constexpr int channels() { return kEncoderChannels; }

  PortStatus read(int channel, std::int32_t& counts) {
    if (channel < 0 || channel >= kEncoderChannels) return PortStatus::InvalidChannel;
    return backend().do_read(channel, counts);
  }

  PortStatus write(int channel, std::int32_t counts) {
    if (channel < 0 || channel >= kEncoderChannels) return PortStatus::InvalidChannel;
    return backend().do_write(channel, counts);
  }

  // Write, read back, compare. `read_back` receives what the register holds
  // after the attempt (when it could be read), so a caller can report it.
  PortStatus write_verified(int channel, std::int32_t counts, std::int32_t& read_back) {
    const PortStatus w = write(channel, counts);
    if (w != PortStatus::Ok) return w;
    const PortStatus r = read(channel, read_back);
    if (r != PortStatus::Ok) return r;
    return read_back == counts ? PortStatus::Ok : PortStatus::ReadBackMismatch;
  }

 private:
  Backend& backend() { return static_cast<Backend&>(*this); }
};

// Register counts <-> joint units. One count is `resolution[i]` joint units
// (mm for a prismatic joint, rad for a revolute one). The defaults resolve
// 1 nm and 10 nrad, far below the calibration's noise, with an int32 range of
// ±2147 mm and ±21 rad. A literal type, so a firmware keeps it in flash.
template <class Scalar> struct EncoderOffsetScaling {
  Scalar resolution[kEncoderChannels] = {Scalar(1e-6), Scalar(1e-6), Scalar(1e-6),
                                         Scalar(1e-6), Scalar(1e-6), Scalar(1e-6)};

  // All prismatic (the 6-UPS legs).
  static constexpr EncoderOffsetScaling prismatic() { return EncoderOffsetScaling(); }
  // Three prismatic legs, three revolute wrist joints (the hybrid).
  static constexpr EncoderOffsetScaling hybrid_default() {
    EncoderOffsetScaling s;
    for (int i = 3; i < kEncoderChannels; ++i) s.resolution[i] = Scalar(1e-8);
    return s;
  }
  // A machine's joints as its type says (Machine::revolute): 1 nm per count
  // for a prismatic joint, 10 nrad for a revolute one.
  template <class Machine> static constexpr EncoderOffsetScaling of() {
    EncoderOffsetScaling s;
    for (int i = 0; i < kEncoderChannels; ++i) s.resolution[i] = Machine::revolute(i) ? Scalar(1e-8) : Scalar(1e-6);
    return s;
  }

  // Nearest count; OutOfRange if the value is not finite or does not fit.
  PortStatus to_counts(int channel, Scalar offset, std::int32_t& counts) const {
    const Scalar c = offset / resolution[channel];
    // 2^31 - 1 is exact in double; in float the bound rounds up to 2^31, so
    // compare strictly below it.
    constexpr Scalar kMax = Scalar(2147483647.0);
    if (!(std::fabs(c) < kMax)) return PortStatus::OutOfRange;  // also NaN
    counts = static_cast<std::int32_t>(std::lround(c));
    return PortStatus::Ok;
  }

  Scalar to_joint(int channel, std::int32_t counts) const { return Scalar(counts) * resolution[channel]; }
};

}  // namespace kincal::port
