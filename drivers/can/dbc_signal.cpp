#include "can/dbc_signal.hpp"

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace rutd {
namespace {

double unit_to_mm_s(const std::string& unit) {
  if (unit == "km/h" || unit == "kph" || unit == "kmh") return 1000.0 / 3.6;
  if (unit == "m/s") return 1000.0;
  if (unit == "mm/s") return 1.0;
  if (unit == "mph") return 1609.344 / 3.6;
  return 0;
}

}  // namespace

SpeedSignalLayout load_dbc_speed_signal(const std::string& path, const std::string& message,
                                        const std::string& signal) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open the DBC file");
  std::string line;
  bool in_message = false, found_message = false;
  unsigned long long raw_id = 0;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "BO_") {
      std::string name;
      ls >> raw_id >> name;
      if (!name.empty() && name.back() == ':') name.pop_back();
      in_message = ls && name == message;
      found_message = found_message || in_message;
      continue;
    }
    if (tag != "SG_" || !in_message) continue;
    std::string name, colon;
    ls >> name >> colon;
    if (name != signal) continue;
    const std::string where = path + ": line " + std::to_string(line_number) + ", " + message + "." + signal;
    if (colon != ":") throw std::invalid_argument(where + ": multiplexed signals are not supported");
    std::string layout, scale, range, unit;
    ls >> layout >> scale >> range;
    std::getline(ls, unit);
    SpeedSignalLayout s;
    char bar = 0, at = 0, sign = 0;
    int order = -1;
    std::istringstream lay(layout);
    lay >> s.start_bit >> bar >> s.length >> at >> order >> sign;
    double factor = 0, offset = 0;
    char open = 0, comma = 0;
    std::istringstream sc(scale);
    sc >> open >> factor >> comma >> offset;
    const auto q1 = unit.find('"'), q2 = unit.find('"', q1 + 1);
    const std::string unit_name =
        q1 == std::string::npos || q2 == std::string::npos ? "" : unit.substr(q1 + 1, q2 - q1 - 1);
    if (!lay || bar != '|' || at != '@' || (order != 0 && order != 1) || (sign != '+' && sign != '-') || open != '(' ||
        comma != ',' || !sc)
      throw std::invalid_argument(where + ": not a signal definition 'start|length@order+ (factor,offset)'");
    const double to_mm_s = unit_to_mm_s(unit_name);
    if (to_mm_s == 0)
      throw std::invalid_argument(where + ": unit '" + unit_name + "' is not a speed (km/h, m/s, mm/s or mph)");
    s.little_endian = order == 1;
    s.is_signed = sign == '-';
    s.factor_mm_s = factor * to_mm_s;
    s.offset_mm_s = offset * to_mm_s;
    s.extended = (raw_id & 0x80000000ULL) != 0;
    s.id = static_cast<std::uint32_t>(raw_id & (s.extended ? 0x1FFFFFFFULL : 0x7FFULL));
    // A J1939 message matches on its parameter group, whatever priority and sender; 11-bit ones exactly.
    s.id_mask = s.extended ? 0x03FFFF00 : 0x7FF;
    s.j1939_ranges = s.extended;
    s.name = message + "." + signal + " (" + path + ")";
    return s;
  }
  if (!found_message) throw std::invalid_argument(path + ": no message " + message);
  throw std::invalid_argument(path + ": message " + message + " has no signal " + signal);
}

}  // namespace rutd
