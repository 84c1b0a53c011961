#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "gpu/sgm.hpp"

namespace rutd::gpu {
namespace {

// The path directions in the order the GPU runs them; the first `paths` are used.
constexpr std::array<std::array<int, 2>, 8> kDirections = {
    {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {-1, 1}, {1, -1}, {-1, -1}}};

int line_count(int w, int h, int dx, int dy) { return dy == 0 ? h : dx == 0 ? w : w + h - 1; }

// First pixel of line `line` of direction (dx, dy), as aggregate.comp computes it.
void line_start(int w, int h, int dx, int dy, int line, int& x, int& y) {
  if (dy == 0) {
    x = dx > 0 ? 0 : w - 1;
    y = line;
  } else if (line < w) {
    x = line;
    y = dy > 0 ? 0 : h - 1;
  } else {
    x = dx > 0 ? 0 : w - 1;
    y = dy > 0 ? 1 + (line - w) : h - 2 - (line - w);
  }
}

}  // namespace

std::string check_sgm_input(int width, int height, SgmBand band, const SgmConfig& params) {
  if (width < 1 || height < 1) return "empty image";
  if (band.min_disparity < 0) return "min_disparity must be >= 0";
  if (band.num_disparities < 2 || band.num_disparities > kMaxDisparities || band.num_disparities % 2 != 0)
    return "num_disparities must be even and 2.." + std::to_string(kMaxDisparities);
  if (params.paths != 2 && params.paths != 4 && params.paths != 8) return "paths must be 2, 4 or 8";
  if (params.p1 < 0 || params.p2 <= params.p1 || params.p2 > kMaxP2)
    return "need 0 <= p1 < p2 <= " + std::to_string(kMaxP2);
  if (params.uniqueness < 0 || params.uniqueness > 99) return "uniqueness must be 0..99";
  if (params.segment != 0 && params.segment < 16) return "segment must be 0 (off) or >= 16 px";
  if (params.segment_run_in < 0) return "segment run-in must be >= 0";
  return {};
}

void census_reference(const ImageView& im, std::vector<std::uint32_t>& out) {
  out.resize(static_cast<std::size_t>(im.width) * static_cast<std::size_t>(im.height) * 2);
  for (int y = 0; y < im.height; ++y) {
    for (int x = 0; x < im.width; ++x) {
      const std::uint8_t c = im.at(x, y);
      std::uint32_t lo = 0, hi = 0;
      int k = 0;
      for (int dy = -3; dy <= 3; ++dy) {
        for (int dx = -4; dx <= 4; ++dx) {
          if (dx == 0 && dy == 0) continue;
          const int sx = std::clamp(x + dx, 0, im.width - 1), sy = std::clamp(y + dy, 0, im.height - 1);
          const std::uint32_t b = im.at(sx, sy) < c ? 1u : 0u;
          if (k < 32) lo |= b << k;
          else hi |= b << (k - 32);
          ++k;
        }
      }
      const std::size_t i =
          (static_cast<std::size_t>(y) * static_cast<std::size_t>(im.width) + static_cast<std::size_t>(x)) * 2;
      out[i] = lo;
      out[i + 1] = hi;
    }
  }
}

void aggregate_reference(SgmStages& st, const SgmConfig& params) {
  const int w = st.width, h = st.height, nd = st.band.num_disparities, dmin = st.band.min_disparity;
  constexpr std::uint32_t kBig = 0xFFFF;
  st.sums.assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * static_cast<std::size_t>(nd), 0);
  std::vector<std::uint32_t> prev(static_cast<std::size_t>(nd) + 2), cur(prev.size());
  const auto p1 = static_cast<std::uint32_t>(params.p1), p2 = static_cast<std::uint32_t>(params.p2);
  for (int dir = 0; dir < params.paths; ++dir) {
    const int dx = kDirections[static_cast<std::size_t>(dir)][0], dy = kDirections[static_cast<std::size_t>(dir)][1];
    // Rows in segments (SgmConfig::segment): segment k keeps walk steps [k S, (k + 1) S), walked from
    // max(0, k S - run_in).
    const bool segmented = dy == 0 && params.segment > 0;
    const int segments = segmented ? (w + params.segment - 1) / params.segment : 1;
    for (int line_seg = 0; line_seg < line_count(w, h, dx, dy) * segments; ++line_seg) {
      const int line = line_seg / segments, seg = line_seg % segments;
      int x = 0, y = 0;
      line_start(w, h, dx, dy, line, x, y);
      int begin = 0, end = 1 << 30, keep_from = 0;
      if (segmented) {
        begin = std::max(0, seg * params.segment - params.segment_run_in);
        end = std::min((seg + 1) * params.segment, w);
        keep_from = seg * params.segment - begin;
        x += begin * dx;
      }
      std::fill(prev.begin(), prev.end(), kBig);
      std::fill(cur.begin(), cur.end(), kBig);
      std::uint32_t prev_min = 0;
      for (int step = 0; x >= 0 && x < w && y >= 0 && y < h && step < end - begin; ++step, x += dx, y += dy) {
        const std::size_t p = static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
        const std::uint32_t cl0 = st.census_left[2 * p], cl1 = st.census_left[2 * p + 1];
        std::uint32_t cur_min = kBig;
        for (int d = 0; d < nd; ++d) {
          const int xr = x - dmin - d;
          std::uint32_t c = 64;
          if (xr >= 0) {
            const std::size_t r = p - static_cast<std::size_t>(x - xr);
            c = static_cast<std::uint32_t>(__builtin_popcount(cl0 ^ st.census_right[2 * r]) +
                                           __builtin_popcount(cl1 ^ st.census_right[2 * r + 1]));
          }
          std::uint32_t l = c;
          if (step > 0) {
            const auto di = static_cast<std::size_t>(d);
            const std::uint32_t near = std::min(prev[di], prev[di + 2]) + p1;
            l = c + std::min(std::min(prev[di + 1], near), prev_min + p2) - prev_min;
          }
          cur[static_cast<std::size_t>(d) + 1] = l;
          cur_min = std::min(cur_min, l);
          if (step >= keep_from)
            st.sums[p * static_cast<std::size_t>(nd) + static_cast<std::size_t>(d)] += static_cast<std::uint16_t>(l);
        }
        std::swap(prev, cur);
        prev_min = cur_min;
      }
    }
  }
}

void wta_reference(SgmStages& st, const SgmConfig& params) {
  const int w = st.width, h = st.height, nd = st.band.num_disparities, dmin = st.band.min_disparity;
  st.disparity_left.assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), -1);
  st.disparity_right.assign(st.disparity_left.size(), -1);
  const auto cost = [&](int x, int y, int d) -> std::uint32_t {
    return st.sums[(static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)) *
                       static_cast<std::size_t>(nd) +
                   static_cast<std::size_t>(d)];
  };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
      if (x >= dmin + nd - 1) {
        std::uint32_t best = std::numeric_limits<std::uint32_t>::max();
        int bd = 0;
        for (int d = 0; d < nd; ++d) {
          if (cost(x, y, d) < best) {
            best = cost(x, y, d);
            bd = d;
          }
        }
        bool unique = true;
        for (int d = 0; d < nd; ++d) {
          if (std::abs(d - bd) > 1 && cost(x, y, d) * static_cast<std::uint32_t>(100 - params.uniqueness) < best * 100u)
            unique = false;
        }
        if (unique) {
          int v = (dmin + bd) * kSubpixelScale;
          if (bd > 0 && bd < nd - 1) {
            const int a = static_cast<int>(cost(x, y, bd - 1)), b = static_cast<int>(cost(x, y, bd + 1));
            const int den = std::max(a + b - 2 * static_cast<int>(best), 1);
            const int n = (a - b) * kSubpixelScale + den;
            v += n >= 0 ? n / (2 * den) : -((-n) / (2 * den));
          }
          st.disparity_left[p] = v;
        }
      }
      std::uint32_t best_r = std::numeric_limits<std::uint32_t>::max();
      for (int d = 0; d < nd && x + dmin + d < w; ++d) {
        if (cost(x + dmin + d, y, d) < best_r) {
          best_r = cost(x + dmin + d, y, d);
          st.disparity_right[p] = dmin + d;
        }
      }
    }
  }
}

void lr_median_reference(SgmStages& st, const SgmConfig& params) {
  const int w = st.width, h = st.height;
  const auto at = [w](int x, int y) {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
  };
  const auto checked = [&](int x, int y) {
    const int v = st.disparity_left[at(x, y)];
    if (v < 0 || params.lr_max_diff < 0) return v;
    const int d = (v + kSubpixelScale / 2) >> 6;
    if (x - d < 0) return -1;
    const int r = st.disparity_right[at(x - d, y)];
    return r >= 0 && std::abs(r - d) <= params.lr_max_diff ? v : -1;
  };
  st.disparity.resize(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      int m;
      if (!params.median || x == 0 || y == 0 || x == w - 1 || y == h - 1) {
        m = checked(x, y);
      } else {
        std::array<int, 9> v{};
        int n = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) v[static_cast<std::size_t>(n++)] = checked(x + dx, y + dy);
        std::nth_element(v.begin(), v.begin() + 4, v.end());  // the same value as the shader's sort
        m = v[4];
      }
      st.disparity[at(x, y)] = m < 0 ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(m) / 64.0f;
    }
  }
}

void sgm_reference(const ImageView& left, const ImageView& right, SgmBand band, const SgmConfig& params,
                   SgmStages& st) {
  st.width = left.width;
  st.height = left.height;
  st.band = band;
  census_reference(left, st.census_left);
  census_reference(right, st.census_right);
  aggregate_reference(st, params);
  wta_reference(st, params);
  lr_median_reference(st, params);
}

}  // namespace rutd::gpu
