#include "gps/gpsd_report.hpp"

#include "gpsd_fix.hpp"

namespace rutd {

struct GpsdReportParser::State {
  gps_data_t data{};
};

GpsdReportParser::GpsdReportParser() : state_(std::make_unique<State>()) { buffer_.reserve(4096); }
GpsdReportParser::~GpsdReportParser() = default;

GpsdReportKind GpsdReportParser::parse(std::string_view json, std::int64_t rx_t_ns, GeoFix& fix) {
  while (!json.empty() && (json.back() == '\n' || json.back() == '\r')) json.remove_suffix(1);
  if (json.empty() || json.front() != '{' || json.back() != '}') return GpsdReportKind::Malformed;
  buffer_.assign(json);
  gps_data_t& data = state_->data;
  clear_gpsd_report(data);
  if (gps_unpack(buffer_.data(), &data) != 0) return GpsdReportKind::Malformed;
  if (!is_tpv_report(json)) return GpsdReportKind::Other;
  fix = geofix_from_gpsd(data.fix, data.set, rx_t_ns);
  return GpsdReportKind::Fix;
}

}  // namespace rutd
