#pragma once
// Distance along the track from the vehicle's speed signal (core/track.hpp: SpeedSample in,
// VehicleMotion out). Pure: the caller feeds samples in the order received and asks for the motion at a
// frame's capture time; the same samples give the same motions live and in replay.
//
// Integration: the signed position advances by the trapezoid rule between consecutive valid samples at
// most max_age apart; a query between samples gets the position at the last sample (no extrapolation,
// so the distance never decreases; it lags by at most one sample period) and that sample's speed, for at
// most max_age. Nothing is integrated across a gap (a sample not Ok, or valid samples further apart
// than max_age): the position holds there, counted as a gap, so the distance is never guessed; the
// frames of the gap get no distance (NaN) and their segments are Unknown.
//
// New ground: distance_m is the largest signed position reached so far (metres). It holds at rest and
// while reversing, and again while driving forward over the stretch reversed over, because the camera
// behind the tyre sees the same ground again; it advances once the vehicle passes its furthest point.
#include <cstdint>

#include "core/track.hpp"

namespace rutd {

struct OdometerConfig {
  std::int64_t max_age_ns = 500'000'000;  // speed older than this is Stale (trafficability.speed.max_age_ms)
};

struct OdometerStats {
  std::uint64_t samples = 0;       // fed
  std::uint64_t out_of_order = 0;  // older than the previous sample: ignored
  std::uint64_t gaps = 0;          // gaps not integrated across (see above)
  double reversed_m = 0.0;         // distance driven backwards, m
};

class Odometer {  // not thread-safe: one thread feeds and asks
 public:
  explicit Odometer(OdometerConfig config = {});
  void add(const SpeedSample& sample) noexcept;
  // The motion at t_ns, from the samples fed so far (the caller feeds those received up to t_ns).
  VehicleMotion motion_at(std::int64_t t_ns) const noexcept;
  const OdometerStats& stats() const noexcept { return stats_; }

 private:
  OdometerConfig config_;
  OdometerStats stats_;
  bool any_ = false;      // a sample has been fed
  bool have_ok_ = false;  // the last sample was Ok (integration may continue from it)
  SpeedState last_state_ = SpeedState::NoSource;
  std::int64_t last_t_ns_ = 0;
  double last_speed_mm_s_ = 0.0;
  double position_mm_ = 0.0;      // signed, at last_t_ns_
  double max_position_mm_ = 0.0;  // new ground
};

}  // namespace rutd
