// Depth readings read together (measurement/depth_readings.hpp) against draws whose truth is known: each
// reading is the truth plus a part shared by all (the rut's shape: the same z for every reading of a
// draw, scaled by its systematic_mm) and noise of its own. The mean's u must describe its error over many
// draws (neither smaller nor larger); readings that disagree, or too few or too many, are not combined.
#include <array>
#include <cmath>
#include <random>
#include <span>

#include <gtest/gtest.h>

#include "measurement/depth_readings.hpp"

namespace rutd {
namespace {

struct Coverage {
  int draws = 0, combined = 0;
  double rms_error_over_u = 0.0;  // root mean square of (mean - truth) / u over the combined draws
};

// `draws` draws of the readings u and s given (mm) around a truth of 50 mm.
template <std::size_t K>
Coverage draw(const std::array<double, K>& u, const std::array<double, K>& s, int draws, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  constexpr double kTruth = 50.0;
  Coverage c;
  double sum = 0.0;
  for (int d = 0; d < draws; ++d) {
    const double shared = n01(rng);
    std::array<DepthReading, K> r;
    for (std::size_t i = 0; i < K; ++i)
      r[i] = {kTruth + s[i] * shared + std::sqrt(u[i] * u[i] - s[i] * s[i]) * n01(rng), u[i], s[i]};
    ++c.draws;
    const auto mean = combine_depth_readings(r);
    if (!mean) continue;
    ++c.combined;
    EXPECT_GE(mean->systematic_mm, 0.0);
    EXPECT_LE(mean->systematic_mm, mean->u_mm);
    sum += std::pow((mean->depth_mm - kTruth) / mean->u_mm, 2);
  }
  c.rms_error_over_u = c.combined > 0 ? std::sqrt(sum / c.combined) : 0.0;
  return c;
}

// Noise alone: the classic weighted mean, u = 1 / sqrt(sum of 1/u^2), describes its error.
TEST(DepthReadings, NoiseAloneAveragesOut) {
  const Coverage c = draw<3>({0.6, 0.5, 0.7}, {0.0, 0.0, 0.0}, 20000, 1);
  EXPECT_EQ(c.draws, 20000);
  EXPECT_GE(c.combined, 18800);  // the chi-square test refuses about 5 %
  EXPECT_NEAR(c.rms_error_over_u, 1.0, 0.1);
}

// Mostly the shape's part: three strips over the same gap share it, and their mean is hardly better
// than one. Taken as noise (u = 1 / sqrt(sum of 1/u^2), 0.34 mm here) the mean's error would be 1.45 of
// its u, and a frame 2 mm off would be published at u 0.6 where one 1.2 mm off would.
TEST(DepthReadings, TheShapesPartDoesNotAverageOut) {
  const Coverage c = draw<3>({0.6, 0.5, 0.7}, {0.45, 0.4, 0.5}, 20000, 2);
  EXPECT_EQ(c.draws, 20000);
  EXPECT_GE(c.combined, 18800);
  EXPECT_NEAR(c.rms_error_over_u, 1.0, 0.1);
}

// Strips and frames of every kind: one without a gap (s = 0) and the rest with parts of it, up to seven.
TEST(DepthReadings, MixedReadingsKeepTheirCoverage) {
  const Coverage c = draw<7>({0.5, 0.6, 0.9, 0.4, 0.7, 0.55, 1.2}, {0.0, 0.3, 0.8, 0.1, 0.5, 0.0, 0.6}, 20000, 3);
  EXPECT_EQ(c.draws, 20000);
  EXPECT_GE(c.combined, 17000);
  EXPECT_NEAR(c.rms_error_over_u, 1.0, 0.1);
}

// The mean leans on the reading without a shape's part, and so does its systematic part.
TEST(DepthReadings, AReadingWithoutAGapCarriesTheMean) {
  const std::array<DepthReading, 2> r = {DepthReading{50.0, 0.5, 0.0}, DepthReading{50.4, 0.5, 0.48}};
  const auto mean = combine_depth_readings(r);
  ASSERT_TRUE(mean);
  EXPECT_DOUBLE_EQ(mean->depth_mm, 50.2);
  EXPECT_DOUBLE_EQ(mean->systematic_mm, 0.24);
  // The noise parts (0.25 and 0.25 - 0.48^2 mm^2) at weights of a half each, and the shared part, 0.24.
  EXPECT_NEAR(mean->u_mm, std::sqrt((0.25 + (0.25 - 0.48 * 0.48)) / 4.0 + 0.24 * 0.24), 1e-12);
}

TEST(DepthReadings, DisagreeingTooFewOrTooManyOrInvalidAreNotCombined) {
  // 3 u apart: chi-square 4.5 over 1 degree of freedom, beyond its 95th percentile (3.84).
  EXPECT_FALSE(combine_depth_readings(std::array{DepthReading{50.0, 0.5, 0.0}, DepthReading{52.12, 0.5, 0.0}}));
  EXPECT_TRUE(combine_depth_readings(std::array{DepthReading{50.0, 0.5, 0.0}, DepthReading{51.3, 0.5, 0.0}}));
  EXPECT_FALSE(combine_depth_readings(std::array{DepthReading{50.0, 0.5, 0.0}}));
  std::array<DepthReading, 8> eight;
  eight.fill(DepthReading{50.0, 0.5, 0.0});
  EXPECT_FALSE(combine_depth_readings(eight));
  EXPECT_TRUE(combine_depth_readings(std::span(eight).first(7)));
  for (double bad : {0.0, -0.5, std::nan(""), HUGE_VAL})
    EXPECT_FALSE(combine_depth_readings(std::array{DepthReading{50.0, 0.5, 0.0}, DepthReading{50.0, bad, 0.0}})) << bad;
  // A systematic part beyond u counts as u.
  const auto capped = combine_depth_readings(std::array{DepthReading{50.0, 0.5, 2.0}, DepthReading{50.0, 0.5, 2.0}});
  ASSERT_TRUE(capped);
  EXPECT_DOUBLE_EQ(capped->systematic_mm, 0.5);
  EXPECT_DOUBLE_EQ(capped->u_mm, 0.5);
}

}  // namespace
}  // namespace rutd
