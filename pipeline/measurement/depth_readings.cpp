#include "measurement/depth_readings.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace rutd {

std::optional<DepthReading> combine_depth_readings(std::span<const DepthReading> readings) {
  constexpr std::array<double, 7> kChi2_95 = {0.0, 3.84, 5.99, 7.81, 9.49, 11.07, 12.59};
  const std::size_t k = readings.size();
  if (k < 2 || k > kChi2_95.size()) return std::nullopt;
  const auto shared = [](const DepthReading& r) { return std::clamp(r.systematic_mm, 0.0, r.u_mm); };
  double sw = 0.0, swd = 0.0, sws = 0.0;
  for (const DepthReading& r : readings) {
    if (!std::isfinite(r.u_mm) || !(r.u_mm > 0.0) || !std::isfinite(r.depth_mm)) return std::nullopt;
    const double wt = 1.0 / (r.u_mm * r.u_mm);
    sw += wt;
    swd += wt * r.depth_mm;
    sws += wt * shared(r);
  }
  const double mean = swd / sw;
  double chi2 = 0.0, noise = 0.0;  // noise: the variance of the mean's noise part, times sw^2
  for (const DepthReading& r : readings) {
    const double s = shared(r);
    chi2 += std::pow((r.depth_mm - mean) / r.u_mm, 2);
    noise += (r.u_mm * r.u_mm - s * s) / std::pow(r.u_mm, 4);
  }
  if (!(chi2 <= kChi2_95[k - 1])) return std::nullopt;
  const double s = sws / sw;
  return DepthReading{mean, std::sqrt(std::max(1.0, chi2 / double(k - 1)) * noise / (sw * sw) + s * s), s};
}

}  // namespace rutd
