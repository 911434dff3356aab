// NC stream of the bare-metal backend: poses from a host CSV file, joint
// commands to a host CSV file, both through Arm semihosting (qemu's
// -semihosting-config target=native; semihosting.h). The format is
// port/include/kincal/port/csv_stream.hpp's.
//
// This stands in for the real NC link (an interpolator in shared memory, a
// fieldbus): the file is read when the controller asks for the next point,
// so the stream never underruns or overruns by itself; the host tests make
// both happen on the emulator backend instead.
//
// It also models the drive at the far end of the command link: a command
// is in the drive's frame (the encoder reading plus the drive's offset
// register, see kincal/port/controller.hpp), and the drive servos its raw
// encoder to command − offset. The file records that raw setpoint, which is
// the quantity `kincal compensate` computes, so the two can be compared
// number for number.
//
// Static RAM: 128 B read chunk, 192 B line (longer input lines are answered
// as malformed points), 512 B output buffer (one output line), two in-flight
// rows: about 1.1 KiB, no heap.
#pragma once

#include <cstddef>
#include <cstdint>

#include "kincal/port/csv_stream.hpp"
#include "kincal/port/encoder_registers.hpp"
#include "kincal/port/nc_stream.hpp"
#include "ram_encoder_registers.hpp"

extern "C" {
#include "semihosting.h"
}

namespace kincal::port::baremetal {

// `FormulaColumns`: the poses file's `time` and named-input columns are read
// (a machine with formula effects; PoseCsvReader).
template <class Scalar, bool FormulaColumns = false>
class SemihostNcStream : public NcStreamPort<SemihostNcStream<Scalar, FormulaColumns>, Scalar> {
 public:
  // `scaling` must outlive the stream (a constant in flash, typically).
  SemihostNcStream(RamEncoderRegisters& drive_registers, const EncoderOffsetScaling<Scalar>& scaling)
      : registers_(drive_registers), scaling_(scaling) {}

  // The named inputs of the machine's formula effects (required columns of
  // the poses file; PoseCsvReader::set_inputs). Before open().
  void set_inputs(const char* const* names, int count) {
    if constexpr (FormulaColumns) reader_.set_inputs(names, count);
    (void)names;
    (void)count;
  }

  // Opens both files; false if either cannot be opened (the output is
  // created or truncated) or the header cannot be written.
  bool open(const char* poses_path, const char* joints_path) {
    in_ = kincal_semihost_open(poses_path, KINCAL_SEMIHOST_READ);
    out_ = kincal_semihost_open(joints_path, KINCAL_SEMIHOST_WRITE);
    if (in_ < 0 || out_ < 0) return false;
    const char* h = JointCsvWriter::header();
    while (*h != '\0') out_buffer_[out_size_++] = *h++;
    return true;
  }

  // Flushes and closes both files; false if anything was lost.
  bool close() {
    bool ok = flush() && !io_error_;
    if (in_ >= 0 && kincal_semihost_close(in_) != 0) ok = false;
    if (out_ >= 0 && kincal_semihost_close(out_) != 0) ok = false;
    in_ = out_ = -1;
    return ok;
  }

  bool header_error() const { return header_error_; }
  std::uint32_t rows_read() const { return reader_.rows(); }
  std::uint32_t rows_written() const { return written_; }

  // --- backend ---------------------------------------------------------------
  // Not inlined into the controller's step(): the file and text handling has
  // its own stack frame, beside the compensation's instead of on top of it.
  KINCAL_PORT_NOINLINE PortStatus do_receive(NcInput<Scalar>& point) {
    if (io_error_) return PortStatus::IoError;
    for (;;) {
      if (ended_) return PortStatus::EndOfStream;
      std::size_t size = 0;
      bool overlong = false;
      if (!next_line(size, overlong)) {
        ended_ = true;
        if (!reader_.have_header()) header_error_ = true;
        continue;
      }
      CsvId id;
      if (overlong) {
        if (!reader_.have_header()) return fail_header();
        reader_.malformed_row(point, id);
      } else {
        const auto r = reader_.feed(line_, size, point, id);
        if (r == PoseCsvReader<Scalar, FormulaColumns>::LineResult::Skipped) continue;
        if (r == PoseCsvReader<Scalar, FormulaColumns>::LineResult::BadHeader) return fail_header();
      }
      remember(point, id);
      return point.valid ? PortStatus::Ok : PortStatus::Malformed;
    }
  }

  KINCAL_PORT_NOINLINE PortStatus do_send(const JointCommand<Scalar>& c) {
    if (io_error_) return PortStatus::IoError;
    // The row this command answers (in order; an unknown sequence number is
    // still written, without its id and pose).
    Pending row;
    row.point.sequence = c.sequence;
    if (pending_count_ > 0 && pending_[pending_head_].point.sequence == c.sequence) {
      row = pending_[pending_head_];
      pending_head_ = (pending_head_ + 1) % kPending;
      --pending_count_;
    }
    // Raw encoder setpoint: the drive subtracts the offset its register holds.
    Vec6<Scalar> raw = c.q;
    for (int k = 0; k < kEncoderChannels; ++k) {
      std::int32_t counts = 0;
      if (registers_.read(k, counts) == PortStatus::Ok) raw(k) -= scaling_.to_joint(k, counts);
    }
    if (kOutCapacity - out_size_ < kCsvLineCapacity && !flush()) return PortStatus::IoError;
    out_size_ += JointCsvWriter::format(out_buffer_ + out_size_, row.id, row.point, raw, status_text(c), c.flags);
    ++written_;
    return PortStatus::Ok;
  }

 private:
  static constexpr std::size_t kChunk = 128;
  static constexpr std::size_t kLine = 192;
  static constexpr std::size_t kOutCapacity = kCsvLineCapacity;  // the longest line; flushed before each
  static constexpr std::size_t kPending = 2;

  struct Pending {
    NcInput<Scalar> point;
    CsvId id;
  };

  PortStatus fail_header() {
    header_error_ = true;
    ended_ = true;
    return PortStatus::IoError;
  }

  void remember(const NcInput<Scalar>& point, const CsvId& id) {
    // Only the controller's in-flight point is pending; a full ring means
    // commands were never sent for old rows: drop the oldest's echo.
    if (pending_count_ == kPending) {
      pending_head_ = (pending_head_ + 1) % kPending;
      --pending_count_;
    }
    Pending& p = pending_[(pending_head_ + pending_count_) % kPending];
    p.point = point;
    p.id = id;
    ++pending_count_;
  }

  // Next line of the input into line_ (without '\n'); false at end of file
  // with nothing left. A line longer than the buffer is consumed whole and
  // reported as overlong.
  bool next_line(std::size_t& size, bool& overlong) {
    size = 0;
    overlong = false;
    bool any = false;
    for (;;) {
      if (chunk_pos_ == chunk_size_) {
        if (eof_) return any;
        chunk_size_ = kincal_semihost_read_file(in_, chunk_, kChunk);
        chunk_pos_ = 0;
        if (chunk_size_ == 0) {
          eof_ = true;
          return any;
        }
      }
      const char c = chunk_[chunk_pos_++];
      any = true;
      if (c == '\n') return true;
      if (size < kLine)
        line_[size++] = c;
      else
        overlong = true;
    }
  }

  bool flush() {
    if (out_size_ == 0) return true;
    const std::size_t n = kincal_semihost_write_file(out_, out_buffer_, out_size_);
    const bool ok = n == out_size_;
    out_size_ = 0;
    if (!ok) io_error_ = true;
    return ok;
  }

  RamEncoderRegisters& registers_;
  const EncoderOffsetScaling<Scalar>& scaling_;
  PoseCsvReader<Scalar, FormulaColumns> reader_;
  int in_ = -1, out_ = -1;
  char chunk_[kChunk];
  std::size_t chunk_size_ = 0, chunk_pos_ = 0;
  char line_[kLine];
  char out_buffer_[kOutCapacity];
  std::size_t out_size_ = 0;
  Pending pending_[kPending];
  std::size_t pending_head_ = 0, pending_count_ = 0;
  std::uint32_t written_ = 0;
  bool eof_ = false, ended_ = false, io_error_ = false, header_error_ = false;
};

}  // namespace kincal::port::baremetal
