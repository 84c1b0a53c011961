#include "daemon/run_summary.hpp"

#include <string>

#include <spdlog/spdlog.h>

namespace rutd {

RunSummary::RunSummary() : start_(std::chrono::steady_clock::now()) {}

void RunSummary::add(const RutMeasurement& m, const MeasurementDiagnostics& d) {
  ++pairs_;
  const auto s = static_cast<std::size_t>(m.status);
  if (s < by_status_.size()) ++by_status_[s];
  if (d.gaps_read) ++gaps_read_;
  if (d.low_texture_read) ++low_texture_read_;
  if (const auto r = static_cast<std::size_t>(d.water_rule); r > 0 && r < by_water_rule_.size()) ++by_water_rule_[r];
  if (const auto r = static_cast<std::size_t>(d.dry_overruled); r > 0 && r < dry_overruled_.size()) ++dry_overruled_[r];
  rectify_ms_ += d.rectify_ms;
  band_ms_ += d.band_ms;
  disparity_ms_ += d.disparity_ms;
  dic_ms_ += d.dic_ms;
  reproject_ms_ += d.reproject_ms;
  rut_ms_ += d.rut_ms;
}

void RunSummary::log() const {
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double measure_ms = rectify_ms_ + band_ms_ + disparity_ms_ + dic_ms_ + reproject_ms_ + rut_ms_;
  std::string statuses;
  for (std::size_t i = 0; i < by_status_.size(); ++i) {
    if (by_status_[i] == 0) continue;
    if (!statuses.empty()) statuses += ", ";
    statuses += std::string(to_string(static_cast<RutStatus>(i))) + " " + std::to_string(by_status_[i]);
  }
  const auto per_rule = [](const std::array<std::uint64_t, kWaterRuleCount>& counts) {
    std::string text;
    for (std::size_t r = 1; r < counts.size(); ++r) {
      if (counts[r] == 0) continue;
      text += (text.empty() ? "" : ", ") + std::string(water_rule_name(static_cast<WaterRule>(r))) + " " +
              std::to_string(counts[r]);
    }
    return text;
  };
  if (const std::string water = per_rule(by_water_rule_); !water.empty()) statuses += "; flagged Water by " + water;
  if (const std::string dry = per_rule(dry_overruled_); !dry.empty())
    statuses += "; read dry as the steady frames before, overruling " + dry;
  if (gaps_read_ > 0) statuses += "; gaps read again with wider windows on " + std::to_string(gaps_read_) + " pairs";
  if (low_texture_read_ > 0)
    statuses += "; read again with the noise judging the windows on " + std::to_string(low_texture_read_) + " pairs";
  const std::uint64_t failures = pairs_ - by_status_[static_cast<std::size_t>(RutStatus::Ok)];
  spdlog::info("{} pairs, {} failures ({}); {:.1f} Hz measuring, {:.1f} Hz wall", pairs_, failures,
               statuses.empty() ? "none" : statuses, measure_ms > 0 ? 1000.0 * pairs_ / measure_ms : 0.0,
               wall_s > 0 ? pairs_ / wall_s : 0.0);
  if (pairs_ == 0) return;
  const double n = static_cast<double>(pairs_);
  spdlog::info(
      "mean ms per pair: rectify {:.2f}, band {:.2f}, disparity {:.2f}, dic {:.2f}, reproject {:.2f}, rut {:.2f}, "
      "total {:.2f}",
      rectify_ms_ / n, band_ms_ / n, disparity_ms_ / n, dic_ms_ / n, reproject_ms_ / n, rut_ms_ / n, measure_ms / n);
}

}  // namespace rutd
