// rutd bench --tables: the seed paper's Tables 1-3 measured on this machine with the synthetic bench.
//   Table 1  rate (Hz) per engine, image size and mode (strip: the default measured strip; full: every row),
//            with and without DIC. One thread runs the three stages in turn, back to back (OpenCV's matchers
//            may still spread a call over its own worker threads), on pairs
//            rendered up front (StereoMeasurer::measure, as `replay` does): the rate of the algorithm,
//            not of the threaded pipeline, whose figures are the speed rows of plain `rutd bench`.
//   Table 2  surface error (mm) of the measured strip against the renderer's exact surface, per engine and
//            size: for every pixel with a 3D point, its Z minus the Z where that pixel's ray meets the
//            terrain (both on the same ray), mean and standard deviation over the strip.
//   Table 3  rut depth measured on rendered ruts 30, 40, 50 and 60 mm deep, and its error against the
//            renderer's truth, per engine and size.
#include "daemon/bench_tables.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <thread>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "daemon/dimensions.hpp"
#include "daemon/progress.hpp"
#include "measurement/measurer.hpp"
#include "synthetic/synthetic_renderer.hpp"

namespace rutd {
namespace {

constexpr double kTable3Depths[] = {30, 40, 50, 60};

struct Scene {
  cv::Size size;
  std::unique_ptr<SyntheticRenderer> renderer;
  std::vector<StereoFrame> frames;
};

Scene make_scene(cv::Size size, double depth_mm, std::size_t frames) {
  SyntheticRendererConfig p;
  p.rig.image_size = size;
  p.rut.depth_mm = depth_mm;
  Scene s;
  s.size = size;
  s.renderer = std::make_unique<SyntheticRenderer>(p);
  s.frames = s.renderer->render_pairs(frames);
  return s;
}

MeasurerConfig config_for(EngineKind engine, bool dic, bool full, cv::Size size) {
  MeasurerConfig c;
  c.engine = engine;
  c.dic = dic;
  if (full) c.strip = StripConfig{size.height, 0};
  return c;
}

const char* b(bool v) { return v ? "true" : "false"; }

// Table 1: rate of measure() back to back, at least `seconds` and at least 2 pairs after one warm-up.
void table1(const std::vector<Scene>& scenes, const std::vector<EngineKind>& engines, const BenchTablesOptions& o) {
  if (!o.json) {
    std::printf(
        "\nTable 1: measurement rate (Hz), the stages in turn on one thread (OpenCV's own workers aside), %.1f s "
        "per configuration\n",
        o.seconds);
    std::printf("%-9s %-10s %-6s %12s %12s\n", "engine", "size", "mode", "Hz no DIC", "Hz DIC");
  }
  ProgressLine progress("table 1", scenes.size() * engines.size() * 4);
  std::uint64_t done = 0;
  for (const Scene& s : scenes) {
    for (const char* mode : {"strip", "full"}) {
      for (EngineKind e : engines) {
        double hz[2] = {0, 0};
        for (bool dic : {false, true}) {
          StereoMeasurer measurer(s.renderer->calibration(), config_for(e, dic, std::string(mode) == "full", s.size));
          measurer.measure(s.frames[0].left, s.frames[0].right);  // warm-up: buffers, engine
          std::uint64_t n = 0;
          const auto t0 = std::chrono::steady_clock::now();
          double elapsed = 0;
          do {
            const StereoFrame& f = s.frames[n % s.frames.size()];
            measurer.measure(f.left, f.right);
            ++n;
            elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          } while (elapsed < o.seconds || n < 2);
          hz[dic] = static_cast<double>(n) / elapsed;
          progress.clear();
          if (o.json) {
            std::printf(
                "{\"table\":1,\"engine\":\"%s\",\"width\":%d,\"height\":%d,\"mode\":\"%s\",\"rows\":%d,"
                "\"dic\":%s,\"hz\":%.3f,\"ms\":%.3f,\"pairs\":%llu}\n",
                std::string(to_string(e)).c_str(), s.size.width, s.size.height, mode, measurer.geometry().roi().rows,
                b(dic), hz[dic], 1e3 * elapsed / static_cast<double>(n), static_cast<unsigned long long>(n));
            std::fflush(stdout);
          }
          progress.update(++done);
        }
        if (!o.json) {
          progress.clear();
          std::printf("%-9s %-10s %-6s %12.2f %12.2f\n", std::string(to_string(e)).c_str(),
                      fmt::format("{}x{}", s.size.width, s.size.height).c_str(), mode, hz[0], hz[1]);
          std::fflush(stdout);
        }
      }
    }
  }
}

// Table 2. The true Z of every strip pixel is computed once per scene: the pixel's ray in the left
// rectified frame, turned into the raw left camera frame (R1^T) and cast on frame 0's exact terrain.
cv::Mat true_strip_z(const Scene& s, const StereoGeometry& g) {
  const StripRoi roi = g.roi();
  cv::Mat z(roi.rows, g.rectified_size().width, CV_64FC1, cv::Scalar(std::nan("")));
  const double f = g.P1()(0, 0), cx = g.P1()(0, 2), cy = g.P1()(1, 2);
  const cv::Matx33d back = g.R1().t();
  for (int r = 0; r < roi.rows; ++r) {
    for (int u = 0; u < z.cols; ++u) {
      const cv::Vec3d ray((u - cx) / f, (roi.row0 + r - cy) / f, 1.0);
      const auto hit = s.renderer->intersect_left(0, back * ray);
      if (hit) z.at<double>(r, u) = (g.R1() * *hit)[2];
    }
  }
  return z;
}

void table2(const std::vector<Scene>& scenes, const std::vector<EngineKind>& engines, const BenchTablesOptions& o) {
  if (!o.json) {
    std::printf("\nTable 2: surface error of the measured strip against the exact rendered surface (mm), %s rut\n",
                "50 mm");
    std::printf("%-9s %-10s %9s %9s %9s | %9s %9s %9s\n", "engine", "size", "mean", "std", "points", "mean DIC",
                "std DIC", "points");
  }
  ProgressLine progress("table 2", scenes.size() * engines.size() * 2);
  std::uint64_t done = 0;
  for (const Scene& s : scenes) {
    cv::Mat truth;
    for (EngineKind e : engines) {
      double mean[2] = {0, 0}, sd[2] = {0, 0};
      long points[2] = {0, 0};
      for (bool dic : {false, true}) {
        const StereoMeasurer measurer(s.renderer->calibration(), config_for(e, dic, false, s.size));
        if (truth.empty()) truth = true_strip_z(s, measurer.geometry());
        FrameWork w;
        w.frame = s.frames[0];
        MatchContext context = measurer.make_match_context();
        RutWorkspace ws;
        if (measurer.rectify(w)) {
          measurer.match(w, context);
          measurer.extract(w, ws);
        }
        double sum = 0, sum2 = 0;
        long n = 0;
        for (int r = 0; r < w.xyz.rows && r < truth.rows; ++r) {
          for (int u = 0; u < w.xyz.cols && u < truth.cols; ++u) {
            const double zm = w.xyz.at<cv::Vec3f>(r, u)[2], zt = truth.at<double>(r, u);
            if (!std::isfinite(zm) || !std::isfinite(zt)) continue;
            sum += zm - zt;
            sum2 += (zm - zt) * (zm - zt);
            ++n;
          }
        }
        mean[dic] = n > 0 ? sum / n : std::nan("");
        sd[dic] = n > 1 ? std::sqrt(std::max(0.0, (sum2 - sum * sum / n) / (n - 1))) : std::nan("");
        points[dic] = n;
        progress.clear();
        if (o.json) {
          std::printf(
              "{\"table\":2,\"engine\":\"%s\",\"width\":%d,\"height\":%d,\"dic\":%s,\"mean_mm\":%.4f,"
              "\"std_mm\":%.4f,\"points\":%ld}\n",
              std::string(to_string(e)).c_str(), s.size.width, s.size.height, b(dic), mean[dic], sd[dic], n);
          std::fflush(stdout);
        }
        progress.update(++done);
      }
      if (!o.json) {
        progress.clear();
        std::printf("%-9s %-10s %9.3f %9.3f %9ld | %9.3f %9.3f %9ld\n", std::string(to_string(e)).c_str(),
                    fmt::format("{}x{}", s.size.width, s.size.height).c_str(), mean[0], sd[0], points[0], mean[1],
                    sd[1], points[1]);
        std::fflush(stdout);
      }
    }
  }
}

void table3(const std::vector<cv::Size>& sizes, const std::vector<EngineKind>& engines, const BenchTablesOptions& o) {
  if (!o.json) {
    std::printf("\nTable 3: rut depth measured (error against the rendered truth), mm\n");
    std::printf("%-9s %-10s %-4s", "engine", "size", "dic");
    for (double d : kTable3Depths) std::printf(" %18s", fmt::format("{:.0f} mm", d).c_str());
    std::printf("\n");
  }
  ProgressLine progress("table 3", sizes.size() * std::size(kTable3Depths) * engines.size() * 2);
  std::uint64_t done = 0;
  for (cv::Size size : sizes) {
    // results[engine][dic][depth index]
    std::map<EngineKind, std::array<std::array<RutMeasurement, 4>, 2>> results;
    std::array<double, 4> truth{};
    for (std::size_t k = 0; k < std::size(kTable3Depths); ++k) {
      const Scene s = make_scene(size, kTable3Depths[k], 1);
      truth[k] = s.renderer->truth(0).depth_mm;
      for (EngineKind e : engines) {
        for (bool dic : {false, true}) {
          StereoMeasurer measurer(s.renderer->calibration(), config_for(e, dic, false, size));
          const RutMeasurement m = measurer.measure(s.frames[0].left, s.frames[0].right);
          results[e][dic][k] = m;
          progress.clear();
          if (o.json) {
            std::printf(
                "{\"table\":3,\"engine\":\"%s\",\"width\":%d,\"height\":%d,\"dic\":%s,\"truth_mm\":%.4f,"
                "\"depth_mm\":%.4f,\"error_mm\":%.4f,\"status\":\"%s\"}\n",
                std::string(to_string(e)).c_str(), size.width, size.height, b(dic), truth[k], m.depth_mm,
                m.depth_mm - truth[k], std::string(to_string(m.status)).c_str());
            std::fflush(stdout);
          }
          progress.update(++done);
        }
      }
    }
    if (o.json) continue;
    progress.clear();
    for (EngineKind e : engines) {
      for (bool dic : {false, true}) {
        std::printf("%-9s %-10s %-4s", std::string(to_string(e)).c_str(),
                    fmt::format("{}x{}", size.width, size.height).c_str(), dic ? "on" : "off");
        for (std::size_t k = 0; k < 4; ++k) {
          const RutMeasurement& m = results[e][dic][k];
          const std::string cell = m.status == RutStatus::Ok
                                       ? fmt::format("{:.2f} ({:+.2f})", m.depth_mm, m.depth_mm - truth[k])
                                       : std::string(to_string(m.status));
          std::printf(" %18s", cell.c_str());
        }
        std::printf("\n");
      }
    }
    std::fflush(stdout);
  }
}

}  // namespace

int run_bench_tables(const BenchTablesOptions& o) {
  std::vector<EngineKind> engines;
  for (const std::string& name : o.engines) {
    const auto e = parse_engine(name);
    if (!e)
      throw CLI::ValidationError("--engines",
                                 "unknown engine '" + name + "' (bm, sgbm, sgbm3way, hh4, hh, gpu, sgmref)");
    engines.push_back(*e);
  }
  std::vector<cv::Size> sizes;
  for (const std::string& text : o.sizes) {
    const auto size = parse_dimensions(text, 64, 8192);
    if (!size)
      throw CLI::ValidationError("--sizes", "expected WIDTHxHEIGHT between 64x64 and 8192x8192, got '" + text + "'");
    sizes.push_back(*size);
  }
  for (int t : o.tables)
    if (t < 1 || t > 3) throw CLI::ValidationError("--tables", fmt::format("no table {} (1, 2, 3)", t));
  const auto wants = [&](int t) { return std::find(o.tables.begin(), o.tables.end(), t) != o.tables.end(); };
  std::fprintf(o.json ? stderr : stdout, "rutd bench --tables: synthetic 50 mm rut in sand, %u hardware threads\n",
               std::thread::hardware_concurrency());
  if (wants(1) || wants(2)) {
    std::vector<Scene> scenes;
    for (cv::Size size : sizes) scenes.push_back(make_scene(size, 50, 2));
    if (wants(1)) table1(scenes, engines, o);
    if (wants(2)) table2(scenes, engines, o);
  }
  if (wants(3)) table3(sizes, engines, o);
  return 0;
}

}  // namespace rutd
