// SlotQueue (core/slot_queue.hpp): bounded, in order, every slot handed over exactly once between two
// threads through a ready/free loop, and a waiting consumer woken by a push or by wake().
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "core/slot_queue.hpp"

namespace rutd {
namespace {

using namespace std::chrono_literals;

TEST(SlotQueue, HoldsAtMostItsCapacityInOrder) {
  int slots[3] = {0, 1, 2};
  SlotQueue<int> q(2);
  EXPECT_EQ(q.capacity(), 2u);
  EXPECT_EQ(q.pop(), nullptr);
  EXPECT_TRUE(q.push(&slots[0]));
  EXPECT_TRUE(q.push(&slots[1]));
  EXPECT_FALSE(q.push(&slots[2]));  // full: refused, nothing changed
  EXPECT_EQ(q.pop(), &slots[0]);
  EXPECT_TRUE(q.push(&slots[2]));
  EXPECT_EQ(q.pop(), &slots[1]);
  EXPECT_EQ(q.pop(), &slots[2]);
  EXPECT_EQ(q.pop(), nullptr);
  EXPECT_THROW(SlotQueue<int>(0), std::invalid_argument);
}

// A producer fills slots of a pool of 4 with 0..N-1 and a consumer adds them up: every value arrives
// once, in order, and no more than the pool is ever in flight.
TEST(SlotQueue, ReadyFreeLoopHandsEverySlotOverOnce) {
  constexpr std::uint64_t kItems = 200000;
  std::vector<std::uint64_t> pool(4);
  SlotQueue<std::uint64_t> ready(pool.size()), free(pool.size());
  for (auto& slot : pool) ASSERT_TRUE(free.push(&slot));
  std::uint64_t sum = 0, received = 0;
  bool in_order = true;
  std::thread consumer([&] {
    while (received < kItems) {
      const std::uint64_t since = ready.mark();
      std::uint64_t* slot = ready.pop();
      if (slot == nullptr) {
        ready.wait(since, 10ms);
        continue;
      }
      in_order = in_order && *slot == received;
      sum += *slot;
      ++received;
      ASSERT_TRUE(free.push(slot));
    }
  });
  std::uint64_t waits = 0;
  for (std::uint64_t i = 0; i < kItems; ++i) {
    std::uint64_t* slot = nullptr;
    for (;;) {
      const std::uint64_t since = free.mark();
      if ((slot = free.pop()) != nullptr) break;
      ++waits;
      free.wait(since, 10ms);
    }
    *slot = i;
    ASSERT_TRUE(ready.push(slot));
  }
  consumer.join();
  EXPECT_EQ(received, kItems);
  EXPECT_TRUE(in_order);
  EXPECT_EQ(sum, kItems * (kItems - 1) / 2);
  std::printf("%llu items through 4 slots, the producer waited %llu times\n", static_cast<unsigned long long>(kItems),
              static_cast<unsigned long long>(waits));
}

TEST(SlotQueue, WaitReturnsOnAPushOrAWakeNotAtTheTimeout) {
  int slot = 7;
  SlotQueue<int> q(1);
  // A push before wait() (after mark()) is not missed: wait returns at once.
  std::uint64_t since = q.mark();
  ASSERT_TRUE(q.push(&slot));
  auto t0 = std::chrono::steady_clock::now();
  q.wait(since, 10s);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 5s);
  EXPECT_EQ(q.pop(), &slot);

  // A push from another thread while waiting, and a wake() without a slot.
  for (bool with_slot : {true, false}) {
    since = q.mark();
    std::thread other([&] {
      std::this_thread::sleep_for(50ms);
      if (with_slot) q.push(&slot);
      else q.wake();
    });
    t0 = std::chrono::steady_clock::now();
    q.wait(since, 10s);
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 5s) << (with_slot ? "push" : "wake");
    other.join();
    EXPECT_EQ(q.pop(), with_slot ? &slot : nullptr);
  }

  // Nothing: the wait ends at its timeout.
  since = q.mark();
  t0 = std::chrono::steady_clock::now();
  q.wait(since, 30ms);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 25ms);
}

// Two queues sharing one Wakeup: a consumer waiting on both is woken by a push to either.
TEST(SlotQueue, SharedWakeupWakesForEitherQueue) {
  int slot = 1;
  Wakeup shared;
  SlotQueue<int> a(1, &shared), b(1, &shared);
  const std::uint64_t since = shared.mark();
  std::thread other([&] {
    std::this_thread::sleep_for(50ms);
    b.push(&slot);
  });
  const auto t0 = std::chrono::steady_clock::now();
  a.wait(since, 10s);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 5s);
  other.join();
  EXPECT_EQ(a.pop(), nullptr);
  EXPECT_EQ(b.pop(), &slot);
}

}  // namespace
}  // namespace rutd
