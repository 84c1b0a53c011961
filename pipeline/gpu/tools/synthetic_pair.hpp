#pragma once
// A textured stereo pair for the standalone tools: smoothed random texture on the left, the right view
// the left shifted by a disparity that varies smoothly across the image (a slanted, wavy surface) inside
// the band, plus noise. Deterministic for a seed. row_wave_px: the amplitude of the waves down the image,
// px; < 0: a tenth of the band (strong enough that windows spanning tens of rows cannot follow them).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace rutd::gpu::tools {

struct Pair {
  int width = 0, height = 0;
  std::vector<std::uint8_t> left, right;
};

inline Pair synthetic_pair(int width, int height, int min_disparity, int num_disparities, std::uint32_t seed,
                           float row_wave_px = -1.0f) {
  // The wave's amplitude as a share of the band (0.1 exactly by default, the images of earlier builds).
  const float wave = row_wave_px >= 0.0f ? row_wave_px / static_cast<float>(num_disparities) : 0.1f;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  const int margin = min_disparity + num_disparities + 2;
  const int tw = width + margin;
  std::vector<float> texture(static_cast<std::size_t>(tw) * static_cast<std::size_t>(height));
  for (float& t : texture) t = u(rng);
  std::vector<float> smooth(texture.size());
  for (int y = 0; y < height; ++y) {  // 3x3 box: speckle a few px wide, like ground texture
    for (int x = 0; x < tw; ++x) {
      float s = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          s += texture[static_cast<std::size_t>(std::clamp(y + dy, 0, height - 1)) * static_cast<std::size_t>(tw) +
                       static_cast<std::size_t>(std::clamp(x + dx, 0, tw - 1))];
      smooth[static_cast<std::size_t>(y) * static_cast<std::size_t>(tw) + static_cast<std::size_t>(x)] = s / 9.f;
    }
  }
  const auto sample = [&](float x, int y) {  // linear along the row
    const float cx = std::clamp(x, 0.f, static_cast<float>(tw - 2));
    const int x0 = static_cast<int>(cx);
    const float f = cx - static_cast<float>(x0);
    const float* row = smooth.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(tw);
    return row[x0] * (1 - f) + row[x0 + 1] * f;
  };
  Pair p;
  p.width = width;
  p.height = height;
  p.left.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  p.right.resize(p.left.size());
  std::normal_distribution<float> noise(0.f, 1.5f);
  const auto grey = [&](float v) {
    return static_cast<std::uint8_t>(std::clamp(v * 400.f - 70.f + noise(rng), 0.f, 255.f));
  };
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float d =
          static_cast<float>(min_disparity) +
          static_cast<float>(num_disparities) * (0.3f + 0.2f * static_cast<float>(x) / static_cast<float>(width) +
                                                 wave * std::sin(static_cast<float>(y) * 0.05f));
      const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x);
      p.left[i] = grey(sample(static_cast<float>(x + margin), y));
      p.right[i] = grey(sample(static_cast<float>(x + margin) + d, y));
    }
  }
  return p;
}

}  // namespace rutd::gpu::tools
