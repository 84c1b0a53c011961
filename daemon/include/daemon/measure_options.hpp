#pragma once
// Command-line options that configure the per-frame measurement, shared by `run` and `replay`.
#include <string>

#include <CLI/CLI.hpp>

#include "measurement/measurer.hpp"

namespace rutd {

struct MeasureOptions {
  MeasurerConfig config;
  std::string engine = "sgbm3way";
  bool no_dic = false;
  bool no_low_texture_read = false;
  int strip_rows = 0;
  std::string strip_first_row = "centred";  // or a rectified row number
};

void add_measure_options(CLI::App& cmd, MeasureOptions& options);
// Turns parsed options into a MeasurerConfig; throws CLI::ValidationError on contradictory values.
MeasurerConfig resolve_measure_options(const MeasureOptions& options);

}  // namespace rutd
