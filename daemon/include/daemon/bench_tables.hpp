#pragma once
// `rutd bench --tables` (the seed paper's Tables 1-3 on this machine) and `rutd bench --pair` (every
// engine on a user's rectified pair with ground truth). Both print a text table, or with `json` one JSON
// object per row on stdout. Throw InputError / CLI::ValidationError for bad input, naming it.
#include <optional>
#include <string>
#include <vector>

namespace rutd {

struct BenchTablesOptions {
  std::vector<int> tables;                                                  // 1, 2, 3
  std::vector<std::string> engines{"bm", "sgbm", "sgbm3way", "hh4", "hh"};  // as --engine
  std::vector<std::string> sizes{"640x480", "1280x1024"};                   // WIDTHxHEIGHT
  double seconds = 5;                                                       // Table 1: per configuration
  bool json = false;
};
int run_bench_tables(const BenchTablesOptions& o);

struct BenchPairOptions {
  std::string left, right, gt;    // rectified images (grey or colour) and ground-truth disparity image
  double gt_scale = 1;            // stored value / gt_scale = disparity, px; 0 = unknown
  std::optional<int> dmin, dmax;  // searched disparities, px; default: the ground truth's range
  std::vector<std::string> engines{"bm", "sgbm", "sgbm3way", "hh4", "hh"};
  bool json = false;
};
int run_bench_pair(const BenchPairOptions& o);

}  // namespace rutd
