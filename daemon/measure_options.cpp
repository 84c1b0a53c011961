#include "daemon/measure_options.hpp"

#include <exception>
#include <string>

namespace rutd {

void add_measure_options(CLI::App& cmd, MeasureOptions& o) {
  cmd.add_option("--engine", o.engine, "Disparity engine: bm, sgbm, sgbm3way, hh4, hh, gpu, sgmref")
      ->check(CLI::IsMember({"bm", "sgbm", "sgbm3way", "hh4", "hh", "gpu", "sgmref"}))
      ->capture_default_str();
  cmd.add_flag("--no-dic", o.no_dic,
               "Skip the sub-pixel refinement by digital image correlation (faster, biased toward whole pixels)");
  cmd.add_option("--gap-fill-window", o.config.gap_fill_half_window,
                 "Half width (px, 6..15) of the DIC windows that read the gaps of a depth UNCERTAIN only for its gaps "
                 "again (measurement.gap_fill_half_window); 0: off")
      ->check(CLI::Range(0, 15))
      ->capture_default_str();
  cmd.add_flag("--no-low-texture-read", o.no_low_texture_read,
               "Do not read a frame refused for its unmatched DIC windows again with the images' noise judging the "
               "windows' correlation (measurement.low_texture_read: false)");
  cmd.add_option("--strip-rows", o.strip_rows,
                 "Rows of the rectified image measured (0: a tenth of the height, 20..64)")
      ->check(CLI::Range(0, 4096));
  cmd.add_option("--strip-first-row", o.strip_first_row, "First rectified row of the strip: centred, or a row number")
      ->capture_default_str();
  // The option of older releases, refused with its replacement (hidden from --help).
  cmd.add_option_function<std::string>("--strip-row0",
                                       [](const std::string&) {
                                         throw CLI::ValidationError(
                                             "--strip-row0", "replaced by --strip-first-row (centred or a row number)");
                                       })
      ->group("");
  cmd.add_option("--guard-strips", o.config.strip.guards,
                 "Guard strips (0..2) measured a quarter of the image height above and below the strip on the frames "
                 "it finds OK within guard_after_water_s of a frame flagged Water; a frame is refused where one finds "
                 "water it did not")
      ->check(CLI::Range(0, 2))
      ->capture_default_str();
  cmd.add_flag("--guards-always", o.config.strip.guards_always,
               "Guard strips on every frame the strip finds OK, not only after water was seen");
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

MeasurerConfig resolve_measure_options(const MeasureOptions& o) {
  MeasurerConfig c = o.config;
  c.engine = *parse_engine(o.engine);  // IsMember above guarantees a known name
  c.dic = !o.no_dic;
  if (o.no_low_texture_read) c.low_texture_read = false;
  if (c.range.near_mm >= c.range.far_mm) throw CLI::ValidationError("--near-mm", "must be smaller than --far-mm");
  if (const std::string problem = gap_fill_window_problem(c.gap_fill_half_window, c.dic_config.half_window);
      !problem.empty())
    throw CLI::ValidationError("--gap-fill-window", problem);
  if (c.rut.min_rut_width_mm >= c.rut.max_rut_width_mm)
    throw CLI::ValidationError("--min-width-mm", "must be smaller than --max-width-mm");
  c.strip.rows = o.strip_rows;
  c.strip.first_row.reset();
  if (o.strip_first_row != "centred") {
    std::size_t used = 0;
    int row = -1;
    try {
      row = std::stoi(o.strip_first_row, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != o.strip_first_row.size() || row < 0 || row > 65535)
      throw CLI::ValidationError("--strip-first-row",
                                 "expected centred or a row number 0..65535, got '" + o.strip_first_row + "'" +
                                     (o.strip_first_row == "-1" ? " (-1 for centred is now written centred)" : ""));
    c.strip.first_row = row;
  }
  return c;
}

}  // namespace rutd
