// rutd-gpu-bench: speed of the Vulkan matcher. Per image size (640x480, 1280x1024, a 640x48 strip),
// paths (2/4/8) and disparities (64/128): the median over --runs frames after --warmup frames of the
// device time of each stage (GPU timestamps) and of one synchronous frame end to end on the host clock
// (pack and upload both images, all stages, download the float disparity), and the throughput with two
// frames in flight (the next pair's upload overlapping the current pair's work). Images are generated
// (tools/synthetic_pair.hpp) or read from 8-bit binary PGM files (--left/--right, one size then).
// Needs only the Vulkan loader at run time.
//   rutd-gpu-bench [--device NAME|INDEX] [--runs N] [--warmup N] [--sizes 640x480,1280x1024,640x48]
//                  [--paths 2,4,8] [--disparities 64,128] [--left L.pgm --right R.pgm]
//                  [--dic columns|pixels|none] [--input raw|rectified] [--segment N [--run-in N]]
// --segment: rows aggregated in segments of N px with an N px run-in (SgmConfig::segment; default 64).
// --input raw (the default, what the daemon runs): each frame uploads raw images and rectifies them on the
// device through maps of a slightly rotated and scaled rig (a strip of under 480 rows is the centre of a
// 480-row raw image, and only the raw rows its maps reach are uploaded), and downloads the rectified strips
// with the disparity; `rectified` uploads the strips themselves. With raw input, "band" is one synchronous
// band-estimate frame end to end (submit_coarse: rectify, average 2 columns by 2 rows, match 64 coarse
// disparities with the row's paths, download the coarse disparity, strips and coarse left image), which
// the daemon runs when it needs a new band (at most every 30 frames while the band fits).
// DIC (rutd's default DicConfig, 11 px wide windows, over every row): `columns` (the default, what the
// daemon runs) one window per column and block of 16 rows, or per column of the whole image when it has
// at most 64 rows (a strip), as the measurer configures it; `pixels` an 11x11 window around every pixel
// of every second row. The B-spline prefilter runs with the census and counts there.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "gpu/vulkan_sgm.hpp"
#include "synthetic_pair.hpp"

namespace {

using namespace rutd::gpu;
using Clock = std::chrono::steady_clock;

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) out.push_back(item);
  return out;
}

// Binary 8-bit PGM (P5, maxval <= 255); empty on anything else.
bool read_pgm(const std::string& path, int& w, int& h, std::vector<std::uint8_t>& px) {
  std::ifstream f(path, std::ios::binary);
  std::string magic;
  int maxval = 0;
  f >> magic;
  const auto skip = [&] {
    while (f >> std::ws && f.peek() == '#') f.ignore(1 << 20, '\n');
  };
  skip();
  f >> w;
  skip();
  f >> h;
  skip();
  f >> maxval;
  f.get();
  if (!f || magic != "P5" || maxval > 255 || w < 1 || h < 1) return false;
  px.resize(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  f.read(reinterpret_cast<char*>(px.data()), static_cast<std::streamsize>(px.size()));
  return static_cast<bool>(f);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Maps of a rectified rig: the strip (w x h) centred in the raw image, each camera rotated by a few tenths
// of a degree and scaled by a few parts per thousand, as stereoRectify's rotations of a real rig do.
RectifyMaps rig_maps(int w, int h, int raw_w, int raw_h) {
  RectifyMaps m{raw_w, raw_h, w, h, {}, {}};
  for (int cam = 0; cam < 2; ++cam) {
    const float angle = cam == 0 ? 0.004f : -0.003f, scale = cam == 0 ? 1.002f : 0.998f;
    std::vector<float>& map = cam == 0 ? m.left : m.right;
    map.resize(2 * static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
    const float cx = 0.5f * static_cast<float>(w - 1), cy = 0.5f * static_cast<float>(h - 1);
    const float rcx = 0.5f * static_cast<float>(raw_w - 1), rcy = 0.5f * static_cast<float>(raw_h - 1);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const float dx = static_cast<float>(x) - cx, dy = static_cast<float>(y) - cy;
        const std::size_t i =
            2 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x));
        map[i] = rcx + scale * (dx - angle * dy);
        map[i + 1] = rcy + scale * (dy + angle * dx);
      }
    }
  }
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  std::string device, sizes = "640x480,1280x1024,640x48", paths = "2,4,8", disparities = "64,128", left_pgm, right_pgm;
  int runs = 200, warmup = 20;
  std::string dic_mode = "columns", input = "raw";
  int segment = 0, run_in = 64;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool more = i + 1 < argc;
    if (a == "--device" && more) device = argv[++i];
    else if (a == "--runs" && more) runs = std::max(1, std::atoi(argv[++i]));
    else if (a == "--warmup" && more) warmup = std::max(0, std::atoi(argv[++i]));
    else if (a == "--sizes" && more) sizes = argv[++i];
    else if (a == "--paths" && more) paths = argv[++i];
    else if (a == "--disparities" && more) disparities = argv[++i];
    else if (a == "--left" && more) left_pgm = argv[++i];
    else if (a == "--right" && more) right_pgm = argv[++i];
    else if (a == "--dic" && more) dic_mode = argv[++i];
    else if (a == "--no-dic") dic_mode = "none";
    else if (a == "--input" && more) input = argv[++i];
    else if (a == "--segment" && more) segment = std::atoi(argv[++i]);
    else if (a == "--run-in" && more) run_in = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: see the comment at the top of gpu_bench.cpp\n");
      return 2;
    }
  }
  if (dic_mode != "columns" && dic_mode != "pixels" && dic_mode != "none") {
    std::fprintf(stderr, "--dic: columns, pixels or none\n");
    return 2;
  }
  if (input != "raw" && input != "rectified") {
    std::fprintf(stderr, "--input: raw or rectified\n");
    return 2;
  }
  const bool raw = input == "raw";
  {
    SgmConfig segmented;
    segmented.segment = segment;
    segmented.segment_run_in = run_in;
    const std::string error = check_sgm_input(1, 1, SgmBand{0, 2}, segmented);
    if (!error.empty()) {
      std::fprintf(stderr, "--segment/--run-in: %s\n", error.c_str());
      return 2;
    }
  }
  tools::Pair file_pair;
  if (!left_pgm.empty() || !right_pgm.empty()) {
    int rw = 0, rh = 0;
    if (!read_pgm(left_pgm, file_pair.width, file_pair.height, file_pair.left) ||
        !read_pgm(right_pgm, rw, rh, file_pair.right) || rw != file_pair.width || rh != file_pair.height) {
      std::fprintf(stderr, "cannot read two 8-bit binary PGM images of one size from --left/--right\n");
      return 2;
    }
    sizes = std::to_string(file_pair.width) + "x" + std::to_string(file_pair.height);
  }

  bool header = false;
  for (const std::string& size : split(sizes)) {
    const int w = std::atoi(size.c_str()), h = std::atoi(size.substr(size.find('x') + 1).c_str());
    for (const std::string& ds : split(disparities)) {
      const int nd = std::atoi(ds.c_str());
      std::unique_ptr<VulkanSgm> sgm;
      try {
        sgm = std::make_unique<VulkanSgm>(device, w, h, nd);
      } catch (const GpuError& e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 1;
      }
      if (!header) {
        std::printf("device %d: %s (%s, subgroup %u); DIC %s; %s input; median of %d runs after %d warm-up, ms\n",
                    sgm->device().index, sgm->device().name.c_str(), sgm->device().type.c_str(),
                    sgm->device().subgroup_size,
                    dic_mode == "columns"  ? "column windows"
                    : dic_mode == "pixels" ? "per pixel, every second row"
                                           : "off",
                    input.c_str(), runs, warmup);
        std::printf("%-10s %5s %5s | %7s %7s %7s %9s %7s %7s %7s %8s | %9s %8s | %9s | %7s\n", "size", "disp", "paths",
                    "upload", "rectify", "census", "aggregate", "wta", "lr+med", "dic", "download", "end2end", "Hz",
                    "2-flight", "band");
        header = true;
      }
      const SgmBand band{0, nd};
      // Raw input: a strip is the middle of a 480-row image (the daemon's 640x48 of a 640x480 camera).
      const int raw_w = file_pair.width ? file_pair.width : w;
      const int raw_h = file_pair.width ? file_pair.height : raw ? std::max(h, 480) : h;
      const tools::Pair pair =
          file_pair.width ? file_pair : tools::synthetic_pair(raw_w, raw_h, band.min_disparity, nd, 7);
      const ImageView l{pair.left.data(), raw_w, raw_h, static_cast<std::size_t>(raw_w)};
      const ImageView r{pair.right.data(), raw_w, raw_h, static_cast<std::size_t>(raw_w)};
      std::vector<float> out(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
      std::vector<std::uint8_t> strip_l(out.size()), strip_r(out.size());
      const StripsOut strips{strip_l.data(), strip_r.data(), static_cast<std::size_t>(w)};
      if (raw) {
        try {
          sgm->set_rectification(rig_maps(w, h, raw_w, raw_h));
        } catch (const GpuError& e) {
          std::fprintf(stderr, "%s\n", e.what());
          return 1;
        }
      }
      const auto submit = [&](const SgmConfig& params, const DicKernelConfig* dic, int& ticket) {
        return raw ? sgm->submit_raw(l, r, &band, params, dic, ticket) : sgm->submit(l, r, band, params, dic, ticket);
      };
      const auto collect = [&](int ticket, GpuStageTimes* t) {
        return sgm->collect(ticket, out.data(), static_cast<std::size_t>(w), t, raw ? &strips : nullptr);
      };
      for (const std::string& ps : split(paths)) {
        SgmConfig params;
        params.paths = std::atoi(ps.c_str());
        params.segment = segment;
        params.segment_run_in = run_in;
        const std::string error = check_sgm_input(w, h, band, params);
        if (!error.empty()) {
          std::fprintf(stderr, "%s\n", error.c_str());
          return 2;
        }
        std::vector<double> up, rect, census, agg, wta, lrm, dict, down, total;
        DicKernelConfig dic;
        dic.row_step = 2;
        if (dic_mode == "columns") {
          dic.column_windows = true;
          dic.column_block_rows = h <= 64 ? 0 : 16;  // MeasurerConfig::kMaxColumnWindowRows, kColumnBlockRows
        }
        const DicKernelConfig* dic_ptr = dic_mode != "none" ? &dic : nullptr;
        for (int i = 0; i < warmup + runs; ++i) {
          GpuStageTimes t;
          const auto t0 = Clock::now();
          int ticket = 0;
          GpuStatus s = submit(params, dic_ptr, ticket);
          if (s == GpuStatus::Ok) s = collect(ticket, &t);
          const double ms = ms_since(t0);
          if (s != GpuStatus::Ok) {
            std::fprintf(stderr, "frame failed: %s\n", std::string(to_string(s)).c_str());
            return 1;
          }
          if (i < warmup) continue;
          up.push_back(t.upload_ms);
          rect.push_back(t.rectify_ms);
          census.push_back(t.census_ms);
          agg.push_back(t.aggregate_ms);
          wta.push_back(t.wta_ms);
          lrm.push_back(t.lr_median_ms);
          dict.push_back(t.dic_ms);
          down.push_back(t.download_ms);
          total.push_back(ms);
        }
        // Two in flight: submit frame i+1, then collect frame i.
        int tickets[2] = {0, 0};
        const auto t0 = Clock::now();
        bool ok = submit(params, dic_ptr, tickets[0]) == GpuStatus::Ok;
        for (int i = 1; ok && i <= runs; ++i) {
          if (i < runs) ok = submit(params, dic_ptr, tickets[i % 2]) == GpuStatus::Ok;
          ok = ok && collect(tickets[(i - 1) % 2], nullptr) == GpuStatus::Ok;
        }
        const double flight_hz = ok ? 1000.0 * runs / ms_since(t0) : 0.0;
        std::vector<double> band_ms;
        if (raw) {
          const CoarseGrid grid = coarse_grid(w, h, 2);
          std::vector<float> coarse(static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height));
          std::vector<std::uint8_t> coarse_left(coarse.size());
          StripsOut with_coarse = strips;
          with_coarse.coarse_left = coarse_left.data();
          with_coarse.coarse_stride = static_cast<std::size_t>(grid.width);
          const SgmBand coarse_band{0, std::min(64, nd)};
          for (int i = 0; ok && i < warmup + std::max(1, runs / 10); ++i) {
            const auto t1 = Clock::now();
            int ticket = 0;
            ok = sgm->submit_coarse(l, r, 2, coarse_band, params, ticket) == GpuStatus::Ok &&
                 sgm->collect(ticket, coarse.data(), static_cast<std::size_t>(grid.width), nullptr, &with_coarse) ==
                     GpuStatus::Ok;
            if (i >= warmup) band_ms.push_back(ms_since(t1));
          }
          if (!ok) {
            std::fprintf(stderr, "band-estimate frame failed\n");
            return 1;
          }
        }
        const double e2e = median(total);
        std::printf("%-10s %5d %5d | %7.3f %7.3f %7.3f %9.3f %7.3f %7.3f %7.3f %8.3f | %9.3f %8.0f | %9.0f | %7.3f\n",
                    size.c_str(), nd, params.paths, median(up), median(rect), median(census), median(agg), median(wta),
                    median(lrm), median(dict), median(down), e2e, 1000.0 / e2e, flight_hz, median(band_ms));
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
