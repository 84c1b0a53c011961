// rutd map RECORDING|CSV... --out DIR: where the ruts are. Takes one drive per argument, in the order
// driven: a recording folder with gps.jsonl (measured here as `rutd replay REC --positions` does, into
// DIR/NAME.measured.csv, and with its vehicle.log into the distance segments DIR/NAME.segments.csv), a
// segment CSV with positions (trafficability.segments_csv of a run with gps, `rutd replay --positions
// --segments`), or a measurement CSV with positions (`rutd replay --positions --out`, or sinks.csv with
// sinks.csv_positions), and writes into DIR:
//   track.geojson     one Point feature per track piece (WGS84 lon/lat) with its drive, pass, depth
//                     (mean, max), depth uncertainty, horizontal error, heading, advisory and the sinkage
//                     increase over the earlier pass where matched; opens in QGIS
//   depth_by_pass.png the mean depth along each drive's track (PLplot)
//   matched.csv       the matched pieces (trafficability/passes.hpp): which earlier piece, distance,
//                     allowed error, heading difference, pass, sinkage increase and its uncertainty
// A track piece is a distance segment (trafficability/: segment_length_m of new ground, with its advisory and
// the position at its middle) where the drive had a vehicle speed; without one (a measurement CSV, a
// recording without vehicle.log), the stretch between two receiver epochs: the consecutive measurements
// that share one fix, with their mean depth, its standard error as the uncertainty and the distance between
// fixes as its length; advisory UNKNOWN. The GeoJSON's `piece_kind` says which ("segment" or "fix").
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/input_error.hpp"
#include "daemon/commands.hpp"
#include "daemon/measure_options.hpp"
#include "daemon/replay.hpp"
#include "plots/plots.hpp"
#include "recording/measurement_csv.hpp"
#include "recording/segment_csv_sink.hpp"
#include "trafficability/passes.hpp"

namespace rutd {
namespace {

struct MapOptions {
  std::vector<std::string> drives;  // recording folders or measurement CSVs
  std::string out;
  PassConfig passes;
  double max_fix_age_ms = GpsConfig{}.max_fix_age_ms;
  std::string config;  // the trafficability section for recordings' segments; empty: the embedded default
  MeasureOptions measure;
};

// Where a drive's track comes from: its segment CSV when it has one, else its measurement CSV.
struct DriveFiles {
  std::string measurements;
  std::string segments;
};

bool is_segment_csv(const std::string& path) {
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  return header.rfind("index,start_m,end_m,", 0) == 0;
}

// The argument itself, or what measuring the recording it names wrote.
DriveFiles drive_files(const std::string& drive, const MapOptions& o) {
  if (!std::filesystem::is_directory(drive)) {
    if (is_segment_csv(drive)) return {{}, drive};
    return {drive, {}};
  }
  ReplayOptions r;
  r.dir = drive;
  std::string name = std::filesystem::path(drive).filename().string();
  if (name.empty()) name = std::filesystem::path(drive).parent_path().filename().string();
  r.out = (std::filesystem::path(o.out) / (name + ".measured.csv")).string();
  if (std::filesystem::exists(std::filesystem::path(drive) / "vehicle.log"))
    r.segments = (std::filesystem::path(o.out) / (name + ".segments.csv")).string();
  r.config = o.config;
  r.positions = true;
  r.max_fix_age_ms = o.max_fix_age_ms;
  r.measure = o.measure;
  if (replay_recording(r) != 0)
    spdlog::warn("{}: some pairs could not be measured (see above); mapping the others", drive);
  return {r.out, r.segments};
}

// Track pieces of one drive from its measurement rows (see the file comment).
std::vector<Segment> pieces_of(const MeasurementCsv& csv) {
  std::vector<Segment> pieces;
  std::vector<double> depths;
  auto close = [&](Segment& s) {
    if (!depths.empty()) {
      double sum = 0, sq = 0, max = -INFINITY;
      for (double d : depths) sum += d, sq += d * d, max = std::max(max, d);
      const double n = static_cast<double>(depths.size());
      s.mean_depth_mm = sum / n;
      s.max_depth_mm = max;
      const double var = depths.size() > 1 ? std::max(0.0, (sq - sum * sum / n) / (n - 1)) : NAN;
      s.depth_uncertainty_mm = std::sqrt(var / n);
    }
    depths.clear();
    pieces.push_back(s);
  };
  Segment current;
  bool open = false;
  double along = 0.0;
  for (const MeasurementRow& r : csv.rows) {
    if (!r.position.valid()) continue;
    const bool same_fix = open && r.position.latitude_deg == current.position.latitude_deg &&
                          r.position.longitude_deg == current.position.longitude_deg;
    if (!same_fix) {
      if (open) {
        along += ground_distance_m(current.position, r.position);
        current.end_m = along;
        close(current);
      }
      current = Segment{};
      current.index = pieces.size();
      current.start_m = along;
      current.position = r.position;
      current.t_start_ns = r.t_ns;
      open = true;
    }
    current.t_end_ns = r.t_ns;
    ++current.frames;
    if (r.measurement.status == RutStatus::Ok && std::isfinite(r.measurement.depth_mm))
      depths.push_back(r.measurement.depth_mm);
    else ++current.refused;
  }
  if (open) {
    current.end_m = along + (pieces.empty() ? 0.0 : pieces.back().end_m - pieces.back().start_m);
    close(current);
  }
  return pieces;
}

std::string number(double v, int decimals) {
  if (!std::isfinite(v)) return "null";
  return fmt::format("{:.{}f}", v, decimals);
}

// A JSON string's content: file names may hold quotes or backslashes.
std::string json_text(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"' || c == '\\') out.push_back('\\');
    if (static_cast<unsigned char>(c) >= 0x20) out.push_back(c);
  }
  return out;
}

void write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw InputError(path.string(), "--out", "cannot write");
}

int run_map(const MapOptions& o) {
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec) throw InputError(o.out, "--out", "cannot create the folder: " + ec.message());
  std::vector<std::vector<Segment>> drives;
  std::vector<bool> of_segments;
  for (const std::string& drive : o.drives) {
    const DriveFiles files = drive_files(drive, o);
    if (!files.segments.empty()) {
      drives.push_back(read_segment_csv(files.segments));  // throws InputError naming file, line and column
      of_segments.push_back(true);
      std::size_t located = 0;
      for (const Segment& s : drives.back()) located += s.position.valid();
      spdlog::info("{}: {} distance segments, {} with a position", files.segments, drives.back().size(), located);
      if (located == 0) spdlog::warn("{}: no segment with a position; nothing to map from it", files.segments);
      continue;
    }
    const MeasurementCsv csv = read_measurement_csv(files.measurements);  // throws InputError naming file and line
    if (!csv.has_positions)
      throw InputError(files.measurements, "line 1",
                       "no position columns (measure with positions: rutd replay --positions)");
    drives.push_back(pieces_of(csv));
    of_segments.push_back(false);
    spdlog::info("{}: no vehicle speed, so {} pieces between fixes (advisory UNKNOWN)", files.measurements,
                 drives.back().size());
    if (drives.back().empty())
      spdlog::warn("{}: no measurement with a position; nothing to map from it", files.measurements);
  }
  const PassNumbering passes = number_passes(drives, o.passes);

  // Sinkage increase per piece, where matched.
  std::vector<std::vector<double>> increase(drives.size()), increase_u(drives.size());
  for (std::size_t d = 0; d < drives.size(); ++d) {
    increase[d].assign(drives[d].size(), NAN);
    increase_u[d].assign(drives[d].size(), NAN);
    for (const SegmentMatch& m : passes.matches[d]) {
      increase[d][m.later] = m.sinkage_increase_mm;
      increase_u[d][m.later] = m.sinkage_increase_uncertainty_mm;
    }
  }

  std::ostringstream geo;
  geo << R"({"type":"FeatureCollection","features":[)";
  bool first = true;
  std::size_t unlocated = 0;  // segments without a fix (before the first, or gpsd lost): in the CSV, not here
  for (std::size_t d = 0; d < drives.size(); ++d) {
    for (std::size_t i = 0; i < drives[d].size(); ++i) {
      const Segment& s = drives[d][i];
      if (!s.position.valid()) {
        ++unlocated;
        continue;
      }
      geo << (first ? "" : ",") << "\n"
          << R"({"type":"Feature","geometry":{"type":"Point","coordinates":[)" << number(s.position.longitude_deg, 9)
          << "," << number(s.position.latitude_deg, 9) << "]},\"properties\":{\"drive\":" << d << ",\"source\":\""
          << json_text(std::filesystem::path(o.drives[d]).filename().string()) << "\",\"piece\":" << i
          << ",\"piece_kind\":\"" << (of_segments[d] ? "segment" : "fix") << '"' << ",\"pass\":" << s.pass
          << ",\"start_m\":" << number(s.start_m, 3) << ",\"end_m\":" << number(s.end_m, 3)
          << ",\"frames\":" << s.frames << ",\"refused\":" << s.refused
          << ",\"mean_depth_mm\":" << number(s.mean_depth_mm, 3) << ",\"max_depth_mm\":" << number(s.max_depth_mm, 3)
          << ",\"depth_uncertainty_mm\":" << number(s.depth_uncertainty_mm, 3)
          << ",\"horizontal_error_m\":" << number(s.position.horizontal_error_m, 3)
          << ",\"heading_deg\":" << number(s.position.heading_deg, 2) << ",\"advisory\":\"" << to_string(s.advisory)
          << "\",\"sinkage_increase_mm\":" << number(increase[d][i], 3)
          << ",\"sinkage_increase_uncertainty_mm\":" << number(increase_u[d][i], 3) << "}}";
      first = false;
    }
  }
  geo << "\n]}\n";
  write_file(std::filesystem::path(o.out) / "track.geojson", geo.str());

  std::ostringstream matched;
  matched << "drive,piece,earlier_drive,earlier_piece,distance_m,allowed_m,heading_difference_deg,pass,"
             "sinkage_increase_mm,sinkage_increase_uncertainty_mm\n";
  std::size_t n_matched = 0;
  for (std::size_t d = 0; d < drives.size(); ++d) {
    for (std::size_t k = 0; k < passes.matches[d].size(); ++k) {
      const SegmentMatch& m = passes.matches[d][k];
      auto blank = [](double v, int dec) { return std::isfinite(v) ? fmt::format("{:.{}f}", v, dec) : std::string(); };
      matched << d << ',' << m.later << ',' << passes.covering[d][k] << ',' << m.earlier << ','
              << blank(m.distance_m, 3) << ',' << blank(m.allowed_m, 3) << ',' << blank(m.heading_difference_deg, 2)
              << ',' << drives[d][m.later].pass << ',' << blank(m.sinkage_increase_mm, 3) << ','
              << blank(m.sinkage_increase_uncertainty_mm, 3) << '\n';
      ++n_matched;
    }
  }
  write_file(std::filesystem::path(o.out) / "matched.csv", matched.str());

  // Depth along the track, passes over the same ground at the same abscissa: the first drive at its own
  // distance, a later drive's matched pieces at the distance of the piece they matched (recursively, so
  // all on the first drive's); its pieces on ground no earlier drive covered are left out of the plot
  // (they are in the GeoJSON); a drive that matched nothing is drawn at its own distance.
  std::vector<std::vector<double>> along(drives.size());
  std::vector<DepthAlongTrack> lines;
  for (std::size_t d = 0; d < drives.size(); ++d) {
    DepthAlongTrack line;
    std::uint32_t max_pass = 0;
    along[d].assign(drives[d].size(), NAN);
    for (std::size_t i = 0; i < drives[d].size(); ++i) along[d][i] = 0.5 * (drives[d][i].start_m + drives[d][i].end_m);
    if (!passes.matches[d].empty()) {
      along[d].assign(drives[d].size(), NAN);
      for (std::size_t k = 0; k < passes.matches[d].size(); ++k) {
        const SegmentMatch& m = passes.matches[d][k];
        along[d][m.later] = along[passes.covering[d][k]][m.earlier];
      }
    }
    // In order of abscissa (several pieces may sit on one earlier piece), the line broken where it jumps
    // over more than 2 m of ground (between stretches in common).
    std::vector<std::pair<double, double>> points;
    for (std::size_t i = 0; i < drives[d].size(); ++i) {
      if (std::isfinite(along[d][i])) points.emplace_back(along[d][i], drives[d][i].mean_depth_mm);
      max_pass = std::max(max_pass, drives[d][i].pass);
    }
    std::stable_sort(points.begin(), points.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (i > 0 && points[i].first - points[i - 1].first > 2.0) {
        line.distance_m.push_back(NAN);
        line.depth_mm.push_back(NAN);
      }
      line.distance_m.push_back(points[i].first);
      line.depth_mm.push_back(points[i].second);
    }
    line.label = fmt::format("drive {} (up to pass {})", d, max_pass);
    lines.push_back(std::move(line));
  }
  const PlotResult png = plot_depth_along_track((std::filesystem::path(o.out) / "depth_by_pass.png").string(), lines,
                                                "rut depth per drive, passes at the first drive's distance");
  if (!png.ok) spdlog::error("{}", png.error);
  std::size_t pieces = 0;
  for (const auto& d : drives) pieces += d.size();
  spdlog::info(
      "map {}: {} drives, {} track pieces ({} without a position, not in the GeoJSON), {} matched to an "
      "earlier drive",
      o.out, drives.size(), pieces, unlocated, n_matched);
  return png.ok ? 0 : 1;
}

}  // namespace

void add_map_command(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<MapOptions>();
  CLI::App* cmd = app.add_subcommand(
      "map", "Map measured ruts: GeoJSON, depth along the track per pass (PNG) and the matched passes (CSV)");
  cmd->add_option("drives", o->drives,
                  "One per drive, in the order driven: a recording folder with gps.jsonl (measured here, as rutd "
                  "replay --positions does; with vehicle.log, mapped by distance segments), a segment CSV with "
                  "positions, or a measurement CSV with positions")
      ->required()
      ->check(CLI::ExistingPath);
  cmd->add_option("--out", o->out, "Output folder (created if missing)")->required();
  cmd->add_option("--heading-tolerance-deg", o->passes.heading_tolerance_deg,
                  "Passes: headings may differ by at most this")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 180.0));
  cmd->add_option("--min-common-m", o->passes.min_common_m, "Passes: at least this many metres in common")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10000.0));
  cmd->add_option("--max-fix-age-ms", o->max_fix_age_ms,
                  "Recordings: a fix older than this at a pair's capture time is stale (gps.max_fix_age_ms)")
      ->capture_default_str()
      ->check(CLI::Range(10.0, 600000.0));
  cmd->add_option("--config", o->config,
                  "Recordings with vehicle.log: the trafficability section (speed, segment length, advisory) of "
                  "this configuration file; default: the embedded one")
      ->check(CLI::ExistingFile);
  add_measure_options(*cmd, o->measure);
  cmd->callback([o, &exit_code] { exit_code = run_map(*o); });
}

}  // namespace rutd
