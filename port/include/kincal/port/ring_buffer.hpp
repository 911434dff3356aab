// A fixed-capacity FIFO for the port's queues: storage inside the object, no
// heap, no exceptions. A full queue refuses a push (the caller keeps the
// element and decides: retry, count an overrun); an empty one refuses a pop.
// Single-threaded (one interpolation loop); an interrupt-driven backend would
// wrap push/pop in its own critical section.
#pragma once

#include <cstddef>

namespace kincal::port {

template <class T, std::size_t Capacity> class RingBuffer {
  static_assert(Capacity > 0, "a queue needs room for at least one element");

 public:
  static constexpr std::size_t capacity() { return Capacity; }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  bool full() const { return size_ == Capacity; }

  bool push(const T& value) {
    if (full()) return false;
    items_[(head_ + size_) % Capacity] = value;
    ++size_;
    return true;
  }

  bool pop(T& out) {
    if (empty()) return false;
    out = items_[head_];
    head_ = (head_ + 1) % Capacity;
    --size_;
    return true;
  }

  // The oldest element; only valid when !empty().
  const T& front() const { return items_[head_]; }

  void clear() { head_ = size_ = 0; }

 private:
  T items_[Capacity]{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
};

}  // namespace kincal::port
