#pragma once
// libgps's report state to rutd's GeoFix. Private to drivers/gps: only here is gps.h included.
#include <gps.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string_view>

#include "core/track.hpp"

namespace rutd {

// A TPV's fix as gpsd reported it; `rx_t_ns` is when it was received, on the frames' clock.
inline GeoFix geofix_from_gpsd(const gps_fix_t& f, gps_mask_t set, std::int64_t rx_t_ns) {
  GeoFix fix;
  fix.t_ns = rx_t_ns;
  switch ((set & MODE_SET) ? f.mode : MODE_NOT_SEEN) {
    case MODE_NO_FIX: fix.mode = GeoFix::Mode::NoFix; break;
    case MODE_2D: fix.mode = GeoFix::Mode::Fix2d; break;
    case MODE_3D: fix.mode = GeoFix::Mode::Fix3d; break;
    default: fix.mode = GeoFix::Mode::NoFix; break;  // a TPV without a mode: no fix known
  }
  if (!fix.valid()) return fix;
  if ((set & LATLON_SET) && std::isfinite(f.latitude) && std::isfinite(f.longitude)) {
    fix.latitude_deg = f.latitude;
    fix.longitude_deg = f.longitude;
  } else {
    fix.mode = GeoFix::Mode::NoFix;  // a fix mode without a position is no fix to place anything by
    return fix;
  }
  // Height above mean sea level as receivers show it; the ellipsoid height when only that came.
  if (fix.mode == GeoFix::Mode::Fix3d) fix.altitude_m = std::isfinite(f.altMSL) ? f.altMSL : f.altHAE;
  // gpsd's eph (95 %); without it the two axes' 95 % errors combined, which never understates it.
  if (std::isfinite(f.eph)) fix.horizontal_error_m = f.eph;
  else if (std::isfinite(f.epx) && std::isfinite(f.epy)) fix.horizontal_error_m = std::hypot(f.epx, f.epy);
  if ((set & TRACK_SET) && std::isfinite(f.track)) fix.heading_deg = f.track;
  if ((set & SPEED_SET) && std::isfinite(f.speed)) fix.speed_m_s = f.speed;
  if (set & TIME_SET)
    fix.utc_ns = static_cast<std::int64_t>(f.time.tv_sec) * 1'000'000'000 + static_cast<std::int64_t>(f.time.tv_nsec);
  return fix;
}

// Whether a report line is a TPV (gpsd writes "class" first and without spaces).
inline bool is_tpv_report(std::string_view json) { return json.find("\"class\":\"TPV\"") != std::string_view::npos; }

// Clears what a previous report left, so that a field absent from this one reads as absent.
inline void clear_gpsd_report(gps_data_t& data) {
  data.set = 0;
  gps_clear_fix(&data.fix);
}

}  // namespace rutd
