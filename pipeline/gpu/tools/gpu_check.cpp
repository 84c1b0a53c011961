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
// output. Exit status: 0 all equal, 1 a difference, 2 usage, 77 no usable Vulkan device (CTest's skip
// code). Needs only the Vulkan loader at run time.
//   rutd-gpu-check [--device NAME|INDEX] [--seed N] [--cases N] [--aggregate-threads N]
// --aggregate-threads: the aggregation's workgroup size (VulkanSgm); several subgroups' worth checks its
// shared-memory path.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <string>

#include "gpu/dic.hpp"
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
DicComparison compare_dic(const std::vector<float>& ref, const std::vector<float>& dev, int width, const DicParams& p) {
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
  int aggregate_threads = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--device" && i + 1 < argc) device = argv[++i];
    else if (a == "--seed" && i + 1 < argc) seed = static_cast<unsigned>(std::strtoul(argv[++i], nullptr, 10));
    else if (a == "--cases" && i + 1 < argc) cases = std::atoi(argv[++i]);
    else if (a == "--aggregate-threads" && i + 1 < argc) aggregate_threads = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: %s [--device NAME|INDEX] [--seed N] [--cases N] [--aggregate-threads N]\n", argv[0]);
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

  std::unique_ptr<VulkanSgm> sgm;
  int failures = 0;
  for (std::size_t k = 0; k < list.size(); ++k) {
    const Case c = list[k];
    SgmParams params;
    constexpr int kPaths[] = {2, 4, 8};
    params.paths = kPaths[k % 3];
    params.p1 = uni(0, 30);
    params.p2 = uni(params.p1 + 1, kMaxP2);  // the largest keeps path costs at a byte's edge
    params.uniqueness = uni(0, 25);
    params.lr_max_diff = uni(-1, 2);
    params.median = k % 4 != 3;
    const SgmBand band{c.min_disparity, c.num_disparities};
    DicParams dic;
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
    DicParams columns = dic;
    columns.column_windows = true;
    columns.column_block_rows = c.height <= 64 && k % 2 == 1 ? 0 : uni(2, 24);
    if (k == 1) {
      columns.row_begin = 0;
      columns.row_end = c.height;
    }
    try {
      sgm = std::make_unique<VulkanSgm>(device, c.width, c.height, c.num_disparities, 0, aggregate_threads);
    } catch (const GpuError& e) {
      if (k == 0) {
        std::printf("SKIP: no usable Vulkan device: %s\n", e.what());
        return 77;
      }
      std::printf("FAIL case %zu: %s\n", k, e.what());
      return 1;
    }
    if (k == 0)
      std::printf(
          "device %d: %s (%s, subgroup %u%s)\n", sgm->device().index, sgm->device().name.c_str(),
          sgm->device().type.c_str(), sgm->device().subgroup_size,
          aggregate_threads > 0 ? (", aggregation workgroup " + std::to_string(aggregate_threads)).c_str() : "");
    // Gentle waves down two cases in three, so that column windows spanning many rows refine; the rest
    // keep waves that reject many of them.
    const auto pair = tools::synthetic_pair(c.width, c.height, c.min_disparity, c.num_disparities,
                                            seed + static_cast<unsigned>(k), k % 3 != 2 ? 1.0f : -1.0f);
    const ImageView l{pair.left.data(), c.width, c.height, static_cast<std::size_t>(c.width)};
    const ImageView r{pair.right.data(), c.width, c.height, static_cast<std::size_t>(c.width)};
    SgmStages ref, dev;
    sgm_reference(l, r, band, params, ref);
    bspline_reference(l, ref.spline_left);
    bspline_reference(r, ref.spline_right);
    dic_reference(l, ref.spline_left, ref.spline_right, ref.disparity, dic, ref.refined);
    std::vector<float> ref_columns, dev_columns(ref.disparity.size());
    dic_reference(l, ref.spline_left, ref.spline_right, ref.disparity, columns, ref_columns);
    GpuStatus s = sgm->compute_stages(l, r, band, params, &dic, dev);
    if (s == GpuStatus::Ok)
      s = sgm->compute(l, r, band, params, &columns, dev_columns.data(), static_cast<std::size_t>(c.width));
    std::printf("case %2zu: %4dx%-4d band %3d+%-3d paths %d P1 %2d P2 %3d uniq %2d lr %2d median %d: ", k, c.width,
                c.height, c.min_disparity, c.num_disparities, params.paths, params.p1, params.p2, params.uniqueness,
                params.lr_max_diff, params.median ? 1 : 0);
    if (s != GpuStatus::Ok) {
      std::printf("FAIL (%s)\n", std::string(to_string(s)).c_str());
      ++failures;
      continue;
    }
    const long diffs[] = {first_difference(ref.census_left, dev.census_left),
                          first_difference(ref.census_right, dev.census_right),
                          first_difference(ref.sums, dev.sums),
                          first_difference(ref.disparity_left, dev.disparity_left),
                          first_difference(ref.disparity_right, dev.disparity_right),
                          first_difference(ref.disparity, dev.disparity)};
    const char* names[] = {"census left",        "census right", "path sums",
                           "WTA/sub-pixel left", "WTA right",    "LR check/median"};
    bool ok = true;
    for (int i = 0; i < 6; ++i) {
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
          "(%s) within %.5f px, %ld of %ld on one side only\n",
          100.0 * static_cast<double>(valid) / static_cast<double>(ref.disparity.size()), pixels.worst, pixels.one_side,
          pixels.refined,
          columns.column_block_rows > 0 ? ("blocks of " + std::to_string(columns.column_block_rows) + " rows").c_str()
                                        : "one block",
          cols.worst, cols.one_side, cols.refined);
    failures += !ok;
  }
  std::printf("%s: %d of %zu cases differ\n", failures ? "FAIL" : "PASS", failures, list.size());
  return failures ? 1 : 0;
}
