// Rendered images of the synthetic renderer and the synthetic source: consistency with the calibration,
// world-fixed texture, determinism, texture contrast, sizes; render times are printed, not asserted.
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "core/io_faults.hpp"
#include "synthetic/synthetic_renderer.hpp"
#include "synthetic/synthetic_source.hpp"

namespace rutd {
namespace {

SyntheticRendererConfig quiet_params() {
  SyntheticRendererConfig p;
  p.noise_sigma = 0;
  p.full_well_e = 0;
  return p;
}

double mean_abs_diff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  return cv::mean(d)[0];
}

TEST(SyntheticRender, RightImageAgreesWithCalibrationAndGeometry) {
  const SyntheticRendererConfig p = quiet_params();
  const SyntheticRenderer renderer(p);
  StereoFrame frame;
  renderer.render(2, frame);
  const StereoCalibration& c = renderer.calibration();
  // For each left pixel of a central block: its 3D point, projected into the right image.
  const cv::Rect block(200, 150, 240, 180);
  cv::Mat map(block.size(), CV_32FC2);
  for (int v = 0; v < block.height; ++v) {
    for (int u = 0; u < block.width; ++u) {
      const auto hit = renderer.intersect_left(2, renderer.pixel_ray(Camera::Left, block.x + u, block.y + v));
      ASSERT_TRUE(hit.has_value());
      const cv::Vec3d in_right = c.R * *hit + c.T;
      std::vector<cv::Point3d> point{cv::Point3d(in_right[0], in_right[1], in_right[2])};
      std::vector<cv::Point2d> px;
      cv::projectPoints(point, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), c.M2, c.D2, px);
      map.at<cv::Vec2f>(v, u) = cv::Vec2f(static_cast<float>(px[0].x), static_cast<float>(px[0].y));
    }
  }
  // The warped right image matches the left one best at zero offset, better than half a pixel away.
  const cv::Mat left = frame.left(block);
  const auto error_at = [&](float dx, float dy) {
    cv::Mat moved = map + cv::Scalar(dx, dy), warped;
    cv::remap(frame.right, warped, moved, cv::noArray(), cv::INTER_CUBIC);
    return mean_abs_diff(left, warped);
  };
  const double at_zero = error_at(0, 0);
  std::printf("left vs warped right: %.2f grey levels;", at_zero);
  for (const cv::Point2f o :
       {cv::Point2f(0.5f, 0), cv::Point2f(-0.5f, 0), cv::Point2f(0, 0.5f), cv::Point2f(0, -0.5f)}) {
    const double off = error_at(o.x, o.y);
    std::printf(" (%+.1f, %+.1f) px off: %.2f;", o.x, o.y, off);
    EXPECT_LT(at_zero, 0.6 * off);
  }
  std::printf("\n");
}

TEST(SyntheticRender, TextureIsWorldFixed) {
  // Pinhole cameras over flat ground moving by exactly 7 pixel rows per frame: frame k+1 must be frame
  // k shifted by 7 rows (the camera's Y axis is world -y, so the scene moves to larger v).
  SyntheticRendererConfig p = quiet_params();
  p.rig.image_size = {320, 240};
  p.rig.distortion_left = p.rig.distortion_right = cv::Vec<double, 5>(0, 0, 0, 0, 0);
  p.rut.lateral_offset_mm = 5000;
  p.bit_depth = 16;
  const double f = 160 / std::tan(p.rig.hfov_deg / 2 * std::acos(-1.0) / 180);
  p.speed_mm_s = 7 * p.rig.height_mm / f * p.fps;
  const SyntheticRenderer renderer(p);
  StereoFrame a, b;
  renderer.render(40, a);
  renderer.render(41, b);
  const cv::Mat before = a.left(cv::Rect(0, 0, 320, 233)), after = b.left(cv::Rect(0, 7, 320, 233));
  double worst = 0;
  cv::minMaxLoc(cv::abs(cv::Mat_<double>(before) - cv::Mat_<double>(after)), nullptr, &worst);
  const double unshifted = mean_abs_diff(a.left, b.left);
  std::printf("shifted frames differ by at most %.0f of 65535; unshifted by %.0f on average\n", worst, unshifted);
  EXPECT_LE(worst, 2);
  EXPECT_GT(unshifted, 500);
}

// Anti-aliasing: a camera moved by half a pixel row must see the first image resampled half a row,
// which only holds when the image has no detail beyond what its pixels can carry. Returns the mean
// absolute difference between the moved image and the resampled one, in 8-bit grey levels, and the
// image's standard deviation in `contrast`.
double half_pixel_resampling_error(Texture texture, int supersample, bool band_limit, double& contrast) {
  SyntheticRendererConfig p = quiet_params();
  p.texture = texture;
  p.rig.image_size = {320, 240};
  p.rig.hfov_deg = 42;  // 0.84 mm per pixel at 350 mm, as a 640 px wide image at the default 75 degrees
  p.rig.distortion_left = p.rig.distortion_right = cv::Vec<double, 5>(0, 0, 0, 0, 0);
  p.rut.lateral_offset_mm = 5000;
  p.bit_depth = 16;
  p.supersample = supersample;
  p.band_limit = band_limit;
  const double f = 160 / std::tan(p.rig.hfov_deg / 2 * std::acos(-1.0) / 180);
  p.speed_mm_s = 0.5 * p.rig.height_mm / f * p.fps;  // half a pixel row per frame
  const SyntheticRenderer renderer(p);
  StereoFrame a, b;
  renderer.render(40, a);
  renderer.render(41, b);
  cv::Mat first, moved, resampled;
  a.left.convertTo(first, CV_32F, 1.0 / 257);
  b.left.convertTo(moved, CV_32F, 1.0 / 257);
  cv::Mat map(first.size(), CV_32FC2);
  for (int v = 0; v < map.rows; ++v) {
    for (int u = 0; u < map.cols; ++u) map.at<cv::Vec2f>(v, u) = cv::Vec2f(u, v - 0.5f);  // scene moves to +v
  }
  cv::remap(first, resampled, map, cv::noArray(), cv::INTER_CUBIC);
  const cv::Rect inner(8, 8, first.cols - 16, first.rows - 16);
  cv::Scalar mean, stddev;
  cv::meanStdDev(first(inner), mean, stddev);
  contrast = stddev[0];
  return mean_abs_diff(moved(inner), resampled(inner));
}

TEST(SyntheticRender, BandLimitedTextureAntiAliases) {
  for (Texture texture : {Texture::Sand, Texture::Grass}) {
    double contrast = 0, contrast_point = 0, contrast_3x3 = 0, contrast_2x2 = 0;
    const double filtered = half_pixel_resampling_error(texture, 1, true, contrast);  // the default
    const double filtered_2x2 = half_pixel_resampling_error(texture, 2, true, contrast_2x2);
    const double point = half_pixel_resampling_error(texture, 1, false, contrast_point);
    const double point_3x3 = half_pixel_resampling_error(texture, 3, false, contrast_3x3);
    std::printf(
        "%-5s half-pixel resampling error, grey levels (image std): band-limited 1x1 %.2f (%.1f), "
        "2x2 %.2f (%.1f); point-sampled 1x1 %.2f (%.1f), 3x3 %.2f (%.1f)\n",
        std::string(to_string(texture)).c_str(), filtered, contrast, filtered_2x2, contrast_2x2, point, contrast_point,
        point_3x3, contrast_3x3);
    EXPECT_LT(filtered, 0.5 * point);         // aliasing shows up as resampling error...
    EXPECT_LT(filtered, point_3x3);           // ...which 3x3 point samples reduce less than band-limiting
    EXPECT_LT(filtered, 0.15 * contrast);     // and is small against the contrast (3x3 point: 0.18)
    EXPECT_GT(contrast, 0.7 * contrast_3x3);  // without washing the texture out
  }
}

TEST(SyntheticRender, SilhouettesAreSupersampled) {
  // Tall piles hide part of the wall behind them; the silhouette pixels of a one-sample render differ
  // from a densely supersampled reference, far less so with edge supersampling. Snow: its faint texture
  // keeps the differences away from the silhouettes small.
  SyntheticRendererConfig p = quiet_params();
  p.texture = Texture::Snow;
  p.rig.image_size = {320, 240};
  p.rig.roll_deg = 8;
  p.rut.pile_left_mm = p.rut.pile_right_mm = 35;
  p.rut.pile_width_mm = 30;
  const auto render = [&](int supersample, int edge) {
    SyntheticRendererConfig q = p;
    q.supersample = supersample;
    q.edge_supersample = edge;
    StereoFrame frame;
    SyntheticRenderer(q).render(0, frame);
    cv::Mat left;
    frame.left.convertTo(left, CV_32F);
    return left;
  };
  const cv::Mat reference = render(6, 1), plain = render(1, 1), edges = render(1, 3);
  const cv::Mat plain_error = cv::abs(plain - reference), edge_error = cv::abs(edges - reference);
  // Silhouette pixels found from the geometry, independently of the images: the distances to the
  // surface seen through the pixel's corners differ by more than 5 mm (a pile in front of the wall).
  const SyntheticRenderer geometry(p);
  cv::Mat silhouette(reference.size(), CV_8U, cv::Scalar(0));
  for (int v = 0; v < silhouette.rows; ++v) {
    for (int u = 0; u < silhouette.cols; ++u) {
      double lo = 1e9, hi = -1e9;
      for (const double du : {-0.5, 0.5}) {
        for (const double dv : {-0.5, 0.5}) {
          const auto hit = geometry.intersect_left(0, geometry.pixel_ray(Camera::Left, u, v, du, dv));
          const double z = hit ? (*hit)[2] : 1e9;
          lo = std::min(lo, z);
          hi = std::max(hi, z);
        }
      }
      silhouette.at<std::uint8_t>(v, u) = hi - lo > 5.0 ? 255 : 0;
    }
  }
  const int count = cv::countNonZero(silhouette);
  const double plain_mean = cv::mean(plain_error, silhouette)[0], edge_mean = cv::mean(edge_error, silhouette)[0];
  std::printf(
      "%d silhouette pixels: error against 6x6 samples %.1f grey levels with 1 sample, %.1f with 3x3 at edges\n", count,
      plain_mean, edge_mean);
  EXPECT_GT(count, 20);  // the scene has silhouettes
  EXPECT_LT(edge_mean, 0.5 * plain_mean);
}

TEST(SyntheticRender, DeterministicPerSeedFrameAndCamera) {
  SyntheticRendererConfig p;
  p.rig.image_size = {160, 120};
  p.speed_mm_s = 0;  // same scene every frame: only the noise changes
  StereoFrame a, b, c, d;
  SyntheticRenderer(p).render(3, a);
  SyntheticRenderer(p).render(3, b);
  EXPECT_EQ(cv::norm(a.left, b.left, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a.right, b.right, cv::NORM_INF), 0);
  SyntheticRenderer(p).render(4, c);
  const double noise = mean_abs_diff(a.left, c.left);
  std::printf("frame-to-frame noise difference %.2f grey levels\n", noise);
  EXPECT_GT(noise, 0.5);  // fresh noise per frame...
  EXPECT_LT(noise, 5.0);  // ...on the same scene
  p.seed = 2;
  SyntheticRenderer(p).render(3, d);
  EXPECT_GT(mean_abs_diff(a.left, d.left), 5.0);  // another seed, another texture
}

TEST(SyntheticRender, SnowHasMuchLessContrastThanSand) {
  double stddev[4], mean[4];
  for (Texture texture : {Texture::Sand, Texture::Mud, Texture::Snow, Texture::Grass}) {
    SyntheticRendererConfig p = quiet_params();
    p.texture = texture;
    p.rut.lateral_offset_mm = 5000;  // texture only, no shading of walls
    StereoFrame frame;
    SyntheticRenderer(p).render(0, frame);
    cv::Scalar m, s;
    cv::meanStdDev(frame.left, m, s);
    const int i = static_cast<int>(texture);
    mean[i] = m[0], stddev[i] = s[0];
    std::printf("%-5s mean %6.1f std %5.2f grey levels\n", std::string(to_string(texture)).c_str(), m[0], s[0]);
  }
  EXPECT_LT(stddev[2], stddev[0] / 4);
  EXPECT_GT(mean[2], mean[0]);  // snow is bright
  EXPECT_LT(mean[1], mean[0]);  // mud is dark
  EXPECT_GT(stddev[3], 5);      // grass has structure
}

TEST(SyntheticRender, RendersBothSizesAndReportsTimes) {
  StereoFrame frame;
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(1280, 1024)}) {
    SyntheticRendererConfig p;
    p.rig.image_size = size;
    const SyntheticRenderer renderer(p);
    double best_ms = 1e30, cpu_ms = 0;  // wall: best of 3 (a shared machine); CPU: the mean
    for (int i = 0; i < 3; ++i) {
      const std::clock_t cpu_start = std::clock();
      const auto start = std::chrono::steady_clock::now();
      renderer.render(1, frame);
      best_ms = std::min(best_ms,
                         std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
      cpu_ms += 1000.0 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC / 3;
    }
    double load[1] = {0};
    getloadavg(load, 1);
    std::printf("render %dx%d pair: %.0f ms wall (best of 3), %.0f ms CPU, %d threads, load average %.2f\n", size.width,
                size.height, best_ms, cpu_ms, cv::getNumThreads(), load[0]);
    EXPECT_EQ(frame.left.size(), size);
    EXPECT_EQ(frame.right.type(), CV_8UC1);
    EXPECT_EQ(frame.seq, 1u);
    EXPECT_EQ(frame.t_ns, std::llround(1e9 / p.fps));
    const double mean = cv::mean(frame.right)[0];
    EXPECT_GT(mean, 60);
    EXPECT_LT(mean, 200);
  }
  // A frame that already fits is refilled in place.
  SyntheticRendererConfig p;
  p.rig.image_size = {1280, 1024};
  p.supersample = 1;
  const uchar* left = frame.left.data;
  const uchar* right = frame.right.data;
  SyntheticRenderer(p).render(2, frame);
  EXPECT_EQ(frame.left.data, left);
  EXPECT_EQ(frame.right.data, right);
}

TEST(SyntheticSource, ProducesTheRenderersFramesInSequence) {
  SyntheticRendererConfig p;
  p.rig.image_size = {96, 64};
  SyntheticSource source(p, {.paced = false, .first_index = 5, .frame_count = 3});
  const SyntheticRenderer reference(p);
  StereoFrame frame, expected;
  for (std::uint64_t i = 5; i < 8; ++i) {
    ASSERT_EQ(source.next(frame), SourceStatus::Ok);
    EXPECT_EQ(frame.seq, i);
    reference.render(i, expected);
    EXPECT_EQ(frame.t_ns, expected.t_ns);
    EXPECT_EQ(cv::norm(frame.left, expected.left, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(frame.right, expected.right, cv::NORM_INF), 0);
  }
  EXPECT_EQ(source.next(frame), SourceStatus::EndOfStream);
  EXPECT_TRUE(source.error_message().empty());
  EXPECT_EQ(source.calibration().M1, reference.calibration().M1);
}

TEST(SyntheticSource, PacedFramesCarryIncreasingMonotonicTimes) {
  SyntheticRendererConfig p;
  p.rig.image_size = {64, 48};
  p.fps = 100;
  SyntheticSource source(p);
  StereoFrame frame;
  std::int64_t last = 0;
  for (int i = 0; i < 4; ++i) {
    ASSERT_EQ(source.next(frame), SourceStatus::Ok);
    EXPECT_EQ(frame.seq, static_cast<std::uint64_t>(i));
    EXPECT_EQ(frame.clock, ClockKind::Monotonic);
    EXPECT_GT(frame.t_ns, last);
    last = frame.t_ns;
  }
}

// The live renderer under camera-pop faults (tests' fault injection): every third pop a corrupt buffer,
// then timeouts. A lost pop loses that period's pair (its index is skipped, as a camera's frame would
// be); the pairs delivered are still exactly the renderer's pairs for their index.
TEST(SyntheticSource, CameraPopFaultsLoseThatPeriodsPair) {
  SyntheticRendererConfig p;
  p.rig.image_size = {96, 64};
  const SyntheticRenderer reference(p);
  StereoFrame frame, expected;
  for (const int fault : {io_fault::kCorrupt, io_fault::kShort, EIO, io_fault::kTimeout}) {
    SCOPED_TRACE(fault);
    IoFaults faults;
    faults.set(IoPoint::CameraPop, {.fault = fault, .every = 3});
    SyntheticSource source(p, {.paced = false, .first_index = 0, .frame_count = 9}, &faults);
    int ok = 0, failed = 0;
    for (std::uint64_t i = 0; i < 9; ++i) {
      const SourceStatus status = source.next(frame);
      if (i % 3 == 2) {
        ++failed;
        EXPECT_EQ(status, fault == io_fault::kTimeout ? SourceStatus::Timeout : SourceStatus::Error);
        if (fault != io_fault::kTimeout) {
          EXPECT_NE(source.error_message().find("synthetic camera: "), std::string::npos);
        }
        continue;
      }
      ++ok;
      ASSERT_EQ(status, SourceStatus::Ok);
      EXPECT_TRUE(source.error_message().empty());
      EXPECT_EQ(frame.seq, i);
      reference.render(i, expected);
      EXPECT_EQ(cv::norm(frame.left, expected.left, cv::NORM_INF), 0);
    }
    EXPECT_EQ(ok, 6);
    EXPECT_EQ(failed, 3);
    EXPECT_EQ(faults.injected(IoPoint::CameraPop), 3u);
    EXPECT_EQ(source.next(frame), SourceStatus::EndOfStream);
  }
}

}  // namespace
}  // namespace rutd
