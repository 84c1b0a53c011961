#pragma once
// truth.csv: the ground truth of a synthetic recording, one line per stereo pair (RutTruth). Header:
//   index,t_ns,depth_mm,width_mm,left_pile_mm,right_pile_mm,area_mm2,ground_slope_deg,center_x_mm,
//   tread_depth_mm,y_mm,water_depth_mm,waterline_depth_mm,waterline_left_x_mm,waterline_right_x_mm,
//   right_delay_ns,exposure,gain
// (one line in the file). Numbers are written in the shortest form that reads back to the same double;
// a waterline of a dry rut is "nan". Files written before the water and camera columns (the first 11
// columns only) are read too, with a dry rut, triggered cameras, exposure and gain 1.
#include <cstdint>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "synthetic/synthetic_scene.hpp"

namespace rutd {

inline constexpr std::string_view kTruthCsvHeader =
    "index,t_ns,depth_mm,width_mm,left_pile_mm,right_pile_mm,area_mm2,ground_slope_deg,center_x_mm,"
    "tread_depth_mm,y_mm,water_depth_mm,waterline_depth_mm,waterline_left_x_mm,waterline_right_x_mm,"
    "right_delay_ns,exposure,gain";
// The header of files written before the water and camera columns.
inline constexpr std::string_view kTruthCsvHeaderDry =
    "index,t_ns,depth_mm,width_mm,left_pile_mm,right_pile_mm,area_mm2,ground_slope_deg,center_x_mm,"
    "tread_depth_mm,y_mm";

// Not thread-safe. Each line is flushed, so a file cut off by a crash holds every appended line.
class TruthCsvWriter {
 public:
  // Creates or truncates the file and writes the header; throws InputError(path, "file", ...) if it
  // cannot.
  explicit TruthCsvWriter(const std::string& path);
  // Appends one line (no allocation once the stream is warm). Returns false if the write failed.
  bool append(const RutTruth& truth, std::int64_t t_ns);

 private:
  std::string path_;
  std::ofstream out_;
  std::string line_;  // reused for every line
};

// Reads a whole truth.csv. Throws InputError naming the file and "line N" (1-based, the header is
// line 1) for a wrong header, a wrong number of fields or a field that is not a number; and
// (file, "file") when it cannot be opened or is empty. `t_ns`, when given, receives each line's t_ns.
std::vector<RutTruth> read_truth_csv(const std::string& path, std::vector<std::int64_t>* t_ns = nullptr);
// The same from a stream the caller opened; `path` names it in messages.
std::vector<RutTruth> read_truth_csv(std::istream& in, const std::string& path, std::vector<std::int64_t>* t_ns);

}  // namespace rutd
