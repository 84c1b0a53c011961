// The PNG plots, read back with OpenCV: size, content, and on the cross-section the ground line and the
// deepest point drawn at the pixels computed from the measurement and the plot's axis mapping. The plot
// sink: never blocks, drops and counts when its plot thread is behind, counts write errors.
#include <chrono>
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "measured_pair.hpp"
#include "measurement/measurer.hpp"
#include "plots/plot_sink.hpp"
#include "plots/plots.hpp"
#include "synthetic/synthetic_renderer.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;

// A tilted ground Z = 400 + 0.05 X with a 40 mm raised-cosine rut (flat bottom 60 mm wide, opening 160 mm)
// centred at X = 20, and 10 mm piles beside it; 1 mm bins from -250 to 250 mm.
CrossSection tilted_rut() {
  CrossSection s;
  s.x0_mm = -250;
  s.dx_mm = 1;
  for (int i = 0; i <= 500; ++i) {
    const double x = -250 + i, t = std::abs(x - 20);
    double h = 0;  // above the ground, mm
    if (t <= 30) h = -40;
    else if (t <= 80) h = -40 * 0.5 * (1 + std::cos(M_PI * (t - 30) / 50));
    else if (t <= 120) h = 10 * std::pow(std::sin(M_PI * (t - 80) / 40), 2);
    // Heights are perpendicular to the ground line; Z grows away from the camera.
    s.z_mm.push_back(400 + 0.05 * x - h * std::sqrt(1 + 0.05 * 0.05));
    s.count.push_back(10);
  }
  return s;
}

double colour_distance(const cv::Vec3b& p, const cv::Scalar& c) {
  return std::sqrt(std::pow(p[0] - c[0], 2) + std::pow(p[1] - c[1], 2) + std::pow(p[2] - c[2], 2));
}

// Whether a pixel within `radius` of (x, y) has colour c (within anti-aliasing tolerance).
bool colour_near(const cv::Mat& img, cv::Point2d at, const cv::Scalar& c, int radius, double tol = 60) {
  for (int dy = -radius; dy <= radius; ++dy)
    for (int dx = -radius; dx <= radius; ++dx) {
      const int x = static_cast<int>(std::lround(at.x)) + dx, y = static_cast<int>(std::lround(at.y)) + dy;
      if (x >= 0 && y >= 0 && x < img.cols && y < img.rows && colour_distance(img.at<cv::Vec3b>(y, x), c) < tol)
        return true;
    }
  return false;
}

int non_white(const cv::Mat& img) {
  int n = 0;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) n += img.at<cv::Vec3b>(y, x) != cv::Vec3b(255, 255, 255);
  return n;
}

TEST(Plots, CrossSectionShowsGroundLineAndDeepestPointWhereMeasured) {
  const CrossSection s = tilted_rut();
  RutWorkspace ws;
  const RutMeasurement m = extract_rut(s, RutConfig{}, ws);
  ASSERT_EQ(m.status, RutStatus::Ok);
  const RutGeometry& g = ws.geometry;
  ASSERT_TRUE(g.has_line && g.has_rut);
  // The geometry against the profile's own truth: ground 400 + 0.05 X, bottom 40 mm below it near X = 20.
  EXPECT_NEAR(g.line_m, 0.05, 0.002);
  EXPECT_NEAR(g.line_c, 400, 0.5);
  EXPECT_NEAR(g.deepest_x_mm, 20, 31);
  EXPECT_NEAR(m.depth_mm, 40, 0.5);
  EXPECT_NEAR(g.left_pile_x_mm, -80, 10);
  EXPECT_NEAR(g.right_pile_x_mm, 120, 10);

  test::TempDir tmp;
  const std::string path = (tmp.path() / "section.png").string();
  PlotAxes axes;
  const PlotResult r = plot_cross_section(path, s, m, g, "test", cv::Size(1000, 600), &axes);
  ASSERT_TRUE(r.ok) << r.error;
  const cv::Mat img = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_EQ(img.size(), cv::Size(1000, 600));
  EXPECT_GT(non_white(img), 10000);
  // The axis mapping is the plot frame: box edges at the area's left and bottom sides (a 1 px black line
  // anti-aliased over two pixels: mid grey).
  const cv::Scalar black(0, 0, 0);
  for (double f : {0.2, 0.5, 0.8}) {
    EXPECT_TRUE(colour_near(img, {axes.area_px.x, axes.area_px.y + f * axes.area_px.height}, black, 1, 240)) << f;
    EXPECT_TRUE(colour_near(img, {axes.area_px.x + f * axes.area_px.width, axes.area_px.br().y}, black, 1, 240)) << f;
  }
  // The ground line at X positions across the whole section, and not 12 px away from where it should be.
  for (double x : {-240.0, -200.0, -150.0, 0.0, 150.0, 200.0, 240.0}) {
    const cv::Point2d p = axes.to_pixel(x, 0.05 * x + 400);
    EXPECT_TRUE(colour_near(img, p, kPlotGroundLineBgr, 2)) << "ground line at X = " << x << ", pixel " << p;
    EXPECT_FALSE(colour_near(img, p + cv::Point2d(0, 12), kPlotGroundLineBgr, 2)) << x;
    EXPECT_FALSE(colour_near(img, p - cv::Point2d(0, 12), kPlotGroundLineBgr, 2)) << x;
  }
  // The deepest point: depth below the line, perpendicular to it, at the deepest X.
  const double zd = g.line_m * g.deepest_x_mm + g.line_c + m.depth_mm * std::sqrt(1 + g.line_m * g.line_m);
  const cv::Point2d deepest = axes.to_pixel(g.deepest_x_mm, zd);
  // A filled disc of radius 6 px there: red at its centre and 4 px to either side (the dashed depth line
  // above it is vertical and thin, so only the disc is red beside the centre), and not red 10 px out.
  for (double dx : {-4.0, 0.0, 4.0})
    EXPECT_TRUE(colour_near(img, deepest + cv::Point2d(dx, 0), kPlotDeepestBgr, 0)) << deepest << " " << dx;
  for (double dx : {-10.0, 10.0})
    EXPECT_FALSE(colour_near(img, deepest + cv::Point2d(dx, 0), kPlotDeepestBgr, 1, 80)) << deepest << " " << dx;
  // Pile tops (green triangles) above the ground line.
  const double norm = std::sqrt(1 + g.line_m * g.line_m);
  EXPECT_TRUE(
      colour_near(img, axes.to_pixel(g.left_pile_x_mm, g.line_m * g.left_pile_x_mm + g.line_c - m.left_pile_mm * norm),
                  kPlotPileBgr, 2));
}

TEST(Plots, DisparitySeriesAndOverlayHaveTheirSizeAndContent) {
  test::TempDir tmp;
  cv::Mat d(48, 320, CV_32FC1);
  for (int r = 0; r < d.rows; ++r)
    for (int c = 0; c < d.cols; ++c) d.at<float>(r, c) = c < 40 ? NAN : 30.0f + 0.05f * c;
  const std::string dp = (tmp.path() / "d.png").string();
  ASSERT_TRUE(plot_disparity(dp, d, 216, "disparity").ok);
  const cv::Mat di = cv::imread(dp, cv::IMREAD_COLOR);
  ASSERT_EQ(di.size(), cv::Size(1000, 600));
  cv::Mat hsv;
  cv::cvtColor(di, hsv, cv::COLOR_BGR2HSV);
  std::vector<cv::Mat> ch;
  cv::split(hsv, ch);
  EXPECT_GT(cv::countNonZero(ch[1] > 100), 40000);  // a colour map, not grey

  std::vector<SeriesSample> samples;
  for (int i = 0; i < 50; ++i)
    samples.push_back({static_cast<std::uint64_t>(i), i / 30.0, i % 10 == 3 ? RutStatus::NoRut : RutStatus::Ok,
                       40.0 + 0.2 * i, 200, 0.9});
  const std::string sp = (tmp.path() / "s.png").string();
  ASSERT_TRUE(plot_series(sp, samples, "series").ok);
  const cv::Mat si = cv::imread(sp, cv::IMREAD_COLOR);
  ASSERT_EQ(si.size(), cv::Size(1000, 800));
  EXPECT_GT(non_white(si), 10000);

  const cv::Mat grey(240, 320, CV_8UC1, cv::Scalar(128));
  const std::string op = (tmp.path() / "o.png").string();
  ASSERT_TRUE(write_strip_overlay(op, grey, ImageMarks{100, 24, 50, 250, 150, "caption"}).ok);
  const cv::Mat oi = cv::imread(op, cv::IMREAD_COLOR);
  ASSERT_EQ(oi.size(), cv::Size(640, 480));                              // scaled up x2
  EXPECT_TRUE(colour_near(oi, {320, 200}, cv::Scalar(0, 220, 255), 2));  // strip outline, top edge row 100 x2

  const PlotResult bad = plot_series((tmp.path() / "missing" / "s.png").string(), samples, "x");
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.error.find("missing/s.png"), std::string::npos) << bad.error;
}

struct Measured : test::MeasuredPair {
  // What the daemon hands the plot sink (cmd_run.cpp).
  PlotContext context() const { return PlotContext{renderer->calibration(), measurer->geometry().rectification()}; }
};

TEST(PlotSink, NeverBlocksDropsWhenBehindAndWritesEveryFile) {
  Measured m;
  ASSERT_EQ(m.work.measurement.status, RutStatus::Ok);
  test::TempDir tmp;
  PlotConfig pc;
  pc.dir = tmp.path().string();
  pc.every = 1;
  pc.min_interval_s = 0;
  pc.queue = 1;
  pc.series_period_s = 0;
  PlotSink sink(pc, m.context());
  const auto t0 = std::chrono::steady_clock::now();
  for (std::uint64_t i = 0; i < 40; ++i) {
    m.work.frame.seq = i;
    m.work.frame.t_ns = static_cast<std::int64_t>(i) * 33'000'000;
    sink.publish(published_frame(m.work, SensorHealth{}));
  }
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  // 40 publishes copy at most a handful of frames; drawing one takes far longer than all of them.
  EXPECT_LT(ms, 200.0);
  const PlotSinkStats s = sink.finish();
  EXPECT_EQ(s.frames_chosen, 40u);
  EXPECT_GT(s.dropped, 30u);
  EXPECT_EQ(s.frames_plotted + s.dropped, 40u);
  EXPECT_EQ(s.errors, 0u) << s.last_error;
  EXPECT_EQ(s.files_written, 3 * s.frames_plotted + 1);  // section, disparity, left; series
  const cv::Mat section = cv::imread((tmp.path() / "frame_000000_section.png").string());
  EXPECT_EQ(section.size(), cv::Size(1000, 600));
  const cv::Mat left = cv::imread((tmp.path() / "frame_000000_left.png").string());
  EXPECT_EQ(left.size(), cv::Size(640, 480));
  EXPECT_EQ(cv::imread((tmp.path() / "series.png").string()).size(), cv::Size(1000, 800));
}

TEST(PlotSink, WriteErrorsAreCountedNotThrown) {
  Measured m;
  test::TempDir tmp;
  const fs::path dir = tmp.path() / "plots";
  fs::create_directory(dir);
  PlotConfig pc;
  pc.dir = dir.string();
  pc.min_interval_s = 0;
  pc.lossless = true;
  PlotSink sink(pc, m.context());
  fs::remove_all(dir);  // the folder goes away under a running sink
  sink.publish(published_frame(m.work, SensorHealth{}));
  const PlotSinkStats s = sink.finish();
  EXPECT_EQ(s.errors, 4u);  // three frame plots and the series
  EXPECT_NE(s.last_error.find(dir.string()), std::string::npos) << s.last_error;
  EXPECT_THROW(PlotSink(pc, m.context()), std::invalid_argument);
}

}  // namespace
}  // namespace rutd
