// rutd-gpu-bench: speed of the Vulkan matcher. Per configuration (image size x disparities x paths x row
// segment x winner-takes-all segment): the median and 99th percentile over --runs frames after --warmup
// frames of the device time of each stage (GPU timestamps) and of one synchronous frame end to end on the
// host clock (pack and upload both images, all stages, download and decode the disparity and, with raw
// input, copy the strips out, as the daemon's engine does), and the throughput with two frames in flight
// (the next pair's upload overlapping the current pair's work). Images are generated
// (tools/synthetic_pair.hpp) or read from 8-bit binary PGM files (--left/--right, one size then).
// Needs only the Vulkan loader at run time.
//   rutd-gpu-bench [--device NAME|INDEX] [--runs N] [--warmup N] [--sizes 640x480,1280x1024,640x48]
//                  [--paths 2,4,8] [--disparities 64,128] [--left L.pgm --right R.pgm]
//                  [--dic columns|pixels|none] [--input raw|rectified] [--segment 0,64,...] [--run-in N]
//                  [--wta-segment 0,128,...] [--aggregate int|half] [--aggregate-lanes 0,8,...]
//                  [--dic-window-subgroups 0,1,4,...] [--json]
// --segment: rows aggregated in segments of N px with a --run-in px run-in (SgmConfig::segment; 0, the
// default, whole rows); a list times each. --wta-segment: the winner-takes-all's rows walked in segments
// (VulkanSgmOptions::wta_segment; 0 whole rows, -1 the default: 128 px on a GPU, whole rows on a CPU device).
// --aggregate half: the aggregation's step in packed half floats (VulkanSgmOptions::aggregate_half).
// --aggregate-lanes: the invocations that walk one line of the aggregation (VulkanSgmOptions::aggregate_lanes;
// 0, the default, the device's default); a list times each. --dic-window-subgroups: the subgroups that
// share a DIC column window (VulkanSgmOptions::dic_window_subgroups; 0, the default, the automatic choice);
// a list times each.
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
// --json: one JSON object per configuration on stdout instead of the table: device, type, driver,
// subgroup, width, height, disparities, paths, segment, run_in, wta_segment, aggregate ("int"/"half"), dic
// ("columns"/"pixels"/"none"), input, runs, warmup, then {"median": ms, "p99": ms} for upload_ms,
// rectify_ms, census_ms, aggregate_ms, wta_ms, lr_median_ms, dic_ms, download_ms (device times; 0 without
// timestamps) and end_to_end_ms (host), hz (1000 / median end to end), two_in_flight_hz, band_ms (raw
// input; else null), and the end to end's two host parts: host_submit_ms (pack into the upload buffer and
// submit) and host_collect_ms (wait for the frame, decode the disparity, copy the strips out), the latter
// in turn as host_wait_ms (until the frame is complete) and host_decode_ms (decode and copy out of the
// mapped download buffer); aggregate_lanes and dic_window_subgroups (as resolved) and host_cached
// (GpuDeviceInfo).
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
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

std::vector<int> split_ints(const std::string& s) {
  std::vector<int> out;
  for (const std::string& item : split(s)) out.push_back(std::atoi(item.c_str()));
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

// The q-quantile (0.5 median, 0.99 p99) of v: the element at q (n - 1) rounded up.
double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1) + 0.999999);
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// `text` as the inside of a JSON string.
std::string json_escaped(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) >= 0x20) out += c;
  }
  return out;
}

std::string json_stat(const std::vector<double>& v) {
  if (v.empty()) return "null";
  char buf[96];
  std::snprintf(buf, sizeof buf, "{\"median\":%.4f,\"p99\":%.4f}", quantile(v, 0.5), quantile(v, 0.99));
  return buf;
}

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

// Every triple (a, b, c) of a in as, b in bs, c in cs.
std::vector<std::array<int, 3>> combinations(const std::vector<int>& as, const std::vector<int>& bs,
                                             const std::vector<int>& cs) {
  std::vector<std::array<int, 3>> out;
  for (const int a : as)
    for (const int b : bs)
      for (const int c : cs) out.push_back({a, b, c});
  return out;
}

struct Options {
  std::string device, sizes = "640x480,1280x1024,640x48", paths = "2,4,8", disparities = "64,128", left_pgm, right_pgm;
  int runs = 200, warmup = 20;
  std::string dic = "columns", input = "raw", aggregate = "int";
  std::vector<int> segments{0}, wta_segments{VulkanSgmOptions::kWtaSegmentAuto}, lanes{0}, dic_subgroups{0};
  int run_in = 64;
  bool json = false;
};

// Every stage's times of the measured frames.
struct Times {
  std::vector<double> upload, rectify, census, aggregate, wta, lr_median, dic, download, total, band;
  // Host: pack and submit, then wait for the frame, decode the disparity and copy the strips out.
  std::vector<double> submit, collect, wait, decode;
  double flight_hz = 0;
};

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool more = i + 1 < argc;
    if (a == "--device" && more) o.device = argv[++i];
    else if (a == "--runs" && more) o.runs = std::max(1, std::atoi(argv[++i]));
    else if (a == "--warmup" && more) o.warmup = std::max(0, std::atoi(argv[++i]));
    else if (a == "--sizes" && more) o.sizes = argv[++i];
    else if (a == "--paths" && more) o.paths = argv[++i];
    else if (a == "--disparities" && more) o.disparities = argv[++i];
    else if (a == "--left" && more) o.left_pgm = argv[++i];
    else if (a == "--right" && more) o.right_pgm = argv[++i];
    else if (a == "--dic" && more) o.dic = argv[++i];
    else if (a == "--no-dic") o.dic = "none";
    else if (a == "--input" && more) o.input = argv[++i];
    else if (a == "--segment" && more) o.segments = split_ints(argv[++i]);
    else if (a == "--run-in" && more) o.run_in = std::atoi(argv[++i]);
    else if (a == "--wta-segment" && more) o.wta_segments = split_ints(argv[++i]);
    else if (a == "--aggregate" && more) o.aggregate = argv[++i];
    else if (a == "--aggregate-lanes" && more) o.lanes = split_ints(argv[++i]);
    else if (a == "--dic-window-subgroups" && more) o.dic_subgroups = split_ints(argv[++i]);
    else if (a == "--json") o.json = true;
    else {
      std::fprintf(stderr, "usage: see the comment at the top of gpu_bench.cpp\n");
      return 2;
    }
  }
  if (o.dic != "columns" && o.dic != "pixels" && o.dic != "none") {
    std::fprintf(stderr, "--dic: columns, pixels or none\n");
    return 2;
  }
  if (o.input != "raw" && o.input != "rectified") {
    std::fprintf(stderr, "--input: raw or rectified\n");
    return 2;
  }
  if (o.aggregate != "int" && o.aggregate != "half") {
    std::fprintf(stderr, "--aggregate: int or half\n");
    return 2;
  }
  for (const int segment : o.segments) {
    SgmConfig segmented;
    segmented.segment = segment;
    segmented.segment_run_in = o.run_in;
    const std::string error = check_sgm_input(1, 1, SgmBand{0, 2}, segmented);
    if (!error.empty()) {
      std::fprintf(stderr, "--segment/--run-in: %s\n", error.c_str());
      return 2;
    }
  }
  for (const int segment : o.wta_segments) {
    if (segment != VulkanSgmOptions::kWtaSegmentAuto && segment != 0 && segment < 16) {
      std::fprintf(stderr, "--wta-segment: -1 (auto), 0 or >= 16 px\n");
      return 2;
    }
  }
  const bool raw = o.input == "raw";
  tools::Pair file_pair;
  if (!o.left_pgm.empty() || !o.right_pgm.empty()) {
    int rw = 0, rh = 0;
    if (!read_pgm(o.left_pgm, file_pair.width, file_pair.height, file_pair.left) ||
        !read_pgm(o.right_pgm, rw, rh, file_pair.right) || rw != file_pair.width || rh != file_pair.height) {
      std::fprintf(stderr, "cannot read two 8-bit binary PGM images of one size from --left/--right\n");
      return 2;
    }
    o.sizes = std::to_string(file_pair.width) + "x" + std::to_string(file_pair.height);
  }

  bool header = false;
  for (const std::string& size : split(o.sizes)) {
    const int w = std::atoi(size.c_str()), h = std::atoi(size.substr(size.find('x') + 1).c_str());
    for (const int nd : split_ints(o.disparities)) {
      for (const auto& [wta_segment, lanes, dic_subgroups] : combinations(o.wta_segments, o.lanes, o.dic_subgroups)) {
        VulkanSgmOptions options;
        options.wta_segment = wta_segment;
        options.aggregate_lanes = lanes;
        options.dic_window_subgroups = dic_subgroups;
        options.aggregate_half = o.aggregate == "half";
        std::unique_ptr<VulkanSgm> sgm;
        try {
          sgm = std::make_unique<VulkanSgm>(o.device, w, h, nd, options);
        } catch (const GpuError& e) {
          std::fprintf(stderr, "%s\n", e.what());
          return 1;
        }
        const GpuDeviceInfo& info = sgm->device();
        if (!header && !o.json) {
          std::printf("device %d: %s; DIC %s; %s input; aggregation in %s; median of %d runs after %d warm-up, ms\n",
                      info.index, describe(info).c_str(),
                      o.dic == "columns"  ? "column windows"
                      : o.dic == "pixels" ? "per pixel, every second row"
                                          : "off",
                      o.input.c_str(), o.aggregate == "half" ? "half floats" : "integers", o.runs, o.warmup);
          std::printf("%-10s %5s %5s %4s %4s | %7s %7s %7s %9s %7s %7s %7s %8s | %9s %8s %8s | %9s | %7s\n", "size",
                      "disp", "paths", "seg", "wseg", "upload", "rectify", "census", "aggregate", "wta", "lr+med",
                      "dic", "download", "end2end", "p99", "Hz", "2-flight", "band");
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
        // As VulkanSgm::collect's float form, with the wait and the decode timed apart (wait_ms, decode_ms).
        double wait_ms = 0, decode_ms = 0;
        const auto collect = [&](int ticket, GpuStageTimes* t) {
          const auto t0 = Clock::now();
          FrameOutput frame;
          const GpuStatus s = sgm->collect(ticket, frame, t);
          wait_ms = ms_since(t0);
          if (s != GpuStatus::Ok) return s;
          const auto t1 = Clock::now();
          for (int y = 0; y < frame.disparity.height; ++y)
            frame.disparity.decode_row(y, out.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w));
          if (raw)
            for (auto [dst, src] :
                 {std::pair{strip_l.data(), frame.strip_left}, std::pair{strip_r.data(), frame.strip_right}})
              for (int y = 0; y < h; ++y)
                std::memcpy(dst + static_cast<std::size_t>(y) * static_cast<std::size_t>(w),
                            src + static_cast<std::size_t>(y) * frame.strip_stride, static_cast<std::size_t>(w));
          decode_ms = ms_since(t1);
          return s;
        };
        for (const int paths : split_ints(o.paths)) {
          for (const int segment : o.segments) {
            SgmConfig params;
            params.paths = paths;
            params.segment = segment;
            params.segment_run_in = o.run_in;
            const std::string error = check_sgm_input(w, h, band, params);
            if (!error.empty()) {
              std::fprintf(stderr, "%s\n", error.c_str());
              return 2;
            }
            Times t;
            DicKernelConfig dic;
            dic.row_step = 2;
            if (o.dic == "columns") {
              dic.column_windows = true;
              dic.column_block_rows = h <= 64 ? 0 : 16;  // MeasurerConfig::kMaxColumnWindowRows, kColumnBlockRows
            }
            const DicKernelConfig* dic_ptr = o.dic != "none" ? &dic : nullptr;
            for (int i = 0; i < o.warmup + o.runs; ++i) {
              GpuStageTimes st;
              const auto t0 = Clock::now();
              int ticket = 0;
              GpuStatus s = submit(params, dic_ptr, ticket);
              const double submit_ms = ms_since(t0);
              if (s == GpuStatus::Ok) s = collect(ticket, &st);
              const double ms = ms_since(t0);
              if (s != GpuStatus::Ok) {
                std::fprintf(stderr, "frame failed: %s\n", std::string(to_string(s)).c_str());
                return 1;
              }
              if (i < o.warmup) continue;
              t.upload.push_back(st.upload_ms);
              t.rectify.push_back(st.rectify_ms);
              t.census.push_back(st.census_ms);
              t.aggregate.push_back(st.aggregate_ms);
              t.wta.push_back(st.wta_ms);
              t.lr_median.push_back(st.lr_median_ms);
              t.dic.push_back(st.dic_ms);
              t.download.push_back(st.download_ms);
              t.total.push_back(ms);
              t.submit.push_back(submit_ms);
              t.collect.push_back(ms - submit_ms);
              t.wait.push_back(wait_ms);
              t.decode.push_back(decode_ms);
            }
            // Two in flight: submit frame i+1, then collect frame i.
            int tickets[2] = {0, 0};
            const auto t0 = Clock::now();
            bool ok = submit(params, dic_ptr, tickets[0]) == GpuStatus::Ok;
            for (int i = 1; ok && i <= o.runs; ++i) {
              if (i < o.runs) ok = submit(params, dic_ptr, tickets[i % 2]) == GpuStatus::Ok;
              ok = ok && collect(tickets[(i - 1) % 2], nullptr) == GpuStatus::Ok;
            }
            t.flight_hz = ok ? 1000.0 * o.runs / ms_since(t0) : 0.0;
            if (raw) {
              const CoarseGrid grid = coarse_grid(w, h, 2);
              std::vector<float> coarse(static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height));
              std::vector<std::uint8_t> coarse_left(coarse.size());
              StripsOut with_coarse = strips;
              with_coarse.coarse_left = coarse_left.data();
              with_coarse.coarse_stride = static_cast<std::size_t>(grid.width);
              const SgmBand coarse_band{0, std::min(64, nd)};
              for (int i = 0; ok && i < o.warmup + std::max(1, o.runs / 10); ++i) {
                const auto t1 = Clock::now();
                int ticket = 0;
                ok = sgm->submit_coarse(l, r, 2, coarse_band, params, ticket) == GpuStatus::Ok &&
                     sgm->collect(ticket, coarse.data(), static_cast<std::size_t>(grid.width), nullptr, &with_coarse) ==
                         GpuStatus::Ok;
                if (i >= o.warmup) t.band.push_back(ms_since(t1));
              }
            }
            if (!ok) {
              std::fprintf(stderr, "frame failed with two in flight or in the band estimate\n");
              return 1;
            }
            const double e2e = quantile(t.total, 0.5);
            if (o.json) {
              std::printf(
                  "{\"device\":\"%s\",\"type\":\"%s\",\"driver\":\"%s\",\"subgroup\":%u,\"width\":%d,\"height\":%d,"
                  "\"disparities\":%d,\"paths\":%d,\"segment\":%d,\"run_in\":%d,\"wta_segment\":%d,"
                  "\"aggregate\":\"%s\",\"dic\":\"%s\",\"input\":\"%s\",\"runs\":%d,\"warmup\":%d,\"upload_ms\":%s,"
                  "\"rectify_ms\":%s,\"census_ms\":%s,\"aggregate_ms\":%s,\"wta_ms\":%s,\"lr_median_ms\":%s,"
                  "\"dic_ms\":%s,\"download_ms\":%s,\"end_to_end_ms\":%s,\"hz\":%.1f,\"two_in_flight_hz\":%.1f,"
                  "\"band_ms\":%s,\"host_submit_ms\":%s,\"host_collect_ms\":%s,\"host_wait_ms\":%s,"
                  "\"host_decode_ms\":%s,\"aggregate_lanes\":%d,\"dic_window_subgroups\":%d,\"host_cached\":%s}\n",
                  json_escaped(info.name).c_str(), info.type.c_str(), json_escaped(info.driver).c_str(),
                  info.subgroup_size, w, h, nd, paths, segment, o.run_in, sgm->wta_segment(), o.aggregate.c_str(),
                  o.dic.c_str(), o.input.c_str(), o.runs, o.warmup, json_stat(t.upload).c_str(),
                  json_stat(t.rectify).c_str(), json_stat(t.census).c_str(), json_stat(t.aggregate).c_str(),
                  json_stat(t.wta).c_str(), json_stat(t.lr_median).c_str(), json_stat(t.dic).c_str(),
                  json_stat(t.download).c_str(), json_stat(t.total).c_str(), 1000.0 / e2e, t.flight_hz,
                  json_stat(t.band).c_str(), json_stat(t.submit).c_str(), json_stat(t.collect).c_str(),
                  json_stat(t.wait).c_str(), json_stat(t.decode).c_str(), sgm->aggregate_lanes(),
                  dic_ptr ? sgm->dic_subgroups_per_window(*dic_ptr) : 0, info.host_cached ? "true" : "false");
            } else {
              std::printf(
                  "%-10s %5d %5d %4d %4d | %7.3f %7.3f %7.3f %9.3f %7.3f %7.3f %7.3f %8.3f | %9.3f %8.3f %8.0f | %9.0f "
                  "| %7.3f\n",
                  size.c_str(), nd, paths, segment, sgm->wta_segment(), quantile(t.upload, 0.5),
                  quantile(t.rectify, 0.5), quantile(t.census, 0.5), quantile(t.aggregate, 0.5), quantile(t.wta, 0.5),
                  quantile(t.lr_median, 0.5), quantile(t.dic, 0.5), quantile(t.download, 0.5), e2e,
                  quantile(t.total, 0.99), 1000.0 / e2e, t.flight_hz, quantile(t.band, 0.5));
            }
            std::fflush(stdout);
          }
        }
      }
    }
  }
  return 0;
}
