// reduce_to_cross_section: strip of 3D points -> Z(X) by robust averaging within X bins.
#include <algorithm>
#include <cmath>
#include <limits>

#include "rut/extract.hpp"

namespace rutd {
namespace {

bool valid_point(const cv::Vec3f& p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]) && p[2] > 0.0f;
}

// Calls f(point) for every valid point of the strip.
template <typename F>
void for_each_valid(const cv::Mat& xyz, F&& f) {
  for (int r = 0; r < xyz.rows; ++r) {
    const cv::Vec3f* row = xyz.ptr<cv::Vec3f>(r);
    for (int col = 0; col < xyz.cols; ++col) {
      if (valid_point(row[col])) f(row[col]);
    }
  }
}

// Mean of the samples [first, last) after dropping `trim` of them at each end (two partial
// partitions, no full sort); the middle one or two for tiny bins, so three samples already reject
// one outlier. Reorders the range.
double trimmed_mean(float* first, float* last, double trim_fraction) {
  const long n = last - first;
  if (n <= 2) return n == 1 ? first[0] : 0.5 * (double(first[0]) + double(first[1]));
  long trim = static_cast<long>(std::floor(double(n) * trim_fraction));
  trim = std::clamp(trim, trim_fraction > 0.0 ? 1L : 0L, (n - 1) / 2);
  if (trim > 0) {
    std::nth_element(first, first + trim, last);        // [0, trim) are the smallest
    std::nth_element(first + trim, last - trim, last);  // [n - trim, n) are the largest
  }
  double sum = 0.0;
  for (const float* p = first + trim; p < last - trim; ++p) sum += *p;
  return sum / double(n - 2 * trim);
}

// Least-squares dZ/dY of the points [first, last) (z, y paired); NaN where Y spans too little to tell.
double slope_along_y(const float* z, const float* y, long n, double min_span) {
  if (n < 8) return std::numeric_limits<double>::quiet_NaN();
  double my = 0.0, mz = 0.0, lo = y[0], hi = y[0];
  for (long i = 0; i < n; ++i) {
    my += y[i];
    mz += z[i];
    lo = std::min(lo, double(y[i]));
    hi = std::max(hi, double(y[i]));
  }
  if (hi - lo < min_span) return std::numeric_limits<double>::quiet_NaN();
  my /= double(n);
  mz /= double(n);
  double syy = 0.0, syz = 0.0;
  for (long i = 0; i < n; ++i) {
    syy += (y[i] - my) * (y[i] - my);
    syz += (y[i] - my) * (z[i] - mz);
  }
  return syz / syy;
}

}  // namespace

void reduce_to_cross_section(const cv::Mat& xyz, const RutConfig& params, CrossSection& out) {
  const double dx = params.bin_mm > 0.0 ? params.bin_mm : 1.0;
  out.dx_mm = dx;
  out.x0_mm = 0.0;
  out.z_mm.clear();
  out.count.clear();
  out.along_slope = 0.0;
  out.ray_elevation = 0.0;
  if (xyz.empty() || xyz.type() != CV_32FC3) return;

  // Pass 1: extent and median of X (a median, so that a few absurd reprojections cannot move it).
  double xmin = std::numeric_limits<double>::infinity();
  double xmax = -xmin;
  double elevation = 0.0;
  out.scratch_z.clear();
  for_each_valid(xyz, [&](const cv::Vec3f& p) {
    xmin = std::min(xmin, double(p[0]));
    xmax = std::max(xmax, double(p[0]));
    elevation += double(p[1]) / double(p[2]);
    out.scratch_z.push_back(p[0]);
  });
  if (out.scratch_z.empty()) return;
  out.ray_elevation = elevation / double(out.scratch_z.size());
  auto mid = out.scratch_z.begin() + static_cast<long>(out.scratch_z.size() / 2);
  std::nth_element(out.scratch_z.begin(), mid, out.scratch_z.end());
  const double half_span = 0.5 * params.max_section_mm;
  xmin = std::max(xmin, double(*mid) - half_span);
  xmax = std::min(xmax, double(*mid) + half_span);

  const long first_bin = std::lround(xmin / dx);
  const int nbins = static_cast<int>(std::lround(xmax / dx) - first_bin + 1);
  out.x0_mm = double(first_bin) * dx;
  out.z_mm.assign(nbins, std::numeric_limits<double>::quiet_NaN());
  out.count.assign(nbins, 0);
  auto bin_of = [&](float x) { return static_cast<int>(std::lround(double(x) / dx) - first_bin); };

  // Pass 2: points per bin; pass 3: scatter Z into contiguous per-bin segments (reusing scratch_z).
  for_each_valid(xyz, [&](const cv::Vec3f& p) {
    const int b = bin_of(p[0]);
    if (b >= 0 && b < nbins) ++out.count[b];
  });
  out.scratch_offset.resize(nbins + 1);
  out.scratch_offset[0] = 0;
  for (int b = 0; b < nbins; ++b) out.scratch_offset[b + 1] = out.scratch_offset[b] + out.count[b];
  out.scratch_z.resize(out.scratch_offset[nbins]);
  out.scratch_y.resize(out.scratch_offset[nbins]);
  for_each_valid(xyz, [&](const cv::Vec3f& p) {
    const int b = bin_of(p[0]);
    if (b >= 0 && b < nbins) {
      out.scratch_y[out.scratch_offset[b]] = p[1];
      out.scratch_z[out.scratch_offset[b]++] = p[2];
    }
  });
  // scratch_offset[b] now holds the end of bin b, i.e. the start of bin b + 1. Each bin's slope along Y
  // before its trimmed mean reorders its Z: most bins see ground or a bottom running along travel, so
  // their median is the ground's (a pitched rig's), and a few mismatched points move one bin's only.
  // A bin must span a few millimetres of Y (a strip of rows does: 48 rows at 300 mm and f = 550 px
  // span 26 mm).
  out.scratch_slope.clear();
  int start = 0;
  for (int b = 0; b < nbins; ++b) {
    const int end = out.scratch_offset[b];
    const double s = slope_along_y(out.scratch_z.data() + start, out.scratch_y.data() + start, end - start, 4.0);
    if (std::isfinite(s)) out.scratch_slope.push_back(s);
    start = end;
  }
  if (!out.scratch_slope.empty()) {
    auto m = out.scratch_slope.begin() + static_cast<long>(out.scratch_slope.size() / 2);
    std::nth_element(out.scratch_slope.begin(), m, out.scratch_slope.end());
    // Beyond 45 degrees the strip sees no ground a rig looks down on: nothing to level.
    out.along_slope = std::abs(*m) <= 1.0 ? *m : 0.0;
  }
  start = 0;
  for (int b = 0; b < nbins; ++b) {
    const int end = out.scratch_offset[b];
    if (end > start) {
      out.z_mm[b] = trimmed_mean(out.scratch_z.data() + start, out.scratch_z.data() + end, params.trim_fraction);
    }
    start = end;
  }
}

}  // namespace rutd
