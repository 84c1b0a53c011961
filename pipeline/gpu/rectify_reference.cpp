#include <algorithm>
#include <cmath>
#include <string>

#include "gpu/rectify.hpp"

// Compiled with -ffp-contract=off (CMakeLists.txt): no fused multiply-adds, as the shader's `precise`.
namespace rutd::gpu {

std::string check_rectify_maps(const RectifyMaps& m, int width, int height) {
  if (m.raw_width < 1 || m.raw_height < 1) return "rectification maps: raw size must be positive";
  if (m.width != width || m.height != height)
    return "rectification maps are for a " + std::to_string(m.width) + "x" + std::to_string(m.height) +
           " strip, the matcher's is " + std::to_string(width) + "x" + std::to_string(height);
  const std::size_t n = 2 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (m.left.size() != n || m.right.size() != n) return "rectification maps: not two floats per strip pixel";
  for (const auto* map : {&m.left, &m.right})
    for (const float v : *map)
      if (!std::isfinite(v)) return "rectification maps: a position is not finite";
  return {};
}

std::array<int, 2> rectify_rows(const RectifyMaps& maps) {
  const int max_y = maps.raw_height - 1;
  int first = max_y, last = 0;
  for (const auto* map : {&maps.left, &maps.right}) {
    for (std::size_t i = 1; i < map->size(); i += 2) {
      const int y0 = static_cast<int>(std::clamp((*map)[i], 0.0f, static_cast<float>(max_y)));
      first = std::min(first, std::max(y0 - 1, 0));
      last = std::max(last, std::min(y0 + 2, max_y));
    }
  }
  if (first > last) return {0, maps.raw_height};  // no pixels
  return {first, last + 1};
}

void rectify_reference(const ImageView& raw, const std::vector<float>& map, int width, int height,
                       std::vector<std::uint8_t>& out) {
  out.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  const int max_x = raw.width - 1, max_y = raw.height - 1;
  const auto weights = [](float t, float w[4]) {
    const float t2 = t * t, t3 = t2 * t, u = 1.0f - t;
    constexpr float kSixth = 1.0f / 6.0f;
    w[0] = u * u * u * kSixth;
    w[1] = (3.0f * t3 - 6.0f * t2 + 4.0f) * kSixth;
    w[2] = (-3.0f * t3 + 3.0f * t2 + 3.0f * t + 1.0f) * kSixth;
    w[3] = t3 * kSixth;
  };
  for (std::size_t i = 0; i < out.size(); ++i) {
    const float x = std::clamp(map[2 * i], 0.0f, static_cast<float>(max_x));
    const float y = std::clamp(map[2 * i + 1], 0.0f, static_cast<float>(max_y));
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    float wx[4], wy[4];
    weights(x - static_cast<float>(x0), wx);
    weights(y - static_cast<float>(y0), wy);
    int xs[4];
    for (int k = 0; k < 4; ++k) xs[k] = std::clamp(x0 - 1 + k, 0, max_x);
    float sum = 0.0f;
    for (int j = 0; j < 4; ++j) {
      const int yj = std::clamp(y0 - 1 + j, 0, max_y);
      const float row = wx[0] * static_cast<float>(raw.at(xs[0], yj)) + wx[1] * static_cast<float>(raw.at(xs[1], yj)) +
                        wx[2] * static_cast<float>(raw.at(xs[2], yj)) + wx[3] * static_cast<float>(raw.at(xs[3], yj));
      sum = sum + wy[j] * row;
    }
    out[i] = static_cast<std::uint8_t>(std::clamp(std::nearbyint(sum), 0.0f, 255.0f));
  }
}

CoarseGrid coarse_grid(int width, int height, int scale) {
  CoarseGrid g;
  g.scale = std::max(scale, 1);
  g.row_factor = height >= 10 ? 2 : 1;
  g.width = width / g.scale;
  g.height = height / g.row_factor;
  return g;
}

void downsample_reference(const ImageView& strip, const CoarseGrid& g, std::vector<std::uint8_t>& out) {
  out.resize(static_cast<std::size_t>(g.width) * static_cast<std::size_t>(g.height));
  const unsigned area = static_cast<unsigned>(g.scale * g.row_factor);
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      unsigned sum = 0;
      for (int dy = 0; dy < g.row_factor; ++dy)
        for (int dx = 0; dx < g.scale; ++dx) sum += strip.at(x * g.scale + dx, y * g.row_factor + dy);
      out[static_cast<std::size_t>(y) * static_cast<std::size_t>(g.width) + static_cast<std::size_t>(x)] =
          static_cast<std::uint8_t>((sum + area / 2) / area);
    }
  }
}

}  // namespace rutd::gpu
