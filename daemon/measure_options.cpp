#include "daemon/measure_options.hpp"

namespace rutd {

void add_measure_options(CLI::App& cmd, MeasureOptions& o) {
  cmd.add_option("--engine", o.engine, "Disparity engine: bm, sgbm, sgbm3way, hh4, hh, gpu, sgmref")
      ->check(CLI::IsMember({"bm", "sgbm", "sgbm3way", "hh4", "hh", "gpu", "sgmref"}))
      ->capture_default_str();
  cmd.add_flag("--no-dic", o.no_dic,
               "Skip the sub-pixel refinement by digital image correlation (faster, biased toward whole pixels)");
  cmd.add_option("--strip-rows", o.strip_rows,
                 "Rows of the rectified image measured (0: a tenth of the height, 20..64)")
      ->check(CLI::Range(0, 4096));
  cmd.add_option("--strip-row0", o.strip_row0, "First rectified row of the strip (-1: centred)")
      ->check(CLI::Range(-1, 65535));
  cmd.add_option("--near-mm", o.config.range.near_mm, "Nearest plausible camera-to-terrain distance, mm")
      ->check(CLI::Range(20.0, 20000.0))
      ->capture_default_str();
  cmd.add_option("--far-mm", o.config.range.far_mm, "Farthest plausible camera-to-terrain distance, mm")
      ->check(CLI::Range(20.0, 20000.0))
      ->capture_default_str();
  cmd.add_option("--min-width-mm", o.config.rut.min_rut_width_mm, "Smallest expected rut width, mm")
      ->check(CLI::Range(10.0, 5000.0))
      ->capture_default_str();
  cmd.add_option("--max-width-mm", o.config.rut.max_rut_width_mm, "Largest expected rut width, mm")
      ->check(CLI::Range(10.0, 5000.0))
      ->capture_default_str();
}

MeasurerConfig resolve_measure_options(const MeasureOptions& o, cv::Size image_size) {
  MeasurerConfig c = o.config;
  c.engine = *parse_engine(o.engine);  // IsMember above guarantees a known name
  c.dic = !o.no_dic;
  if (c.range.near_mm >= c.range.far_mm) throw CLI::ValidationError("--near-mm", "must be smaller than --far-mm");
  if (c.rut.min_rut_width_mm >= c.rut.max_rut_width_mm)
    throw CLI::ValidationError("--min-width-mm", "must be smaller than --max-width-mm");
  if (o.strip_rows > 0 || o.strip_row0 >= 0) {
    c.strip.rows = o.strip_rows > 0 ? o.strip_rows : default_strip(image_size).rows;
    c.strip.row0 = o.strip_row0;  // -1: centred
  }
  return c;
}

}  // namespace rutd
