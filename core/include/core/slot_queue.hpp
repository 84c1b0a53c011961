#pragma once
// Hand-over of preallocated slots between threads, without locks and without allocation after start:
// the real-time pipeline's stage queues, the frame recorder's pairs on their way to the disk and the
// plot sink's frames on their way to its plot thread all pass pointers to slots of a pool allocated at
// start through SlotQueues. The usual pattern is a loop of two: `ready` from a producer thread to a
// consumer thread and `free` back, each able to hold every slot, so a push never fails and the pool
// bounds what is in flight: a producer that finds `free` empty drops its item (or waits, its choice).
//
// Consumer side, a wait that cannot miss a push:
//   const std::uint64_t since = queue.mark();
//   Slot* slot = queue.pop();
//   if (slot == nullptr) queue.wait(since, timeout);  // returns at once if a push came after mark()
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <semaphore>
#include <stdexcept>

#include <boost/lockfree/spsc_queue.hpp>

namespace rutd {

// Wakes a thread that waits (bounded) for items from one or more queues. A permit is released only when
// the waiter announced itself, so the semaphore's count stays at most one or two however long the
// consumer stays busy (a permit per push would grow without bound when it never has to wait). No lost
// wake-up: every operation below is sequentially consistent, so either the waiter's check of `events_`
// sees the producer's increment, or the producer's check of `waiting_` sees the waiter's flag.
// notify(): any thread, several producers allowed; mark() and wait(): the one waiting thread.
class Wakeup {
 public:
  void notify() noexcept {
    events_.fetch_add(1);
    if (waiting_.load() && waiting_.exchange(false)) permits_.release();
  }
  // Before the waiter looks at its queues.
  std::uint64_t mark() const noexcept { return events_.load(); }
  // After its queues were empty: waits up to `timeout` unless notify() was called since mark() returned
  // `since`.
  void wait(std::uint64_t since, std::chrono::nanoseconds timeout) noexcept {
    waiting_.store(true);
    if (events_.load() == since) permits_.try_acquire_for(timeout);
    waiting_.store(false);
  }

 private:
  std::counting_semaphore<> permits_{0};
  std::atomic<std::uint64_t> events_{0};
  std::atomic<bool> waiting_{false};
};

// A bounded single-producer/single-consumer queue of slot pointers (Boost.Lockfree's spsc_queue), whose
// consumer can wait for the next push. Exactly one producer thread calls push(), exactly one consumer
// thread calls pop(), mark() and wait(); wake() is for any thread. A push publishes the slot's contents
// to the consumer (release/acquire): whoever holds the pointer owns the slot. The queue never owns or
// frees the slots.
template <typename Slot>
class SlotQueue {
 public:
  // capacity: the most slots queued at once, >= 1 (allocated here, once). shared: a Wakeup that the
  // consumer waits on for several queues at once (it must outlive the queue); null: the queue's own.
  explicit SlotQueue(std::size_t capacity, Wakeup* shared = nullptr)
      : queue_(checked(capacity)), capacity_(capacity), wakeup_(shared != nullptr ? shared : &own_) {}
  SlotQueue(const SlotQueue&) = delete;
  SlotQueue& operator=(const SlotQueue&) = delete;

  std::size_t capacity() const noexcept { return capacity_; }

  // Producer. false, changing nothing, when `capacity` slots are queued already; wakes the consumer.
  bool push(Slot* slot) noexcept {
    if (!queue_.push(slot)) return false;
    wakeup_->notify();
    return true;
  }
  // Consumer. The oldest queued slot, or nullptr when none is.
  Slot* pop() noexcept {
    Slot* slot = nullptr;
    return queue_.pop(slot) ? slot : nullptr;
  }
  // Consumer: see the file comment.
  std::uint64_t mark() const noexcept { return wakeup_->mark(); }
  void wait(std::uint64_t since, std::chrono::nanoseconds timeout) noexcept { wakeup_->wait(since, timeout); }
  // Any thread: wakes a waiting consumer without a slot (a stop request it should look at).
  void wake() noexcept { wakeup_->notify(); }

 private:
  static std::size_t checked(std::size_t capacity) {
    if (capacity == 0) throw std::invalid_argument("slot queue: capacity must be at least 1");
    return capacity;
  }

  boost::lockfree::spsc_queue<Slot*> queue_;
  std::size_t capacity_;
  Wakeup own_;
  Wakeup* wakeup_;
};

}  // namespace rutd
