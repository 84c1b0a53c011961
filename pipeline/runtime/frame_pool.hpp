#pragma once
// The frame slots of the real-time pipeline, allocated once at start. A slot travels through the stage
// queues as a pointer; whichever thread holds the pointer owns the slot exclusively until it passes the
// pointer on (a queue push is the hand-over and publishes the slot's contents to the next thread).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

#include "measurement/measurer.hpp"

namespace rutd {

struct FrameSlot {
  FrameWork work;
  // CLOCK_MONOTONIC, ns. t0_ns is where latency and age are measured from: the capture time when the
  // source stamps CLOCK_MONOTONIC, otherwise the moment acquisition received the pair.
  std::int64_t t0_ns = 0;
  std::int64_t acquired_ns = 0;
};

// Fixed array of slots; never grows, so slot addresses stay valid for the pool's life. Not thread-safe
// by itself: ownership of each slot follows the pointer (see above).
class FramePool {
 public:
  // Throws std::invalid_argument for zero slots.
  explicit FramePool(std::size_t slots) : size_(slots) {
    if (slots == 0) throw std::invalid_argument("frame pool: slots must be > 0");
    slots_ = std::make_unique<FrameSlot[]>(slots);
  }
  FramePool(const FramePool&) = delete;
  FramePool& operator=(const FramePool&) = delete;

  std::size_t size() const noexcept { return size_; }
  FrameSlot& operator[](std::size_t i) noexcept { return slots_[i]; }
  const FrameSlot& operator[](std::size_t i) const noexcept { return slots_[i]; }

 private:
  std::size_t size_;
  std::unique_ptr<FrameSlot[]> slots_;
};

}  // namespace rutd
