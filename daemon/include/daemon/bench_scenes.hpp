#pragma once
// `rutd bench --scenes`: every scene of the scene matrix (daemon/scene_matrix.hpp) rendered and measured
// as `rutd replay` measures a recording, frame by frame against the renderer's truth; prints the scene
// x outcome table (frames published OK within 1 mm of the soil's depth, OK beyond it, refused with which
// status and conditions) and a summary per group, or with `json` one JSON object per scene on stdout.
// Figures are reported, never judged here: the tests assert them.
#include <string>

#include "measurement/measurer.hpp"

namespace rutd {

struct BenchScenesOptions {
  std::string only;  // ECMAScript regex on the scene names; empty: every scene
  int frames = 4;    // pairs per scene
  std::string engine = "sgbm3way";
  bool dic = true;
  bool json = false;
  int guards = StripConfig{}.guards;  // StripConfig::guards
  bool guards_always = false;         // StripConfig::guards_always
};
// Throws CLI::ValidationError for a bad --only pattern or one that selects nothing.
int run_bench_scenes(const BenchScenesOptions& o);

}  // namespace rutd
