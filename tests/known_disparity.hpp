#pragma once
// Stereo strips with KNOWN fractional disparities, made independently of the code under test: a random
// texture of sinusoids is box-integrated over each pixel analytically, in the left image at x and in
// the right image at the point that maps there for the chosen disparity field, then noise is added and
// it is quantised to 8 bits like a camera would. Shared by the CPU and GPU DIC tests.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <opencv2/core.hpp>

namespace rutd::known_disparity {

struct Wave {
  double kx, ky, phase, amplitude;
};

// Sum of random plane waves, wavelengths 4..20 px, about 40 grey levels RMS around 128.
inline std::vector<Wave> random_texture(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(0.0, 2.0 * CV_PI);
  std::uniform_real_distribution<double> wavelength(4.0, 20.0);
  std::vector<Wave> waves;
  const int count = 60;
  for (int i = 0; i < count; ++i) {
    const double k = 2.0 * CV_PI / wavelength(rng);
    const double dir = angle(rng);
    waves.push_back({k * std::cos(dir), k * std::sin(dir), angle(rng), 40.0 * std::sqrt(2.0 / count)});
  }
  return waves;
}

inline double sinc(double u) { return std::abs(u) < 1e-12 ? 1.0 : std::sin(u) / u; }

// Pixel (x, y) of a view in which texture coordinate s = scale * x + offset (rows unchanged): the
// texture integrated over the pixel's unit square, plus noise, quantised.
// offset_per_row shifts row y by offset_per_row * y more.
inline cv::Mat render(const std::vector<Wave>& waves, cv::Size size, double scale, double offset, double noise,
                      unsigned seed, double offset_per_row = 0.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, noise);
  cv::Mat image(size, CV_8UC1);
  for (int y = 0; y < size.height; ++y) {
    const double row_offset = offset + offset_per_row * y;
    for (int x = 0; x < size.width; ++x) {
      double v = 128.0;
      for (const Wave& w : waves) {
        const double kx = w.kx * scale;  // frequency along the view's x
        v += w.amplitude * std::sin(kx * x + w.kx * row_offset + w.ky * y + w.phase) * sinc(kx / 2) * sinc(w.ky / 2);
      }
      image.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(v + gauss(rng));
    }
  }
  return image;
}

// Disparity d(s) = d0 + slope * s at left pixel s. A right pixel x sees s - d(s) = x, i.e.
// s = (x + d0) / (1 - slope).
struct Pair {
  cv::Mat left, right;
};
// With slope_y, d = d0 + slope * s + slope_y * y (terrain sloping down the strip too).
inline Pair render_pair(double d0, double slope, cv::Size size, unsigned seed, double noise = 0.7,
                        double slope_y = 0.0) {
  const auto waves = random_texture(seed);
  return {render(waves, size, 1.0, 0.0, noise, seed + 1),
          render(waves, size, 1.0 / (1.0 - slope), d0 / (1.0 - slope), noise, seed + 2, slope_y / (1.0 - slope))};
}

struct Error {
  double mean = 0, rms = 0;
  int count = 0;
};

// Error of `disparity` against d0 + slope * x over the valid pixels with x >= x_min.
inline Error error_of(const cv::Mat& disparity, double d0, double slope, int x_min) {
  Error e;
  for (int y = 0; y < disparity.rows; ++y) {
    for (int x = x_min; x < disparity.cols; ++x) {
      const float d = disparity.at<float>(y, x);
      if (!std::isfinite(d)) continue;
      const double err = d - (d0 + slope * x);
      e.mean += err;
      e.rms += err * err;
      ++e.count;
    }
  }
  if (e.count > 0) {
    e.mean /= e.count;
    e.rms = std::sqrt(e.rms / e.count);
  }
  return e;
}

}  // namespace rutd::known_disparity
