// The live view's parts without a browser: the aiming figures against direct computations, the mapping
// from rectified to raw pixels against OpenCV's own inverse (cv::undistortPoints), the answers to
// requests (tokens, paths, methods), and the whole sink: pairs published at camera rate reach the page at
// the configured rate, through cpp-httplib's own client, with the figures of the pair shown.
#include <httplib.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <random>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "measured_pair.hpp"
#include "test_support.hpp"
#include "web/aiming.hpp"
#include "web/live_view.hpp"
#include "web/web_overlay.hpp"
#include "web/web_routes.hpp"

namespace rutd {
namespace {

using namespace std::chrono_literals;

// The variance of the 3x3 Laplacian [0 1 0; 1 -4 1; 0 1 0], by hand over the interior pixels of rows a..b-1.
double laplacian_variance(const cv::Mat& g, int a, int b) {
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int y = std::max(a, 1); y < std::min(b, g.rows - 1); ++y)
    for (int x = 1; x < g.cols - 1; ++x) {
      const double v = g.at<std::uint8_t>(y - 1, x) + g.at<std::uint8_t>(y + 1, x) + g.at<std::uint8_t>(y, x - 1) +
                       g.at<std::uint8_t>(y, x + 1) - 4.0 * g.at<std::uint8_t>(y, x);
      sum += v;
      sum2 += v * v;
      ++n;
    }
  const double mean = sum / n;
  return sum2 / n - mean * mean;
}

cv::Mat noise_image(int w, int h, unsigned seed) {
  cv::Mat g(h, w, CV_8UC1);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> d(40, 210);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) g.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(d(rng));
  cv::GaussianBlur(g, g, cv::Size(0, 0), 0.8);
  return g;
}

TEST(WebAiming, FocusIsTheLaplaciansVarianceOverTheMeasuredRowsAndFallsWithBlur) {
  const cv::Mat g = noise_image(200, 60, 3);
  for (const auto& [a, rows] : {std::pair{10, 20}, std::pair{0, 60}, std::pair{0, 5}, std::pair{50, 10}}) {
    const double want = laplacian_variance(g, a, a + rows);
    EXPECT_NEAR(focus_measure(g, a, rows), want, 1e-6 * want) << a << " " << rows;
  }
  EXPECT_TRUE(std::isnan(focus_measure(g, 10, 2)));
  double previous = focus_measure(g, 10, 40);
  for (const double sigma : {0.7, 1.2, 2.0, 3.0}) {
    cv::Mat blurred;
    cv::GaussianBlur(g, blurred, cv::Size(0, 0), sigma);
    const double f = focus_measure(blurred, 10, 40);
    EXPECT_LT(f, 0.8 * previous) << "sigma " << sigma;
    previous = f;
  }
}

TEST(WebAiming, ExposureCountsSaturatedAndDarkPixelsAtTheSensorsFullScale) {
  cv::Mat g(100, 100, CV_8UC1, cv::Scalar(128));
  g.rowRange(0, 25).setTo(255);  // 25 % saturated
  g.rowRange(25, 35).setTo(3);   // 10 % dark (<= 5.1)
  const CameraAiming a = exposure_figures(g);
  EXPECT_EQ(a.top, 255);
  EXPECT_DOUBLE_EQ(a.saturated_share, 0.25);
  EXPECT_DOUBLE_EQ(a.dark_share, 0.10);
  EXPECT_NEAR(a.mean, (0.25 * 255 + 0.10 * 3 + 0.65 * 128) / 255, 1e-12);
  EXPECT_EQ(a.histogram[63], 2500u);
  EXPECT_EQ(a.histogram[0], 1000u);
  EXPECT_EQ(a.histogram[32], 6500u);  // 128 * 64 / 256
  // A 12-bit sensor in 16-bit pixels: full scale 4095, not 65535.
  cv::Mat w(10, 10, CV_16UC1, cv::Scalar(2000));
  w.rowRange(0, 3).setTo(4095);
  const CameraAiming b = exposure_figures(w);
  EXPECT_EQ(b.top, 4095);
  EXPECT_DOUBLE_EQ(b.saturated_share, 0.3);
  w.rowRange(0, 3).setTo(3000);  // nothing at full scale
  EXPECT_EQ(exposure_figures(w).saturated_share, 0.0);
}

struct Measured : test::MeasuredPair {
  // What the daemon hands the live view (cmd_run.cpp).
  WebContext context() const { return WebContext{renderer->calibration(), measurer->geometry().rectification()}; }
};

TEST(WebOverlay, RawPixelsOfRectifiedOnesAreOpenCvsInverse) {
  const Measured m;
  const WebContext c = m.context();
  ASSERT_GT(cv::norm(c.calibration.D1), 0.0) << "the rig must have lens distortion for this to mean anything";
  int checked = 0;
  for (const bool left : {true, false}) {
    for (int v = 20; v < 240; v += 50)
      for (int u = 20; u < 320; u += 60) {
        const cv::Point2d raw = raw_from_rectified(c, left, {double(u), double(v)});
        std::vector<cv::Point2d> back;
        cv::undistortPoints(std::vector<cv::Point2d>{raw}, back, left ? c.calibration.M1 : c.calibration.M2,
                            left ? c.calibration.D1 : c.calibration.D2, left ? c.rectification.R1 : c.rectification.R2,
                            left ? c.rectification.P1 : c.rectification.P2);
        EXPECT_NEAR(back[0].x, u, 0.02) << left << " " << u << "," << v;
        EXPECT_NEAR(back[0].y, v, 0.02) << left << " " << u << "," << v;
        ++checked;
      }
  }
  EXPECT_EQ(checked, 50);
}

WebRequest get(const std::string& path, const std::string& token = "", const std::string& auth = "") {
  return WebRequest{"GET", path, token, auth, 5};
}

TEST(WebRoutes, ServesTheFixedPagesToReadsAndTheDataOnlyWithTheRightToken) {
  auto content = std::make_shared<WebContent>();
  content->live_json = R"({"seq":1})";
  content->left_jpeg = "JPEG";
  const WebRoutes open("");
  EXPECT_EQ(open.answer(get("/"), nullptr).status, 200);
  EXPECT_EQ(open.answer(get("/"), nullptr).body, web_page_html());
  EXPECT_EQ(open.answer(get("/app.js"), nullptr).content_type, "text/javascript; charset=utf-8");
  EXPECT_EQ(open.answer(get("/api/live.json"), nullptr).status, 503) << "nothing measured yet";
  const WebAnswer live = open.answer(get("/api/live.json"), content);
  EXPECT_EQ(live.status, 200);
  EXPECT_EQ(live.body, content->live_json);
  EXPECT_EQ(live.keep, content) << "the content stays alive while it is sent";
  EXPECT_EQ(open.answer(get("/api/image/right.jpg"), content).status, 503) << "no right image in this content";
  for (const char* path : {"/etc/passwd", "/api", "/api/live.json/", "/index.htm", "/API/LIVE.JSON", ""})
    EXPECT_EQ(open.answer(get(path), content).status, path[0] == '\0' ? 400 : 404) << path;
  for (const char* path : {"/../etc/passwd", "/api/../../etc/passwd", "/..", "/a\\b"})
    EXPECT_EQ(open.answer(get(path), content).status, 400) << path;
  for (const char* method : {"POST", "PUT", "DELETE", "PATCH", "OPTIONS", "TRACE", "get"})
    EXPECT_EQ(open.answer(WebRequest{method, "/", "", "", 5}, content).status, 405) << method;
  EXPECT_EQ(open.answer(WebRequest{"HEAD", "/api/live.json", "", "", 5}, content).status, 200);
  EXPECT_EQ(open.answer(WebRequest{"GET", "/", "", "", kWebMaxHeaders}, content).status, 200);
  EXPECT_EQ(open.answer(WebRequest{"GET", "/", "", "", kWebMaxHeaders + 1}, content).status, 431);

  const std::string token = "0123456789abcdef0123";
  const WebRoutes closed(token);
  EXPECT_EQ(closed.answer(get("/api/live.json"), content).status, 401);
  EXPECT_EQ(closed.answer(get("/"), content).status, 200) << "the page tells nothing without its data";
  EXPECT_EQ(closed.answer(get("/app.js"), content).status, 200);
  EXPECT_EQ(closed.answer(get("/api/image/left.jpg"), content).status, 401);
  EXPECT_EQ(closed.answer(get("/nothing"), content).status, 401) << "which paths exist is not told either";
  EXPECT_EQ(closed.answer(get("/api/live.json", "wrong-token-0000000"), content).status, 403);
  EXPECT_EQ(closed.answer(get("/api/live.json", token + "x"), content).status, 403);
  EXPECT_EQ(closed.answer(get("/api/live.json", "", "Bearer " + token.substr(1)), content).status, 403);
  EXPECT_EQ(closed.answer(get("/api/live.json", "", "Basic " + token), content).status, 401);
  EXPECT_EQ(closed.answer(get("/api/live.json", token), content).status, 200);
  EXPECT_EQ(closed.answer(get("/api/live.json", "", "Bearer " + token), content).status, 200);
}

TEST(WebConfig, TheTokenFileMustBePrivateAndLongEnough) {
  const test::TempDir tmp;
  const auto write = [&](const char* name, const std::string& text, mode_t mode) {
    const std::string p = (tmp.path() / name).string();
    std::ofstream(p) << text;
    ::chmod(p.c_str(), mode);
    return p;
  };
  EXPECT_EQ(read_web_token(write("good", "  0123456789abcdef \nsecond line\n", 0600)), "0123456789abcdef");
  EXPECT_THROW(read_web_token(write("short", "0123456789abcde\n", 0600)), std::invalid_argument);
  try {
    read_web_token(write("open", "0123456789abcdef\n", 0644));
    ADD_FAILURE() << "a token readable by others was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("open: the token file is readable by others (mode 644)"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(read_web_token((tmp.path() / "missing").string()), std::invalid_argument);
  WebConfig c;
  c.enabled = true;
  EXPECT_EQ(check_web_config(c), "");
  c.bind = "0.0.0.0";
  EXPECT_EQ(check_web_config(c).rfind("token_file:", 0), 0u) << check_web_config(c);
  c.bind = "localhost";
  EXPECT_EQ(check_web_config(c).rfind("bind:", 0), 0u) << check_web_config(c);
  EXPECT_TRUE(is_loopback_address("127.0.0.2"));
  EXPECT_TRUE(is_loopback_address("::1"));
  EXPECT_FALSE(is_loopback_address("0.0.0.0"));
  EXPECT_FALSE(is_loopback_address("::"));
}

double json_number(const std::string& json, const std::string& key) {
  const auto at = json.find("\"" + key + "\":");
  if (at == std::string::npos) return std::nan("");
  return std::strtod(json.c_str() + at + key.size() + 3, nullptr);
}

TEST(WebLiveView, PairsAtCameraRateReachThePageAtTheConfiguredRateWithTheirFigures) {
  Measured m;
  ASSERT_EQ(m.work.measurement.status, RutStatus::Ok);
  WebConfig c;
  c.enabled = true;
  c.port = 0;
  c.rate_hz = 5;
  WebLiveView view(c, m.context());
  ASSERT_GT(view.port(), 0);
  httplib::Client client("127.0.0.1", view.port());
  // 3 s of pairs at 100 Hz, each with its own depth so that the page's can be traced to its pair.
  // The pairs the rate limit should let through, from the times they were handed over: the first pair,
  // then each first pair at least 1/rate_hz after the last one let through. Counted here rather than
  // bounded by the elapsed time, because a thread descheduled for a while (ThreadSanitizer on a loaded
  // machine) catches up in a burst of pairs of which only one may pass.
  const std::chrono::nanoseconds interval(static_cast<std::int64_t>(1e9 / c.rate_hz));
  std::uint64_t expected_offers = 0;
  auto last_offer = std::chrono::steady_clock::time_point::min();
  const auto t0 = std::chrono::steady_clock::now();
  for (std::uint64_t i = 1; i <= 300; ++i) {
    m.work.frame.seq = i;
    m.work.frame.t_ns = static_cast<std::int64_t>(i) * 10'000'000;
    m.work.measurement.depth_mm = 40.0 + 0.01 * static_cast<double>(i);
    const auto handed = std::chrono::steady_clock::now();
    if (expected_offers == 0 || handed - last_offer >= interval) {
      ++expected_offers;
      last_offer = handed;
    }
    view.publish(published_frame(m.work, SensorHealth{}));
    std::this_thread::sleep_until(t0 + i * 10ms);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // A segment closed over the last pairs: its advisory is the page's, and the history places it in time.
  Segment seg;
  seg.index = 4;
  seg.start_m = 4;
  seg.end_m = 5;
  seg.t_start_ns = 2'000'000'000;
  seg.t_end_ns = 2'990'000'000;
  seg.advisory = Advisory::NoGo;
  view.publish_segment(seg);
  // The view thread builds what it has at rate_hz; under ThreadSanitizer on a loaded machine that took
  // longer than the 400 ms once waited here: asked again every 200 ms until the segment is on both, 5 s
  // at most.
  std::string j, history_body;
  unsigned asked = 0;
  for (const auto deadline = std::chrono::steady_clock::now() + 5s;;) {
    std::this_thread::sleep_for(200ms);
    const auto live = client.Get("/api/live.json");
    ASSERT_TRUE(live);
    ASSERT_EQ(live->status, 200);
    const auto history = client.Get("/api/history.json");
    ASSERT_TRUE(history);
    ++asked;
    j = live->body;
    history_body = history->body;
    const bool shown =
        j.find(R"("advisory":"NO_GO")") != std::string::npos && history_body.find(R"("index":4,)") != std::string::npos;
    if (shown || std::chrono::steady_clock::now() > deadline) break;
  }
  const double seq = json_number(j, "seq");
  ASSERT_GE(seq, 1);
  EXPECT_NEAR(json_number(j, "depth_mm"), 40.0 + 0.01 * seq, 0.006) << j.substr(0, 400);
  EXPECT_NEAR(json_number(j, "published_rate_hz"), 100, 15) << "every pair is a sample, whatever the rate";
  EXPECT_NE(j.find(R"("advisory":"NO_GO")"), std::string::npos) << j.substr(0, 400);
  EXPECT_NE(history_body.find(R"("index":4,"start_m":4.00,"end_m":5.00,"t_start_s":2.000,"t_end_s":2.990)"),
            std::string::npos)
      << history_body.substr(0, 400);
  // Every pair is a sample: 3 s of them in 0.1 s bins, 10 pairs each.
  EXPECT_NE(history_body.find(R"({"t_s":1.5,"frames":10,"ok":10,"depth_max_mm":41.59,"depth_last_mm":41.59,)"),
            std::string::npos)
      << history_body.substr(0, 400);
  const WebHandoff h = view.stats();
  EXPECT_LE(h.pairs_offered, static_cast<std::uint64_t>(seconds * 5) + 1);
  // The view reads the clock inside publish(), after `handed` and before the next pair's: a pair near a
  // 200 ms edge may fall on its other side. Both are greedy chains of gaps of at least 200 ms over the
  // same pairs, so such a shift delays the view's chain by less than one gap; 2 for the shifts at either
  // end. A limit at 4 Hz would let 12 of about 15 through, one without a limit all 300.
  EXPECT_NEAR(static_cast<double>(h.pairs_offered), static_cast<double>(expected_offers), 2.0)
      << "after " << seconds << " s";
  EXPECT_EQ(h.samples_dropped, 0u);
  // The pictures decode (with OpenCV, not ours) at the camera's size and the strips' layout.
  const auto left = client.Get("/api/image/left.jpg");
  ASSERT_TRUE(left);
  ASSERT_EQ(left->status, 200);
  EXPECT_EQ(left->get_header_value("Content-Type"), "image/jpeg");
  const cv::Mat img = cv::imdecode(std::vector<unsigned char>(left->body.begin(), left->body.end()), cv::IMREAD_COLOR);
  EXPECT_EQ(img.size(), cv::Size(320, 240));
  const auto strip = client.Get("/api/image/strip.png");
  ASSERT_TRUE(strip);
  const cv::Mat s = cv::imdecode(std::vector<unsigned char>(strip->body.begin(), strip->body.end()), cv::IMREAD_COLOR);
  EXPECT_EQ(s.cols, m.work.left_strip.cols);
  EXPECT_EQ(s.rows, 2 * m.work.left_strip.rows + 4);
  // The deepest point is drawn (red) where the left image shows it.
  const RutGeometry& g = m.work.geometry;
  const auto& r = m.context().rectification;
  const double v = m.work.measured_row0 + 0.5 * m.work.measured_rows;
  const double z =
      g.line_m * g.deepest_x_mm + g.line_c + m.work.measurement.depth_mm * std::sqrt(1 + g.line_m * g.line_m);
  const cv::Point2d rect(r.P1(0, 0) * g.deepest_x_mm / z + r.P1(0, 2), v);
  const cv::Point2d raw = raw_from_rectified(m.context(), true, rect);
  int red = 0;
  for (int dy = -7; dy <= 7; ++dy)
    for (int dx = -7; dx <= 7; ++dx) {
      const cv::Point p(cvRound(raw.x) + dx, cvRound(raw.y) + dy);
      if (p.x < 0 || p.y < 0 || p.x >= img.cols || p.y >= img.rows) continue;
      const cv::Vec3b c = img.at<cv::Vec3b>(p);
      red += c[2] > 180 && c[1] < 110 && c[0] < 110;
    }
  EXPECT_GE(red, 8) << "at " << raw;
  view.stop();
  EXPECT_EQ(view.stats().requests, 2 * asked + 2);
}

TEST(WebLiveView, APortInUseIsAStartUpErrorNamingTheAddress) {
  httplib::Server other;
  const int port = other.bind_to_any_port("127.0.0.1");
  ASSERT_GT(port, 0);
  WebConfig c;
  c.enabled = true;
  c.port = port;
  Measured m;
  try {
    WebLiveView view(c, m.context());
    ADD_FAILURE() << "listened on a port in use";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("127.0.0.1:" + std::to_string(port) + ": cannot listen"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace rutd
