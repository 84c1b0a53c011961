#pragma once
// The last few fixes, to find the one in force at a frame's capture time. Pure: no threads, no I/O; not
// thread-safe (GpsdSource guards it with its lock). Fixed capacity, no allocation after construction.
#include <array>
#include <cstddef>
#include <cstdint>

#include "core/track.hpp"

namespace rutd {

// gpsd reports one TPV per sentence, so an epoch's GGA and RMC arrive as two TPVs with the same fix time,
// the first without heading or speed, the second without altitude. A field the later one lacks is taken
// from the earlier one of the same epoch (same utc_ns, both valid). The GGA of the next epoch comes
// without heading and speed: those are carried from the previous fix when it was received at most
// kHeadingCarryNs before (a vehicle turns little in a second; after a longer gap they stay unknown).
inline constexpr std::int64_t kHeadingCarryNs = 1'000'000'000;
void complete_from_same_epoch(GeoFix& fix, const GeoFix& previous) noexcept;

class FixHistory {
 public:
  // Enough for a second of a 10 Hz receiver, well beyond the pipeline's latency (frames are joined at
  // publish, within max_frame_age of capture).
  static constexpr std::size_t kCapacity = 16;

  // Adds a report's fix (valid or not) in receive order; a fix received earlier than the last one added
  // replaces nothing and is dropped (returns false).
  bool add(const GeoFix& fix) noexcept;

  // The position at time t_ns (same clock as the fixes' t_ns): the latest fix received at or before t_ns
  // when it is valid and at most max_age_ns old. Otherwise a fix with Mode::NoFix: none received yet (gpsd
  // absent, or t_ns before the first), or the one in force is stale or has no fix. (Mode::None is left
  // for frames without a positioning source at all.)
  GeoFix at(std::int64_t t_ns, std::int64_t max_age_ns) const noexcept;

  std::size_t size() const noexcept { return count_; }
  void clear() noexcept { count_ = 0; }

 private:
  std::array<GeoFix, kCapacity> ring_{};
  std::size_t next_ = 0, count_ = 0;
};

}  // namespace rutd
