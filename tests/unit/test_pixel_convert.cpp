// Camera pixel conversion against independent truths: Bayer images are mosaicked by hand from a colour
// image following GenICam's pattern definitions and must come back close to OpenCV's BGR-to-grey of that
// image (and clearly further from it under any other pattern); mono images must be copied byte for byte.
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <random>
#include <string_view>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "pixel_convert.hpp"

namespace rutd {
namespace {

constexpr std::array kBayerLayouts{CameraPixelLayout::BayerRG8, CameraPixelLayout::BayerGR8,
                                   CameraPixelLayout::BayerBG8, CameraPixelLayout::BayerGB8};
constexpr std::array kAllLayouts{CameraPixelLayout::Mono8,    CameraPixelLayout::Mono10,   CameraPixelLayout::Mono12,
                                 CameraPixelLayout::Mono16,   CameraPixelLayout::BayerRG8, CameraPixelLayout::BayerGR8,
                                 CameraPixelLayout::BayerBG8, CameraPixelLayout::BayerGB8};

// GenICam PFNC: the colour of each pixel of the top-left 2x2 tile, read row by row.
std::string_view genicam_tile(CameraPixelLayout layout) {
  switch (layout) {
    case CameraPixelLayout::BayerRG8: return "RGGB";
    case CameraPixelLayout::BayerGR8: return "GRBG";
    case CameraPixelLayout::BayerBG8: return "BGGR";
    case CameraPixelLayout::BayerGB8: return "GBRG";
    default: return "";
  }
}

// A smooth image whose three channels vary independently (periods of 150-230 px), so it is strongly
// coloured everywhere: R, G and B differ by up to 200 levels.
cv::Mat colour_image(int width, int height) {
  cv::Mat bgr(height, width, CV_8UC3);
  const double two_pi = 2.0 * std::numbers::pi;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double b = 128 + 110 * std::sin(two_pi * (x / 160.0 + y / 230.0));
      const double g = 128 + 110 * std::sin(two_pi * (x / 190.0 - y / 170.0) + 1.3);
      const double r = 128 + 110 * std::sin(two_pi * (x / 210.0 + y / 150.0) + 2.6);
      bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<std::uint8_t>(b), cv::saturate_cast<std::uint8_t>(g),
                                          cv::saturate_cast<std::uint8_t>(r));
    }
  }
  return bgr;
}

// What a colour-filter-array sensor with `layout` records of `bgr`: one channel per pixel.
cv::Mat mosaic(const cv::Mat& bgr, CameraPixelLayout layout) {
  const std::string_view tile = genicam_tile(layout);
  cv::Mat raw(bgr.size(), CV_8UC1);
  for (int y = 0; y < bgr.rows; ++y) {
    for (int x = 0; x < bgr.cols; ++x) {
      const char colour = tile[static_cast<std::size_t>((y % 2) * 2 + (x % 2))];
      const int channel = colour == 'B' ? 0 : colour == 'G' ? 1 : 2;
      raw.at<std::uint8_t>(y, x) = bgr.at<cv::Vec3b>(y, x)[channel];
    }
  }
  return raw;
}

// Mean absolute difference over the image less a 2-pixel border (where demosaicing extrapolates).
double mean_abs_error(const cv::Mat& a, const cv::Mat& b) {
  const cv::Rect inner(2, 2, a.cols - 4, a.rows - 4);
  cv::Mat diff;
  cv::absdiff(a(inner), b(inner), diff);
  return cv::mean(diff)[0];
}

std::size_t frame_bytes(const cv::Mat& m) { return m.total() * m.elemSize(); }

TEST(PixelConvert, BayerPatternsMatchGreyOfTheColourImage) {
  const cv::Mat bgr = colour_image(640, 480);
  cv::Mat truth;
  cv::cvtColor(bgr, truth, cv::COLOR_BGR2GRAY);

  for (const CameraPixelLayout layout : kBayerLayouts) {
    const cv::Mat raw = mosaic(bgr, layout);
    cv::Mat grey;
    ASSERT_TRUE(convert_to_grey(layout, raw.data, frame_bytes(raw), raw.cols, raw.rows, grey));
    ASSERT_EQ(grey.type(), CV_8UC1);
    ASSERT_EQ(grey.size(), bgr.size());
    const double right = mean_abs_error(grey, truth);
    std::printf("%s: mean abs error %.2f grey levels\n", pixel_layout_name(layout).data(), right);
    EXPECT_LT(right, 2.0) << pixel_layout_name(layout);

    // Reading the same raw image with any other pattern must be clearly worse, so a swapped mapping
    // cannot pass.
    for (const CameraPixelLayout other : kBayerLayouts) {
      if (other == layout) continue;
      cv::Mat wrong;
      ASSERT_TRUE(convert_to_grey(other, raw.data, frame_bytes(raw), raw.cols, raw.rows, wrong));
      const double error = mean_abs_error(wrong, truth);
      std::printf("  read as %s: mean abs error %.2f\n", pixel_layout_name(other).data(), error);
      EXPECT_GT(error, 5.0) << pixel_layout_name(layout) << " read as " << pixel_layout_name(other);
      EXPECT_GT(error, 4.0 * right) << pixel_layout_name(layout) << " read as " << pixel_layout_name(other);
    }
  }
}

TEST(PixelConvert, Mono8IsAByteExactCopyWithOddWidth) {
  constexpr int kWidth = 641;
  constexpr int kHeight = 3;
  std::mt19937 rng(7);
  std::vector<std::uint8_t> raw(kWidth * kHeight);
  for (auto& v : raw) v = static_cast<std::uint8_t>(rng());

  cv::Mat out;
  ASSERT_TRUE(convert_to_grey(CameraPixelLayout::Mono8, raw.data(), raw.size(), kWidth, kHeight, out));
  ASSERT_EQ(out.type(), CV_8UC1);
  ASSERT_EQ(out.cols, kWidth);
  ASSERT_EQ(out.rows, kHeight);
  for (int y = 0; y < kHeight; ++y) {
    EXPECT_EQ(std::memcmp(out.ptr(y), raw.data() + y * kWidth, kWidth), 0) << "row " << y;
  }
}

TEST(PixelConvert, SixteenBitLayoutsKeepTheCameraValues) {
  constexpr int kWidth = 641;
  constexpr int kHeight = 3;
  const std::array<std::pair<CameraPixelLayout, unsigned>, 3> cases{
      {{CameraPixelLayout::Mono10, 1023U}, {CameraPixelLayout::Mono12, 4095U}, {CameraPixelLayout::Mono16, 65535U}}};
  std::mt19937 rng(11);
  for (const auto& [layout, max_value] : cases) {
    // The camera's little-endian words, written byte by byte.
    std::vector<std::uint8_t> raw(static_cast<std::size_t>(kWidth * kHeight * 2));
    std::vector<std::uint16_t> values(static_cast<std::size_t>(kWidth * kHeight));
    for (std::size_t i = 0; i < values.size(); ++i) {
      values[i] = static_cast<std::uint16_t>(rng() % (max_value + 1));
      raw[2 * i] = static_cast<std::uint8_t>(values[i] & 0xFF);
      raw[2 * i + 1] = static_cast<std::uint8_t>(values[i] >> 8);
    }
    cv::Mat out;
    ASSERT_TRUE(convert_to_grey(layout, raw.data(), raw.size(), kWidth, kHeight, out));
    ASSERT_EQ(out.type(), CV_16UC1) << pixel_layout_name(layout);
    ASSERT_EQ(out.size(), cv::Size(kWidth, kHeight));
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        ASSERT_EQ(out.at<std::uint16_t>(y, x), values[static_cast<std::size_t>(y * kWidth + x)])
            << pixel_layout_name(layout) << " at " << x << "," << y;
      }
    }
  }
}

TEST(PixelConvert, TooFewBytesOrBadSizeIsRefused) {
  std::vector<std::uint8_t> raw(64 * 48 * 2, 0x55);
  for (const CameraPixelLayout layout : kAllLayouts) {
    const std::size_t need = 64 * 48 * bytes_per_pixel(layout);
    cv::Mat out;
    EXPECT_TRUE(convert_to_grey(layout, raw.data(), need, 64, 48, out)) << pixel_layout_name(layout);
    EXPECT_FALSE(convert_to_grey(layout, raw.data(), need - 1, 64, 48, out)) << pixel_layout_name(layout);
    EXPECT_FALSE(convert_to_grey(layout, raw.data(), 0, 64, 48, out)) << pixel_layout_name(layout);
    EXPECT_FALSE(convert_to_grey(layout, raw.data(), need, 0, 48, out)) << pixel_layout_name(layout);
    EXPECT_FALSE(convert_to_grey(layout, raw.data(), need, 64, -1, out)) << pixel_layout_name(layout);
    EXPECT_FALSE(convert_to_grey(layout, nullptr, need, 64, 48, out)) << pixel_layout_name(layout);
  }
  cv::Mat out;
  EXPECT_FALSE(convert_to_grey(CameraPixelLayout::BayerRG8, raw.data(), raw.size(), 1, 48, out));
  EXPECT_TRUE(convert_to_grey(CameraPixelLayout::Mono8, raw.data(), raw.size(), 1, 48, out));
}

TEST(PixelConvert, ReusesTheOutputBuffer) {
  const cv::Mat bgr = colour_image(320, 240);
  const cv::Mat bayer = mosaic(bgr, CameraPixelLayout::BayerGB8);
  std::vector<std::uint8_t> mono16(320 * 240 * 2);
  for (std::size_t i = 0; i < mono16.size(); ++i) mono16[i] = static_cast<std::uint8_t>(i * 31);

  const std::array<std::pair<CameraPixelLayout, const void*>, 3> cases{{{CameraPixelLayout::Mono8, bayer.data},
                                                                        {CameraPixelLayout::BayerGB8, bayer.data},
                                                                        {CameraPixelLayout::Mono16, mono16.data()}}};
  for (const auto& [layout, data] : cases) {
    const std::size_t bytes = 320 * 240 * bytes_per_pixel(layout);
    cv::Mat out(10, 10, CV_32FC1);  // wrong size and type: replaced on the first call
    ASSERT_TRUE(convert_to_grey(layout, data, bytes, 320, 240, out));
    const std::uint8_t* first = out.data;
    const cv::Mat copy = out.clone();
    out.setTo(0);
    ASSERT_TRUE(convert_to_grey(layout, data, bytes, 320, 240, out));
    EXPECT_EQ(out.data, first) << pixel_layout_name(layout) << ": reallocated on the second call";
    EXPECT_EQ(cv::norm(out, copy, cv::NORM_INF), 0.0) << pixel_layout_name(layout);
  }
}

TEST(PixelConvert, WritesIntoANonContinuousOutputInPlace) {
  constexpr int kWidth = 641;
  constexpr int kHeight = 3;
  std::vector<std::uint8_t> raw(kWidth * kHeight);
  for (std::size_t i = 0; i < raw.size(); ++i) raw[i] = static_cast<std::uint8_t>(i * 13 + 1);
  cv::Mat parent(kHeight + 2, kWidth + 9, CV_8UC1, cv::Scalar(0));
  cv::Mat out = parent(cv::Rect(4, 1, kWidth, kHeight));  // size and type fit: written in place
  ASSERT_FALSE(out.isContinuous());
  const std::uint8_t* where = out.data;
  ASSERT_TRUE(convert_to_grey(CameraPixelLayout::Mono8, raw.data(), raw.size(), kWidth, kHeight, out));
  EXPECT_EQ(out.data, where);
  for (int y = 0; y < kHeight; ++y) {
    EXPECT_EQ(std::memcmp(parent.ptr(y + 1) + 4, raw.data() + y * kWidth, kWidth), 0) << "row " << y;
  }
  EXPECT_EQ(parent.at<std::uint8_t>(0, 4), 0);  // nothing outside the region touched
  EXPECT_EQ(parent.at<std::uint8_t>(1, 3), 0);
  EXPECT_EQ(parent.at<std::uint8_t>(1, 4 + kWidth), 0);
}

TEST(PixelConvert, LayoutNamesFollowGenicam) {
  const std::array<std::pair<std::string_view, CameraPixelLayout>, 8> names{{
      {"Mono8", CameraPixelLayout::Mono8},
      {"Mono10", CameraPixelLayout::Mono10},
      {"Mono12", CameraPixelLayout::Mono12},
      {"Mono16", CameraPixelLayout::Mono16},
      {"BayerRG8", CameraPixelLayout::BayerRG8},
      {"BayerGR8", CameraPixelLayout::BayerGR8},
      {"BayerBG8", CameraPixelLayout::BayerBG8},
      {"BayerGB8", CameraPixelLayout::BayerGB8},
  }};
  for (const auto& [name, layout] : names) {
    EXPECT_EQ(pixel_layout_from_name(name), layout) << name;
    EXPECT_EQ(pixel_layout_name(layout), name);
  }
  for (const std::string_view other :
       {"", "mono8", "Mono8 ", "Mono10p", "Mono12Packed", "BayerRG10", "RGB8", "BayerRGGB8"}) {
    EXPECT_FALSE(pixel_layout_from_name(other).has_value()) << "'" << other << "'";
  }
  EXPECT_EQ(bytes_per_pixel(CameraPixelLayout::Mono8), 1U);
  EXPECT_EQ(bytes_per_pixel(CameraPixelLayout::Mono12), 2U);
  EXPECT_EQ(bytes_per_pixel(CameraPixelLayout::BayerBG8), 1U);
}

// Not a pass/fail figure: the cost of one 640x480 frame, printed for the record.
TEST(PixelConvert, PrintsConversionCost) {
  const cv::Mat bgr = colour_image(640, 480);
  const cv::Mat bayer = mosaic(bgr, CameraPixelLayout::BayerRG8);
  for (const CameraPixelLayout layout : {CameraPixelLayout::BayerRG8, CameraPixelLayout::Mono8}) {
    cv::Mat out;
    ASSERT_TRUE(convert_to_grey(layout, bayer.data, frame_bytes(bayer), 640, 480, out));
    constexpr int kFrames = 300;
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < kFrames; ++i) {
      ASSERT_TRUE(convert_to_grey(layout, bayer.data, frame_bytes(bayer), 640, 480, out));
    }
    const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
    std::printf("%s 640x480 to grey: %.1f us per frame (mean of %d)\n", pixel_layout_name(layout).data(), us / kFrames,
                kFrames);
  }
}

}  // namespace
}  // namespace rutd
