// The boot test's stall switch (daemon/stalling_stages.hpp): the slots' priming, run by the thread that
// starts the pipeline (the one that built the switch), never counts; on the pipeline's own match thread
// the first N pairs pass and the next one stalls until the process is asked to stop (SIGTERM). Armed
// after start() instead, a pair slipped through on a loaded machine and the unit under systemd became
// ready where it had to stay activating.
#include <atomic>
#include <chrono>
#include <csignal>
#include <thread>

#include <gtest/gtest.h>

#include "daemon/stalling_stages.hpp"
#include "daemon/stop_signal.hpp"

namespace rutd {
namespace {

class CountingStages final : public PipelineStages {
 public:
  bool rectify(FrameWork&) override { return true; }
  void match(FrameWork&) override { ++matched; }
  void extract(FrameWork&) override {}
  std::atomic<int> matched{0};
};

TEST(StallingStages, PrimingDoesNotCountAndThePairAfterTheNthStallsUntilStop) {
  install_stop_handlers();
  CountingStages inner;
  StallingStages stalling(inner, 2);
  FrameWork work;
  // Priming, on the thread that built it: as many calls as the pairs allowed, so that were they counted,
  // the match thread's first pair would stall (and not this thread).
  for (int i = 0; i < 2; ++i) stalling.match(work);
  EXPECT_EQ(inner.matched.load(), 2);

  std::atomic<int> returned{0};
  std::jthread match_thread([&] {
    FrameWork w;
    for (int i = 0; i < 3; ++i) {
      stalling.match(w);
      ++returned;
    }
  });
  // Whatever is asserted below, the stalled call is released before the thread is joined.
  struct ReleaseAtExit {
    ~ReleaseAtExit() { std::raise(SIGTERM); }
  } release;
  // The first two pairs pass at once; the third must still be held well after them.
  for (int i = 0; i < 500 && returned.load() < 2; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_EQ(returned.load(), 2);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(returned.load(), 2) << "the pair after the 2nd was not held";
  EXPECT_EQ(inner.matched.load(), 4);

  std::raise(SIGTERM);  // the stop request releases the stalled call, as `systemctl stop` does
  match_thread.join();
  EXPECT_EQ(returned.load(), 3);
  EXPECT_EQ(inner.matched.load(), 5);
}

}  // namespace
}  // namespace rutd
