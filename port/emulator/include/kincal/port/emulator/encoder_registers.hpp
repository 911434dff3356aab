// Emulated encoder-offset registers for host tests (Zephyr's gpio_emul idea:
// the same interface as the hardware, plus a back door to make it fail).
// Failure modes, per channel:
//   fail_writes(ch, n)   the next n writes return WriteFailed, register unchanged
//   fail_reads(ch, n)    the next n reads return ReadFailed
//   stick_bits(ch, m, v) bits in mask m always read as in v (a stuck line):
//                        a write of any other value reads back as a mismatch
//   lose_writes(ch, n)   the next n writes report Ok but are not stored (a
//                        write lost on the bus): only the read-back sees it
#pragma once

#include <cstdint>

#include "kincal/port/encoder_registers.hpp"

namespace kincal::port::emulator {

class EncoderRegisters : public EncoderOffsetPort<EncoderRegisters> {
 public:
  PortStatus do_read(int ch, std::int32_t& counts) {
    ++reads_;
    if (fail_reads_[ch] > 0) {
      --fail_reads_[ch];
      return PortStatus::ReadFailed;
    }
    counts = visible(ch);
    return PortStatus::Ok;
  }

  PortStatus do_write(int ch, std::int32_t counts) {
    ++writes_;
    if (fail_writes_[ch] > 0) {
      --fail_writes_[ch];
      return PortStatus::WriteFailed;
    }
    if (lose_writes_[ch] > 0) {
      --lose_writes_[ch];
      return PortStatus::Ok;
    }
    value_[ch] = counts;
    return PortStatus::Ok;
  }

  // --- the back door ---------------------------------------------------------
  void fail_writes(int ch, int n) { fail_writes_[ch] = n; }
  void fail_reads(int ch, int n) { fail_reads_[ch] = n; }
  void lose_writes(int ch, int n) { lose_writes_[ch] = n; }
  void stick_bits(int ch, std::uint32_t mask, std::uint32_t value) {
    stuck_mask_[ch] = mask;
    stuck_value_[ch] = value & mask;
  }
  // What the drive really applies (stuck bits included), bypassing faults.
  std::int32_t value(int ch) const { return visible(ch); }
  void set_value(int ch, std::int32_t v) { value_[ch] = v; }
  long reads() const { return reads_; }
  long writes() const { return writes_; }

 private:
  std::int32_t visible(int ch) const {
    const std::uint32_t raw = static_cast<std::uint32_t>(value_[ch]);
    return static_cast<std::int32_t>((raw & ~stuck_mask_[ch]) | stuck_value_[ch]);
  }

  std::int32_t value_[kEncoderChannels] = {};
  int fail_writes_[kEncoderChannels] = {};
  int fail_reads_[kEncoderChannels] = {};
  int lose_writes_[kEncoderChannels] = {};
  std::uint32_t stuck_mask_[kEncoderChannels] = {};
  std::uint32_t stuck_value_[kEncoderChannels] = {};
  long reads_ = 0, writes_ = 0;
};

}  // namespace kincal::port::emulator
