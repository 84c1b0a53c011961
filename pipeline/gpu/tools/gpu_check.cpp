// rutd-gpu-check: every stage of the Vulkan matcher against the C++ reference (sgm.hpp) on randomised
// pairs, sizes and parameters chosen to be awkward (odd widths, widths not a multiple of the workgroup,
// minimum disparity != 0, bands wider than the image). Integer stages must be identical; so must the
// matcher's float output (a fixed-point value / 64). The DIC stages run in float on both sides: B-spline
// coefficients within 1e-3 relative, refined disparities within 1/128 px (the requirement is 1/64 px; the
// device adds each window's sums as a subgroup tree, the reference row by row, so a pixel may stop one
// Gauss-Newton iteration apart: seen up to 0.0023 px on 157,616 pixels of a 631x479 pair), and
// at most 0.5% of the windows refined on one side only (a rejection threshold met within rounding). The DIC
// runs in both modes: per pixel, and column windows (the daemon's: one window per column and row block,
// random block heights, one block of the whole strip on strips up to 64 rows) from the same matcher
// output. Every second case starts from raw images rectified on the device (rectify.hpp) through warped
// maps that reach past the raw border: the strips must equal the reference's byte for byte, and the
// stages after them are compared as above; the band estimate's coarse pass (submit_coarse: the strips
// averaged over 1-4 columns and 2 rows, matched without DIC) must give the reference's coarse image and
// coarse disparity exactly. Exit status: 0 all equal, 1 a difference or a device, shader or pipeline that
// fails, 2 usage, 77 no Vulkan driver at all (CTest's skip code: no loader, or a loader that finds no
// device; a driver whose devices cannot run the matcher is a failure) or, with --aggregate-half, a device
// without shaderFloat16. Needs only the Vulkan loader at run time.
//   rutd-gpu-check [--device NAME|INDEX] [--seed N] [--cases N] [--aggregate-threads N] [--wta-threads N]
//                  [--aggregate-half] [--aggregate-lanes N] [--dic-window-subgroups N]
// --aggregate-threads, --wta-threads: the aggregation's and the winner-takes-all's workgroup sizes
// (VulkanSgmOptions); several subgroups' worth checks their shared-memory paths. --aggregate-lanes: the
// invocations of one aggregation line (VulkanSgmOptions::aggregate_lanes; with fewer than the workgroup,
// several lines a workgroup). --dic-window-subgroups: the subgroups that share a column window
// (VulkanSgmOptions::dic_window_subgroups; by default several only on tall row blocks). --aggregate-half: the
// aggregation's step in packed half floats (VulkanSgmOptions::aggregate_half). Every third case walks
// the winner-takes-all's rows in segments (VulkanSgmOptions::wta_segment) of a random length, drawn from
// a generator of its own so that the cases are those of earlier builds.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <string>

#include "gpu/dic.hpp"
#include "gpu/rectify.hpp"
#include "gpu/vulkan_sgm.hpp"
#include "synthetic_pair.hpp"

namespace {

using namespace rutd::gpu;

// First differing index of two equally long arrays, or -1.
template <class T>
long first_difference(const std::vector<T>& a, const std::vector<T>& b) {
  if (a.size() != b.size()) return 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if constexpr (std::is_floating_point_v<T>) {
      if (std::isnan(a[i]) != std::isnan(b[i]) || (!std::isnan(a[i]) && a[i] != b[i])) return static_cast<long>(i);
    } else if (a[i] != b[i]) {
      return static_cast<long>(i);
    }
  }
  return -1;
}

// Largest |a - b| / max(1, |b|); `at` receives its element index.
double max_relative(const std::vector<float>& a, const std::vector<float>& b, std::size_t* at = nullptr) {
  double worst = a.size() == b.size() ? 0.0 : 1e30;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
    const double r = std::abs(static_cast<double>(a[i]) - b[i]) / std::max(1.0, std::abs(static_cast<double>(b[i])));
    if (r > worst) {
      worst = r;
      if (at) *at = i;
    }
  }
  return worst;
}

// Elements whose relative difference exceeds `limit`.
long count_over(const std::vector<float>& a, const std::vector<float>& b, double limit) {
  long n = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i)
    n += std::abs(static_cast<double>(a[i]) - b[i]) / std::max(1.0, std::abs(static_cast<double>(b[i]))) > limit;
  return n;
}

struct Case {
  int width, height, min_disparity, num_disparities;
};

// Maps of a strip that samples a raw image of raw_w x raw_h: a shift with a fraction, a slight rotation,
// a barrel term and a ripple (so neighbouring pixels have different fractions), with positions past the
// raw border on every side (the clamps). `right` shifts by other fractions.
std::vector<float> warped_map(int width, int height, int raw_w, int raw_h, bool right, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  const float ox = 0.5f * static_cast<float>(raw_w - width) + u(rng) * 2.5f + (right ? 0.29f : 0.0f);
  const float oy = 0.5f * static_cast<float>(raw_h - height) + u(rng) * 2.5f + (right ? -0.17f : 0.0f);
  const float rot = 0.01f * u(rng), barrel = 4e-6f * u(rng), ripple = 0.4f * u(rng);
  const float cx = 0.5f * static_cast<float>(width), cy = 0.5f * static_cast<float>(height);
  std::vector<float> map(2 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float dx = static_cast<float>(x) - cx, dy = static_cast<float>(y) - cy;
      const float r2 = dx * dx + dy * dy;
      const std::size_t i =
          2 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x));
      map[i] = cx + ox + dx * (1.0f + barrel * r2) - rot * dy + ripple * std::sin(0.37f * static_cast<float>(y));
      map[i + 1] = cy + oy + dy * (1.0f + barrel * r2) + rot * dx + ripple * std::cos(0.23f * static_cast<float>(x));
    }
  }
  return map;
}

// A DIC output against its reference.
struct DicComparison {
  long refined = 0;   // windows the reference refined
  long one_side = 0;  // windows refined on one side only
  long windows = 0;   // windows tried
  double worst = 0;   // px, largest difference where both refined
  bool within(double limit) const { return worst <= limit && one_side <= 0.005 * static_cast<double>(windows); }
};

// Per pixel: every pixel is a window. Column windows: a block's rows are refined or NaN together, so a
// window counts once (at its first row); every pixel counts towards the difference.
DicComparison compare_dic(const std::vector<float>& ref, const std::vector<float>& dev, int width,
                          const DicKernelConfig& p) {
  DicComparison c;
  const int height = static_cast<int>(ref.size()) / width;
  std::vector<char> counts(ref.size(), p.column_windows ? 0 : 1);
  if (p.column_windows) {
    const ColumnBlocks blocks(p, height);
    for (int b = 0; b < blocks.count; ++b)
      std::fill_n(counts.begin() + static_cast<long>(blocks.begin(b)) * width, width, 1);
  }
  for (std::size_t i = 0; i < ref.size() && i < dev.size(); ++i) {
    const bool a = !std::isnan(ref[i]), b = !std::isnan(dev[i]);
    if (counts[i]) {
      ++c.windows;
      c.refined += a;
      c.one_side += a != b;
    } else if (a != b) {
      c.one_side += 1;  // a block's later row where its first agreed: each such row counts
    }
    if (a && b) c.worst = std::max(c.worst, std::abs(static_cast<double>(ref[i]) - dev[i]));
  }
  if (ref.size() != dev.size()) c.worst = 1e30;
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  std::string device;
  unsigned seed = 1;
  int cases = 12;
  int aggregate_threads = 0, wta_threads = 0, aggregate_lanes = 0, dic_window_subgroups = 0;
  bool aggregate_half = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--device" && i + 1 < argc) device = argv[++i];
    else if (a == "--seed" && i + 1 < argc) seed = static_cast<unsigned>(std::strtoul(argv[++i], nullptr, 10));
    else if (a == "--cases" && i + 1 < argc) cases = std::atoi(argv[++i]);
    else if (a == "--aggregate-threads" && i + 1 < argc) aggregate_threads = std::atoi(argv[++i]);
    else if (a == "--wta-threads" && i + 1 < argc) wta_threads = std::atoi(argv[++i]);
    else if (a == "--aggregate-half") aggregate_half = true;
    else if (a == "--aggregate-lanes" && i + 1 < argc) aggregate_lanes = std::atoi(argv[++i]);
    else if (a == "--dic-window-subgroups" && i + 1 < argc) dic_window_subgroups = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr,
                   "usage: %s [--device NAME|INDEX] [--seed N] [--cases N] [--aggregate-threads N] [--wta-threads N] "
                   "[--aggregate-half] [--aggregate-lanes N] [--dic-window-subgroups N]\n",
                   argv[0]);
      return 2;
    }
  }
  // Fixed awkward cases first, then random ones.
  std::vector<Case> list = {{631, 479, 5, 64}, {641, 48, 37, 128}, {97, 33, 0, 16}, {13, 7, 3, 20}, {300, 64, 0, 256}};
  std::mt19937 rng(seed);
  const auto uni = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  while (static_cast<int>(list.size()) < cases) {  // wide enough that part of each row has the whole band
    const int dmin = uni(0, 30), nd = 2 * uni(1, 64);
    list.push_back({dmin + nd + uni(8, 300), uni(1, 100), dmin, nd});
  }
  list.resize(static_cast<std::size_t>(cases));

  // Skipped only where no Vulkan driver exists; from here on any device error fails the check.
  try {
    if (list_gpu_devices().empty()) {
      std::printf("SKIP: no Vulkan driver: the Vulkan loader finds no device\n");
      return 77;
    }
  } catch (const GpuError& e) {
    std::printf("SKIP: no Vulkan driver: %s\n", e.what());
    return 77;
  }
  VulkanSgmOptions options;
  options.aggregate_threads = aggregate_threads;
  options.wta_threads = wta_threads;
  options.aggregate_half = aggregate_half;
  options.aggregate_lanes = aggregate_lanes;
  options.dic_window_subgroups = dic_window_subgroups;
  std::mt19937 segment_rng(seed * 7919u + 1u);
  std::unique_ptr<VulkanSgm> sgm;
  int failures = 0;
  for (std::size_t k = 0; k < list.size(); ++k) {
    const Case c = list[k];
    SgmConfig params;
    constexpr int kPaths[] = {2, 4, 8};
    params.paths = kPaths[k % 3];
    params.p1 = uni(0, 30);
    params.p2 = uni(params.p1 + 1, kMaxP2);  // the largest keeps path costs at a byte's edge
    params.uniqueness = uni(0, 25);
    params.lr_max_diff = uni(-1, 2);
    params.median = k % 4 != 3;
    if (k % 4 == 1) {  // rows in segments (SgmConfig::segment), with a run-in shorter or longer than one
      params.segment = uni(16, 100);
      params.segment_run_in = uni(0, 80);
    }
    const SgmBand band{c.min_disparity, c.num_disparities};
    DicKernelConfig dic;
    dic.half_window = uni(2, 7);
    dic.half_height = uni(1, 7);
    dic.step = uni(1, 2);
    dic.row_step = uni(1, 2);
    dic.row_begin = uni(0, c.height / 4);
    dic.row_end = c.height - uni(0, c.height / 4);
    dic.first_order = k % 5 != 4;
    dic.max_sigma_px = k % 2 == 0 ? 0.0f : 0.2f;
    // Column windows as the measurer sets them: one block on strips of up to 64 rows (every other such
    // case here; the whole 641x48 strip in case 1), else blocks of random height.
    DicKernelConfig columns = dic;
    columns.column_windows = true;
    columns.column_block_rows = c.height <= 64 && k % 2 == 1 ? 0 : uni(2, 24);
    if (k == 1) {
      columns.row_begin = 0;
      columns.row_end = c.height;
    }
    options.wta_segment = k % 3 == 2 ? std::uniform_int_distribution<int>(16, 200)(segment_rng) : 0;
    try {
      sgm = std::make_unique<VulkanSgm>(device, c.width, c.height, c.num_disparities, options);
    } catch (const GpuError& e) {
      if (k == 0 && aggregate_half && std::string(e.what()).find("shaderFloat16") != std::string::npos) {
        std::printf("SKIP: %s\n", e.what());  // an optional feature the device lacks
        return 77;
      }
      std::printf("FAIL case %zu: %s\n", k, e.what());
      return 1;
    }
    if (k == 0)
      std::printf("device %d: %s%s%s%s; aggregation lines of %d lanes\n", sgm->device().index,
                  describe(sgm->device()).c_str(),
                  aggregate_threads > 0 ? ("; aggregation workgroup " + std::to_string(aggregate_threads)).c_str() : "",
                  wta_threads > 0 ? ("; winner-takes-all workgroup " + std::to_string(wta_threads)).c_str() : "",
                  aggregate_half ? "; aggregation in half floats" : "", sgm->aggregate_lanes());
    // Gentle waves down two cases in three, so that column windows spanning many rows refine; the rest
    // keep waves that reject many of them.
    // Raw cases: the pair is rendered a little larger than the strip (or smaller: the maps then reach
    // far past the border), and both images go through their own maps.
    const bool raw = k % 2 == 0;
    const int raw_w = raw ? std::max(1, c.width + uni(-4, 24)) : c.width;
    // A strip of a much taller image, as the daemon's, every fourth case: only the rows the maps reach
    // are uploaded.
    const int raw_h = !raw                           ? c.height
                      : c.height <= 64 && k % 4 == 0 ? 8 * c.height
                                                     : std::max(1, c.height + uni(-2, 30));
    const auto pair = tools::synthetic_pair(raw_w, raw_h, c.min_disparity, c.num_disparities,
                                            seed + static_cast<unsigned>(k), k % 3 != 2 ? 1.0f : -1.0f);
    const ImageView raw_l{pair.left.data(), raw_w, raw_h, static_cast<std::size_t>(raw_w)};
    const ImageView raw_r{pair.right.data(), raw_w, raw_h, static_cast<std::size_t>(raw_w)};
    RectifyMaps maps;
    std::vector<std::uint8_t> rect_l, rect_r;
    if (raw) {
      maps = RectifyMaps{raw_w,
                         raw_h,
                         c.width,
                         c.height,
                         warped_map(c.width, c.height, raw_w, raw_h, false, rng),
                         warped_map(c.width, c.height, raw_w, raw_h, true, rng)};
      rectify_reference(raw_l, maps.left, c.width, c.height, rect_l);
      rectify_reference(raw_r, maps.right, c.width, c.height, rect_r);
      try {
        sgm->set_rectification(maps);
      } catch (const GpuError& e) {
        std::printf("FAIL case %zu: %s\n", k, e.what());
        return 1;
      }
    }
    // What the reference matches: the raw pair itself, or its rectified strips.
    const ImageView l = raw ? ImageView{rect_l.data(), c.width, c.height, static_cast<std::size_t>(c.width)} : raw_l;
    const ImageView r = raw ? ImageView{rect_r.data(), c.width, c.height, static_cast<std::size_t>(c.width)} : raw_r;
    SgmStages ref, dev;
    sgm_reference(l, r, band, params, ref);
    bspline_reference(l, ref.spline_left);
    bspline_reference(r, ref.spline_right);
    dic_reference(l, ref.spline_left, ref.spline_right, ref.disparity, dic, ref.refined);
    std::vector<float> ref_columns, dev_columns(ref.disparity.size());
    dic_reference(l, ref.spline_left, ref.spline_right, ref.disparity, columns, ref_columns);
    GpuStatus s = sgm->compute_stages(raw ? raw_l : l, raw ? raw_r : r, band, params, &dic, dev, raw);
    if (s == GpuStatus::Ok && raw) {
      int ticket = -1;
      s = sgm->submit_raw(raw_l, raw_r, &band, params, &columns, ticket);
      if (s == GpuStatus::Ok) s = sgm->collect(ticket, dev_columns.data(), static_cast<std::size_t>(c.width));
    } else if (s == GpuStatus::Ok) {
      s = sgm->compute(l, r, band, params, &columns, dev_columns.data(), static_cast<std::size_t>(c.width));
    }
    // The coarse pass: the reference averages the reference strips and matches them.
    bool coarse_ok = true;
    std::string coarse_note;
    if (s == GpuStatus::Ok && raw) {
      const int scale = uni(1, 4);
      const CoarseGrid grid = coarse_grid(c.width, c.height, scale);
      const SgmBand coarse_band{c.min_disparity / scale, std::max(2, c.num_disparities / scale / 2 * 2)};
      if (grid.width >= 1 && grid.height >= 1 &&
          check_sgm_input(grid.width, grid.height, coarse_band, params).empty()) {
        std::vector<std::uint8_t> ref_l, ref_r, dev_l(static_cast<std::size_t>(grid.width) * grid.height);
        downsample_reference(l, grid, ref_l);
        downsample_reference(r, grid, ref_r);
        SgmStages coarse_ref;
        sgm_reference(ImageView{ref_l.data(), grid.width, grid.height, static_cast<std::size_t>(grid.width)},
                      ImageView{ref_r.data(), grid.width, grid.height, static_cast<std::size_t>(grid.width)},
                      coarse_band, params, coarse_ref);
        std::vector<float> dev_d(dev_l.size());
        StripsOut out;
        out.coarse_left = dev_l.data();
        out.coarse_stride = static_cast<std::size_t>(grid.width);
        int ticket = -1;
        s = sgm->submit_coarse(raw_l, raw_r, scale, coarse_band, params, ticket);
        if (s == GpuStatus::Ok)
          s = sgm->collect(ticket, dev_d.data(), static_cast<std::size_t>(grid.width), nullptr, &out);
        coarse_ok = first_difference(ref_l, dev_l) < 0 && first_difference(coarse_ref.disparity, dev_d) < 0;
        coarse_note = "; coarse " + std::to_string(grid.width) + "x" + std::to_string(grid.height) +
                      (coarse_ok ? " identical" : " DIFFERS");
      }
    }
    std::printf(
        "case %2zu: %4dx%-4d%s band %3d+%-3d paths %d%s%s P1 %2d P2 %3d uniq %2d lr %2d median %d: ", k, c.width,
        c.height, raw ? (" from " + std::to_string(raw_w) + "x" + std::to_string(raw_h) + " raw").c_str() : "",
        c.min_disparity, c.num_disparities, params.paths,
        params.segment > 0 ? (" rows in " + std::to_string(params.segment) + "+" +
                              std::to_string(params.segment_run_in) + " px segments")
                                 .c_str()
                           : "",
        sgm->wta_segment() > 0 ? (" WTA in " + std::to_string(sgm->wta_segment()) + " px segments").c_str() : "",
        params.p1, params.p2, params.uniqueness, params.lr_max_diff, params.median ? 1 : 0);
    if (s != GpuStatus::Ok) {
      std::printf("FAIL (%s)\n", std::string(to_string(s)).c_str());
      ++failures;
      continue;
    }
    const long diffs[] = {raw ? first_difference(rect_l, dev.rectified_left) : -1,
                          raw ? first_difference(rect_r, dev.rectified_right) : -1,
                          first_difference(ref.census_left, dev.census_left),
                          first_difference(ref.census_right, dev.census_right),
                          first_difference(ref.sums, dev.sums),
                          first_difference(ref.disparity_left, dev.disparity_left),
                          first_difference(ref.disparity_right, dev.disparity_right),
                          first_difference(ref.disparity, dev.disparity)};
    const char* names[] = {"rectified left", "rectified right",    "census left", "census right",
                           "path sums",      "WTA/sub-pixel left", "WTA right",   "LR check/median"};
    bool ok = coarse_ok;
    if (!coarse_ok) std::printf("FAIL\n    coarse pass (band estimate) differs\n");
    for (int i = 0; i < 8; ++i) {
      if (diffs[i] < 0) continue;
      if (ok) std::printf("FAIL\n");
      ok = false;
      std::printf("    %s differs first at element %ld\n", names[i], diffs[i]);
    }
    const double spline =
        std::max(max_relative(dev.spline_left, ref.spline_left), max_relative(dev.spline_right, ref.spline_right));
    long valid = 0;
    for (const float d : ref.disparity) valid += !std::isnan(d);
    const DicComparison pixels = compare_dic(ref.refined, dev.refined, c.width, dic);
    const DicComparison cols = compare_dic(ref_columns, dev_columns, c.width, columns);
    const bool dic_ok = spline <= 1e-3 && pixels.within(1.0 / 128) && cols.within(1.0 / 128);
    if (!dic_ok) {
      if (ok) std::printf("FAIL\n");
      ok = false;
      std::printf("    DIC: spline %.2g relative\n", spline);
      for (const auto& [name, cmp] : {std::pair{"per pixel", pixels}, std::pair{"column windows", cols}})
        std::printf("    DIC %s: refined %ld of %ld windows, on one side only %ld, largest difference %.4f px\n", name,
                    cmp.refined, cmp.windows, cmp.one_side, cmp.worst);
      // Where the left spline differs most, and how many coefficients are off: a diagnosis for devices.
      std::size_t at = 0;
      const double left = max_relative(dev.spline_left, ref.spline_left, &at);
      if (left > 1e-3 && at < ref.spline_left.size()) {
        const auto width = static_cast<std::size_t>(c.width);
        std::printf("    left spline: worst at x %zu y %zu (device %.4f, reference %.4f), %ld of %zu over 1e-3\n",
                    at % width, at / width, dev.spline_left[at], ref.spline_left[at],
                    count_over(dev.spline_left, ref.spline_left, 1e-3), ref.spline_left.size());
      }
    }
    if (ok)
      std::printf(
          "identical (%.0f%% valid); DIC per pixel within %.5f px, %ld of %ld on one side only; column windows "
          "(%s) within %.5f px, %ld of %ld on one side only%s\n",
          100.0 * static_cast<double>(valid) / static_cast<double>(ref.disparity.size()), pixels.worst, pixels.one_side,
          pixels.refined,
          columns.column_block_rows > 0 ? ("blocks of " + std::to_string(columns.column_block_rows) + " rows").c_str()
                                        : "one block",
          cols.worst, cols.one_side, cols.refined, coarse_note.c_str());
    failures += !ok;
  }
  std::printf("%s: %d of %zu cases differ\n", failures ? "FAIL" : "PASS", failures, list.size());
  return failures ? 1 : 0;
}
