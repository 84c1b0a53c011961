// truth.csv writer and reader (synthetic/truth_csv.hpp).
#include "synthetic/truth_csv.hpp"

#include <array>
#include <cerrno>
#include <charconv>
#include <cstring>

#include "core/csv_fields.hpp"
#include "core/input_error.hpp"

namespace rutd {
namespace {

constexpr std::size_t kFields = 18;
constexpr std::size_t kDryFields = 11;  // files written before the water and camera columns
constexpr std::array<std::string_view, kFields> kNames = {"index",
                                                          "t_ns",
                                                          "depth_mm",
                                                          "width_mm",
                                                          "left_pile_mm",
                                                          "right_pile_mm",
                                                          "area_mm2",
                                                          "ground_slope_deg",
                                                          "center_x_mm",
                                                          "tread_depth_mm",
                                                          "y_mm",
                                                          "water_depth_mm",
                                                          "waterline_depth_mm",
                                                          "waterline_left_x_mm",
                                                          "waterline_right_x_mm",
                                                          "right_delay_ns",
                                                          "exposure",
                                                          "gain"};

// Appends `value` in its shortest round-trip form and a comma.
template <class T>
void put(std::string& line, T value) {
  std::array<char, 32> text;  // the longest double is 24 characters
  const auto result = std::to_chars(text.data(), text.data() + text.size(), value);
  line.append(text.data(), result.ptr);
  line.push_back(',');
}

std::string line_field(std::size_t line) { return "line " + std::to_string(line); }

template <class T>
T parse(std::string_view text, const std::string& path, std::size_t line, std::size_t field) {
  T value{};
  if (!parse_csv_number(text, value)) {
    throw InputError(path, line_field(line),
                     "field '" + std::string(kNames[field]) + "': not a number: '" + std::string(text) + "'");
  }
  return value;
}

RutTruth parse_line(std::string_view text, const std::string& path, std::size_t line, std::size_t fields,
                    std::int64_t& t_ns) {
  std::string_view f[kFields];
  const std::size_t count = split_csv_fields(text, f, kFields);
  if (count != fields) {
    throw InputError(path, line_field(line),
                     "expected " + std::to_string(fields) + " fields, found " + std::to_string(count));
  }
  RutTruth t;
  t.index = parse<std::uint64_t>(f[0], path, line, 0);
  t_ns = parse<std::int64_t>(f[1], path, line, 1);
  double* values[] = {&t.depth_mm,         &t.width_mm,    &t.left_pile_mm,   &t.right_pile_mm, &t.area_mm2,
                      &t.ground_slope_deg, &t.center_x_mm, &t.tread_depth_mm, &t.y_mm};
  for (std::size_t i = 0; i < 9; ++i) *values[i] = parse<double>(f[i + 2], path, line, i + 2);
  if (fields == kDryFields) return t;
  double* water[] = {&t.water_depth_mm, &t.waterline_depth_mm, &t.waterline_left_x_mm, &t.waterline_right_x_mm};
  for (std::size_t i = 0; i < 4; ++i) *water[i] = parse<double>(f[i + 11], path, line, i + 11);
  t.right_delay_ns = parse<std::int64_t>(f[15], path, line, 15);
  t.exposure = parse<double>(f[16], path, line, 16);
  t.gain = parse<double>(f[17], path, line, 17);
  return t;
}

}  // namespace

TruthCsvWriter::TruthCsvWriter(const std::string& path) : path_(path), out_(path, std::ios::trunc) {
  line_.reserve(512);
  if (!out_) throw InputError(path, "file", std::string("cannot create: ") + std::strerror(errno));
  out_ << kTruthCsvHeader << '\n';
  out_.flush();
  if (!out_) throw InputError(path, "file", "write error");
}

bool TruthCsvWriter::append(const RutTruth& t, std::int64_t t_ns) {
  line_.clear();
  put(line_, t.index);
  put(line_, t_ns);
  for (double v : {t.depth_mm, t.width_mm, t.left_pile_mm, t.right_pile_mm, t.area_mm2, t.ground_slope_deg,
                   t.center_x_mm, t.tread_depth_mm, t.y_mm, t.water_depth_mm, t.waterline_depth_mm,
                   t.waterline_left_x_mm, t.waterline_right_x_mm}) {
    put(line_, v);
  }
  put(line_, t.right_delay_ns);
  put(line_, t.exposure);
  put(line_, t.gain);
  line_.back() = '\n';  // replaces the last separator
  out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
  out_.flush();
  return static_cast<bool>(out_);
}

std::vector<RutTruth> read_truth_csv(const std::string& path, std::vector<std::int64_t>* t_ns) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "file", std::string("cannot open: ") + std::strerror(errno));
  return read_truth_csv(in, path, t_ns);
}

std::vector<RutTruth> read_truth_csv(std::istream& in, const std::string& path, std::vector<std::int64_t>* t_ns) {
  std::string text;
  if (!std::getline(in, text)) throw InputError(path, "file", "file is empty");
  if (!text.empty() && text.back() == '\r') text.pop_back();
  std::size_t fields = kFields;
  if (text == kTruthCsvHeaderDry) {
    fields = kDryFields;
  } else if (text != kTruthCsvHeader) {
    throw InputError(path, "line 1", "expected the header '" + std::string(kTruthCsvHeader) + "'");
  }
  std::vector<RutTruth> rows;
  if (t_ns) t_ns->clear();
  for (std::size_t line = 2; std::getline(in, text); ++line) {
    if (!text.empty() && text.back() == '\r') text.pop_back();
    std::int64_t time = 0;
    rows.push_back(parse_line(text, path, line, fields, time));
    if (t_ns) t_ns->push_back(time);
  }
  if (in.bad()) throw InputError(path, "file", "read error");
  return rows;
}

}  // namespace rutd
