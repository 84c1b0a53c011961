#pragma once
// Where a frame's position comes from: the live gpsd source (GpsdSource) or a recording's gps.jsonl
// (RecordedPositions). The daemon asks it for every published frame (PositionJoinSink).
#include <cstdint>
#include <vector>

#include "core/track.hpp"

namespace rutd {

class PositionSource {
 public:
  virtual ~PositionSource() = default;
  // The fix in force at t_ns (CLOCK_MONOTONIC, the frames' clock): the latest received at or before it,
  // when valid and not older than the source's limit; else Mode::NoFix (also before any report).
  // Thread-safe where the implementation says so; must not block for long (called per frame).
  virtual GeoFix position_at(std::int64_t t_ns) const = 0;
};

// A recording's fixes (read_recorded_fixes), joined exactly as they were live.
class RecordedPositions final : public PositionSource {
 public:
  // `fixes` in receive order (t_ns not decreasing; later fixes received earlier are dropped).
  RecordedPositions(std::vector<GeoFix> fixes, std::int64_t max_age_ns);
  GeoFix position_at(std::int64_t t_ns) const override;
  std::size_t size() const { return fixes_.size(); }

 private:
  std::vector<GeoFix> fixes_;
  std::int64_t max_age_ns_;
};

}  // namespace rutd
