#pragma once
// Counts and timings of a run of measurements, logged at the end of `replay` and `run`.
#include <array>
#include <chrono>
#include <cstdint>

#include "measurement/measurer.hpp"

namespace rutd {

class RunSummary {
 public:
  RunSummary();
  void add(const RutMeasurement& m, const MeasurementDiagnostics& d);
  // Logs pairs, measurements per status (the pairs flagged Water per rule that flagged them, a guard strip's
  // among them, the pairs read dry as the frames before per rule overruled, and on how many the gaps were read
  // again with wider windows), measurement rate (pairs per second
  // of measuring time, and per second of wall time) and the mean time of each stage.
  void log() const;
  std::uint64_t pairs() const { return pairs_; }

 private:
  std::chrono::steady_clock::time_point start_;
  std::uint64_t pairs_ = 0;
  std::array<std::uint64_t, kRutStatusCount> by_status_{};
  std::uint64_t gaps_read_ = 0;                                 // MeasurementDiagnostics::gaps_read
  std::uint64_t low_texture_read_ = 0;                          // MeasurementDiagnostics::low_texture_read
  std::array<std::uint64_t, kWaterRuleCount> by_water_rule_{};  // MeasurementDiagnostics::water_rule
  std::array<std::uint64_t, kWaterRuleCount> dry_overruled_{};  // MeasurementDiagnostics::dry_overruled
  double rectify_ms_ = 0, band_ms_ = 0, disparity_ms_ = 0, dic_ms_ = 0, reproject_ms_ = 0, rut_ms_ = 0;
};

}  // namespace rutd
