// Emulated NC stream for host tests: two bounded queues of fixed capacity
// (no heap), a producer side (the interpolator) and a consumer side (the
// drives) that the test drives period by period, so that both ends can be
// made late on purpose:
//   producer late      -> the controller finds the input empty: Underrun
//   producer too fast  -> push() finds the input full: Overrun to the
//                         producer, which keeps the point and retries; the
//                         next point taken carries the count
//   drives not reading -> the controller's send() finds the output full:
//                         Overrun, the controller keeps the command
#pragma once

#include <cstddef>
#include <cstdint>

#include "kincal/port/nc_stream.hpp"
#include "kincal/port/ring_buffer.hpp"

namespace kincal::port::emulator {

template <class Scalar, std::size_t InputCapacity = 4, std::size_t OutputCapacity = 4>
class NcStream : public NcStreamPort<NcStream<Scalar, InputCapacity, OutputCapacity>, Scalar> {
 public:
  // --- producer side ---------------------------------------------------------
  // Ok, or Overrun: the queue is full, the point was not taken (keep it).
  PortStatus push(const NcInput<Scalar>& p) {
    if (input_.full()) {
      ++producer_overruns_;
      ++pending_overruns_;
      return PortStatus::Overrun;
    }
    NcInput<Scalar> q = p;
    q.producer_overruns = pending_overruns_;
    pending_overruns_ = 0;
    input_.push(q);
    ++pushed_;
    return PortStatus::Ok;
  }
  // The NC program has no more points: once the queue is drained the
  // controller gets EndOfStream instead of Underrun.
  void end() { ended_ = true; }

  // --- consumer side ---------------------------------------------------------
  bool pop(JointCommand<Scalar>& c) { return output_.pop(c); }
  std::size_t output_size() const { return output_.size(); }
  std::size_t input_size() const { return input_.size(); }

  // --- backend (called through NcStreamPort) -------------------------------
  PortStatus do_receive(NcInput<Scalar>& p) {
    if (input_.pop(p)) return PortStatus::Ok;
    if (ended_) return PortStatus::EndOfStream;
    ++underruns_;
    return PortStatus::Underrun;
  }
  PortStatus do_send(const JointCommand<Scalar>& c) {
    if (!output_.push(c)) {
      ++send_overruns_;
      return PortStatus::Overrun;
    }
    return PortStatus::Ok;
  }

  long pushed() const { return pushed_; }
  long producer_overruns() const { return producer_overruns_; }
  long underruns() const { return underruns_; }
  long send_overruns() const { return send_overruns_; }

 private:
  RingBuffer<NcInput<Scalar>, InputCapacity> input_;
  RingBuffer<JointCommand<Scalar>, OutputCapacity> output_;
  std::uint16_t pending_overruns_ = 0;
  bool ended_ = false;
  long pushed_ = 0, producer_overruns_ = 0, underruns_ = 0, send_overruns_ = 0;
};

}  // namespace kincal::port::emulator
