// What trafficability adds to each published frame on the publish thread: two CCVS frames decoded (50 Hz
// speed at 30 fps is under two a frame; the receiver thread decodes them, counted here all the same),
// fed to the odometer, the frame's motion asked for, the measurement placed on the track (a segment
// closing every 15 frames: 1 m at 2 m/s), with damage rules and a soil table configured. Compare with
// the strip path's per-frame cost (`rutd bench`, bench_disparity's BM_Engine and BM_Dic on the same
// machine): the budget is 2 % of it.
//
// BM_SpeedReceiverUnderForeignTraffic: the receiver thread's CPU while a bus carries 2,000 foreign frames a
// second beside 50 speed frames a second, paced in real time for 2 s into the receiver's socket. The socket
// is a socketpair, which has no kernel filters, so every foreign frame is read and decoded: the worst case
// (on SocketCAN the kernel filters drop them before this process sees them, tests/can's flood test). The
// receiver's CPU is the process's minus the sender's and the consumer's (each thread measures its own);
// `speed_lost` must be 0.
#include <sys/resource.h>
#include <sys/socket.h>

#include <atomic>
#include <chrono>
#include <ctime>
#include <limits>
#include <thread>

#include <benchmark/benchmark.h>

#include "can/socketcan_bus.hpp"
#include "can/vehicle_speed.hpp"
#include "can/vehicle_speed_receiver.hpp"
#include "trafficability/odometer.hpp"
#include "trafficability/segment_tracker.hpp"

namespace {

void BM_TrafficabilityPerFrame(benchmark::State& state) {
  rutd::SegmentConfig c;
  c.soil.table = {{0, 900}, {50, 500}, {150, 200}};
  c.soil.source = "bench";
  c.soil.limit_one_pass = 300;
  c.damage = {{"a", 100, 1, 1}, {"b", 200, 1, 1}, {"c", 200, 4, 0.25}};
  rutd::SegmentTracker tracker(c);
  rutd::Odometer odometer;
  rutd::VehicleSpeedDecoder decoder({});
  rutd::RutMeasurement m;
  m.status = rutd::RutStatus::Ok;
  m.depth_uncertainty_mm = 0.3;
  std::int64_t t = 0;
  std::uint64_t closed = 0;
  for (auto _ : state) {
    for (int i = 0; i < 2; ++i) {
      t += 16'666'667;
      if (const auto s = decoder.on_frame(rutd::encode_ccvs1(7.2, 0), t)) odometer.add(*s);
    }
    m.depth_mm = 50 + static_cast<double>(t % 7'000'000) * 1e-5;
    closed += tracker.add(t, m, odometer.motion_at(t));
    benchmark::DoNotOptimize(closed);
  }
  state.counters["segments"] = static_cast<double>(closed);
}
BENCHMARK(BM_TrafficabilityPerFrame);

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

double process_cpu_s() {
  rusage r{};
  getrusage(RUSAGE_SELF, &r);
  auto s = [](const timeval& t) { return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) * 1e-6; };
  return s(r.ru_utime) + s(r.ru_stime);
}

void BM_SpeedReceiverUnderForeignTraffic(benchmark::State& state) {
  const int foreign_per_s = static_cast<int>(state.range(0));
  constexpr int kSpeedPerS = 50;
  constexpr double kSeconds = 2.0;
  for (auto _ : state) {
    int fds[2];
    if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds) != 0) {
      state.SkipWithError("socketpair failed");
      return;
    }
    auto receiver = rutd::VehicleSpeedReceiver::adopt(fds[0], "bench0", {});
    std::atomic<bool> sending{true};
    std::atomic<std::uint64_t> consumed{0};
    double consumer_cpu = 0;
    // The publish thread's side: samples pulled at 30 Hz, as the daemon does per frame.
    std::thread consumer([&] {
      const double c0 = thread_cpu_s();
      rutd::SpeedSample s;
      while (sending.load()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(33));
        while (receiver->next(std::numeric_limits<std::int64_t>::max(), s)) consumed.fetch_add(1);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      while (receiver->next(std::numeric_limits<std::int64_t>::max(), s)) consumed.fetch_add(1);
      consumer_cpu = thread_cpu_s() - c0;
    });
    const double p0 = process_cpu_s(), s0 = thread_cpu_s();
    const int per_s = foreign_per_s + kSpeedPerS;
    const int total = static_cast<int>(per_s * kSeconds);
    const int speed_every = per_s / kSpeedPerS;
    std::uint64_t speed_sent = 0, foreign_sent = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < total; ++i) {
      std::this_thread::sleep_until(t0 + std::chrono::nanoseconds(static_cast<std::int64_t>(i * 1e9 / per_s)));
      rutd::CanFrame f;
      if (i % speed_every == 0) {
        f = rutd::encode_ccvs1(7.2, 0);
        ++speed_sent;
      } else {
        // Another parameter group (EEC1-like, PGN 0xF004) with changing data.
        f = rutd::CanFrame{
            0x0CF00400U, true, 8, {0xFF, 0x7D, static_cast<std::uint8_t>(i), 0x20, 0x1C, 0xFF, 0xFF, 0xF0}};
        ++foreign_sent;
      }
      const struct can_frame k = rutd::to_kernel_frame(f);
      if (::send(fds[1], &k, sizeof k, MSG_NOSIGNAL) != static_cast<ssize_t>(sizeof k)) break;
    }
    const double sender_cpu = thread_cpu_s() - s0;
    sending.store(false);
    consumer.join();
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const rutd::VehicleSpeedReceiverStats st = receiver->stats();
    const double receiver_cpu = process_cpu_s() - p0 - sender_cpu - consumer_cpu;
    receiver.reset();
    ::close(fds[1]);
    state.counters["foreign_per_s"] = foreign_per_s;
    state.counters["frames_read"] = static_cast<double>(st.decoded.frames);
    state.counters["foreign_counted"] = static_cast<double>(st.decoded.other_id);
    state.counters["speed_lost"] = static_cast<double>(speed_sent) - static_cast<double>(consumed.load());
    state.counters["queue_full"] = static_cast<double>(st.queue_full);
    state.counters["receiver_cpu_pct"] = 100.0 * receiver_cpu / wall;
    state.counters["us_per_frame"] = 1e6 * receiver_cpu / static_cast<double>(speed_sent + foreign_sent);
  }
}
BENCHMARK(BM_SpeedReceiverUnderForeignTraffic)
    ->Arg(0)
    ->Arg(2000)
    ->Arg(8000)
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
