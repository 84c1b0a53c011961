#pragma once
// Measurements placed on the travelled distance and gathered into segments of the track (core/track.hpp:
// Segment), each closed with its statistics, soil strength and advisory. Pure: the daemon feeds every
// published measurement with the frame's motion (trafficability/odometer.hpp) from the publish thread,
// and `rutd replay` does the same from a recording; equal inputs give equal segments.
//
// Position: with a positioning source, each segment carries the valid fix of the measurement placed nearest
// its middle ((k + 0.5) L), so a segment is located by its own ground, not by when it closed; a segment on
// which no measurement with a valid fix was placed has none (GeoFix::Mode::None).
//
// Placement: a measurement is placed at motion.distance_m when that is beyond the last placed one; at
// rest and while reversing (the distance holds) it adds nothing (counted as not placed), so a stop does
// not weigh a segment with thirty copies of one rut a second. A measurement without a valid motion
// (speed not Ok) cannot be placed: the segment open at that moment is marked untrusted (advisory
// Unknown). Segment k covers [k L, (k+1) L) of new ground; it closes when a measurement is placed beyond
// it (segments skipped over are reported with no frames, Unknown).
//
// Statistics over the Ok measurements (depth, width, area); P95 by linear interpolation between order
// statistics (numpy's default, Python's statistics.quantiles(method='inclusive')) over the first
// kMaxDepthsPerSegment of them. depth_uncertainty_mm is the mean of the measurements' uncertainties:
// their errors (the ground line's) are correlated along a metre, so averaging does not shrink them.
// Worst status: the least trustworthy in status_severity's order (core/rut_measurement.hpp).
//
// Advisory per segment, raw then with hysteresis:
//   raw UNKNOWN  when the speed was not trustworthy on it, fewer than min_trusted_frames were Ok or NoRut,
//                or the share of the other statuses (the scene not trustworthy) exceeds
//                max_untrusted_fraction; else the worst of
//   depth        P95 >= no_go_depth_mm: NO_GO; >= caution_depth_mm: CAUTION; else GO (NoRut only: GO)
//   strength     (with a soil table, from the mean depth) s + k u < one-pass limit: NO_GO;
//                s - k u < one-pass limit or < fifty-pass limit: CAUTION (k: coverage_factor)
//   reported     UNKNOWN when raw is; else the worst raw of this segment and of the segments that end
//                within hysteresis_m before its start (an UNKNOWN there counts as CAUTION): an advisory
//                gets worse at once and better only after hysteresis_m of better ground.
#include <array>
#include <cstdint>
#include <vector>

#include "core/track.hpp"
#include "trafficability/rut_damage.hpp"
#include "trafficability/soil_strength.hpp"

namespace rutd {

struct AdvisoryConfig {
  double caution_depth_mm = 80;
  double no_go_depth_mm = 150;
  double hysteresis_m = 3.0;
  double max_untrusted_fraction = 0.5;
  std::uint32_t min_trusted_frames = 3;
  double coverage_factor = 2.0;  // k of the strength comparison (2: about 95 %)
};

struct SegmentConfig {
  double length_m = 1.0;
  AdvisoryConfig advisory;
  SoilStrengthConfig soil;
  std::vector<RutDamageRule> damage;
};

// Empty if usable, else what is wrong, naming the field under `key`.
std::string check_segment_config(const SegmentConfig& config, const std::string& key);

struct TrackStats {
  std::uint64_t frames = 0;                   // measurements fed
  std::uint64_t placed = 0;                   // placed on new ground
  std::uint64_t not_placed = 0;               // at rest or reversing
  std::uint64_t no_motion = 0;                // speed not Ok: not placed, their segment Unknown
  std::uint64_t segments = 0;                 // closed
  std::array<std::uint64_t, 4> advisories{};  // closed segments per reported Advisory value
  double distance_m = 0;                      // new ground covered (the last placed distance)
};

class SegmentTracker {  // not thread-safe: one thread feeds it. Allocates only at construction.
 public:
  static constexpr std::size_t kMaxDepthsPerSegment = 4096;
  static constexpr std::size_t kMaxClosedPerCall = 64;  // a jump over more segments reports the first 64

  explicit SegmentTracker(SegmentConfig config);  // throws std::invalid_argument (check_segment_config)

  // One published measurement at capture time t_ns with the vehicle's motion then, and the position fix
  // in force then (default: none). Returns how many segments it closed; they are closed(0) ..
  // closed(n-1), valid until the next call.
  std::size_t add(std::int64_t t_ns, const RutMeasurement& m, const VehicleMotion& motion,
                  const GeoFix& position = GeoFix{});
  // Closes the open segment (end of a run); returns 0 or 1 as add does.
  std::size_t finish();
  const Segment& closed(std::size_t i) const noexcept { return closed_[i]; }

  const TrackStats& stats() const noexcept { return stats_; }
  const RutDamage& damage() const noexcept { return damage_; }
  const SegmentConfig& config() const noexcept { return config_; }

 private:
  struct Open {
    std::uint64_t index = 0;
    std::int64_t t_start_ns = 0, t_end_ns = 0;
    std::uint32_t frames = 0, ok = 0, no_rut = 0;
    double sum_depth = 0, sum_width = 0, sum_area = 0, sum_u = 0, max_depth = 0;
    std::uint32_t u_count = 0;
    RutStatus worst = RutStatus::Ok;
    bool untrusted_speed = false;
    GeoFix fix;                    // of the placed measurement nearest the middle, if any had one
    double fix_from_middle_m = 0;  // its distance from the middle
  };
  void open_segment(std::uint64_t index);
  void close_open();
  Advisory raw_advisory(const Segment& s, const Open& o) const noexcept;
  Advisory with_hysteresis(const Segment& s, Advisory raw) noexcept;

  SegmentConfig config_;
  RutDamage damage_;
  TrackStats stats_;
  bool have_open_ = false;
  Open open_;
  std::vector<double> depths_;  // Ok depths of the open segment (capacity kMaxDepthsPerSegment)
  std::vector<double> sorted_;  // scratch for P95
  bool have_placed_ = false;
  double last_placed_m_ = 0;
  // Recent raw advisories for the hysteresis: (end_m, raw), newest last, bounded.
  std::vector<std::pair<double, Advisory>> recent_;
  std::size_t recent_max_ = 0;
  std::vector<Segment> closed_;
  std::size_t n_closed_ = 0;
};

}  // namespace rutd
