// Encoder-offset registers of the bare-metal backend.
//
// qemu's mps2-an500 has no encoder or drive hardware, so the registers are a
// RAM block with the layout a drive's register file would have, accessed
// only through volatile loads and stores (as memory-mapped registers are).
// On a real controller this class is replaced by the drive's register access
// (a fieldbus object, an FPGA register file) behind the same interface;
// docs/firmware.md "The HAL port". The block also emulates a drive's fault
// state for the firmware tests: bits set in `stuck_mask` read as in
// `stuck_value` whatever is written (a stuck line).
#pragma once

#include <cstdint>

#include "kincal/port/encoder_registers.hpp"

namespace kincal::port::baremetal {

struct EncoderRegisterBlock {
  std::int32_t offset[kEncoderChannels];
  std::uint32_t stuck_mask[kEncoderChannels];
  std::uint32_t stuck_value[kEncoderChannels];
};

class RamEncoderRegisters : public EncoderOffsetPort<RamEncoderRegisters> {
 public:
  explicit RamEncoderRegisters(volatile EncoderRegisterBlock& block) : block_(block) {}

  PortStatus do_read(int ch, std::int32_t& counts) {
    const std::uint32_t raw = static_cast<std::uint32_t>(block_.offset[ch]);
    const std::uint32_t mask = block_.stuck_mask[ch];
    counts = static_cast<std::int32_t>((raw & ~mask) | (block_.stuck_value[ch] & mask));
    return PortStatus::Ok;
  }

  PortStatus do_write(int ch, std::int32_t counts) {
    block_.offset[ch] = counts;
    return PortStatus::Ok;
  }

 private:
  volatile EncoderRegisterBlock& block_;
};

}  // namespace kincal::port::baremetal
