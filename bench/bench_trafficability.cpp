// What trafficability adds to each published frame on the publish thread: two CCVS frames decoded (50 Hz
// speed at 30 fps is under two a frame; the receiver thread decodes them, counted here all the same),
// fed to the odometer, the frame's motion asked for, the measurement placed on the track (a segment
// closing every 15 frames: 1 m at 2 m/s), with damage rules and a soil table configured. Compare with
// the strip path's per-frame cost (`rutd bench`, bench_disparity's BM_Engine and BM_Dic on the same
// machine): the budget is 2 % of it.
#include <benchmark/benchmark.h>

#include "can/vehicle_speed.hpp"
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

}  // namespace

BENCHMARK_MAIN();
