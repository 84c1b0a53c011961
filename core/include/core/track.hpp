#pragma once
// Where the vehicle is and what the rut amounts to along its track: the plain types the trafficability
// computation (trafficability/) produces and every sink may read (CAN, CSV, the uplink, the web view).
// The computations live in trafficability/ (distance, segments, soil strength, the advisory) and in the
// sources (vehicle speed from the CAN bus, positions from gpsd); these are only the values they hand on.
// Lengths in millimetres unless the name says metres, times in nanoseconds on the frames' clock.
#include <cstdint>
#include <limits>
#include <string_view>

#include "core/rut_measurement.hpp"

namespace rutd {

// Stable numeric values: they travel on the CAN bus (config/rutd.dbc value table), in CSV files and in
// the uplink's JSON.
enum class Advisory : std::uint8_t {
  Unknown = 0,  // speed, measurements or the scene not trustworthy: never read as GO
  Go = 1,
  Caution = 2,
  NoGo = 3,
};
std::string_view to_string(Advisory advisory) noexcept;

// What the vehicle's speed signal says at a moment.
enum class SpeedState : std::uint8_t {
  Ok = 0,            // a valid speed, received within the configured age
  NotAvailable = 1,  // the sender says "not available" (J1939: all ones)
  Error = 2,         // the sender says "error" (J1939 error indicator range)
  Stale = 3,         // no valid speed for longer than the configured age
  NoSource = 4,      // no speed source configured or none received yet
};
std::string_view to_string(SpeedState state) noexcept;

// One reading of the vehicle's speed signal as its source decoded it (drivers/can: J1939 CCVS or a DBC
// signal), in the order received. t_ns: receive time on the frames' clock. speed_mm_s is signed
// (negative while reversing, when the source knows the direction) and 0 unless state is Ok.
struct SpeedSample {
  std::int64_t t_ns = 0;
  SpeedState state = SpeedState::NoSource;
  double speed_mm_s = 0.0;
};

// The vehicle's motion at one frame's capture time.
struct VehicleMotion {
  SpeedState state = SpeedState::NoSource;
  double speed_mm_s = 0.0;  // signed: negative while reversing; 0 unless state is Ok
  // Position along the track, metres of new ground covered since the run started: it advances only while
  // driving forward over ground not yet measured, holds at rest and while reversing (the camera behind
  // the tyre then sees ground the tyre has not yet passed over again), and is NaN while speed is unknown.
  double distance_m = std::numeric_limits<double>::quiet_NaN();
};

// A position fix as reported by the positioning source (gpsd). Invalid fields are NaN.
struct GeoFix {
  enum class Mode : std::uint8_t { None = 0, NoFix = 1, Fix2d = 2, Fix3d = 3 };
  Mode mode = Mode::None;
  std::int64_t t_ns = 0;                                           // receive time on the frames' clock
  double latitude_deg = std::numeric_limits<double>::quiet_NaN();  // WGS84
  double longitude_deg = std::numeric_limits<double>::quiet_NaN();
  double altitude_m = std::numeric_limits<double>::quiet_NaN();
  double horizontal_error_m = std::numeric_limits<double>::quiet_NaN();  // gpsd's eph, 95 % estimate
  double heading_deg = std::numeric_limits<double>::quiet_NaN();         // track over ground, true north
  double speed_m_s = std::numeric_limits<double>::quiet_NaN();           // speed over ground
  std::int64_t utc_ns = 0;  // the fix's own time (UTC, ns since 1970) as the receiver gave it; 0: none
  bool valid() const noexcept { return mode == Mode::Fix2d || mode == Mode::Fix3d; }
};

// One segment of the track (configurable length, default 1 m) with what was measured on it. Closed when
// the vehicle's distance passes its end; a segment whose measurements or speed could not be trusted is
// still reported, with advisory Unknown.
struct Segment {
  std::uint64_t index = 0;  // 0, 1, 2 ... along the track of this run
  double start_m = 0.0, end_m = 0.0;
  std::int64_t t_start_ns = 0, t_end_ns = 0;                        // capture times of its first and last frame
  std::uint32_t frames = 0;                                         // measurements placed on it
  std::uint32_t refused = 0;                                        // of those, not Ok
  double mean_depth_mm = std::numeric_limits<double>::quiet_NaN();  // over the Ok measurements
  double max_depth_mm = std::numeric_limits<double>::quiet_NaN();
  double p95_depth_mm = std::numeric_limits<double>::quiet_NaN();
  double depth_uncertainty_mm = std::numeric_limits<double>::quiet_NaN();  // of mean_depth_mm
  double mean_width_mm = std::numeric_limits<double>::quiet_NaN();
  double mean_area_mm2 = std::numeric_limits<double>::quiet_NaN();
  RutStatus worst_status = RutStatus::NoMeasurement;  // the least trustworthy status seen on it
  // Soil strength from the sinkage by the vehicle's calibrated relation (NaN without one), and its
  // standard uncertainty carried from the depth's.
  double soil_strength = std::numeric_limits<double>::quiet_NaN();
  double soil_strength_uncertainty = std::numeric_limits<double>::quiet_NaN();
  Advisory advisory = Advisory::Unknown;
  GeoFix position;         // at the segment's middle, when a positioning source is configured
  std::uint32_t pass = 0;  // pass over this ground (0: first or unknown), when positions are matched
};

}  // namespace rutd
