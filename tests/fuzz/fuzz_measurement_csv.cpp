// libFuzzer target: the measurement CSV reader (read_measurement_csv on a stream, which the file
// overload opens). Rows it accepts are written back with MeasurementCsvWriter and must read back with
// the same count, sequence numbers, times and statuses.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "fuzz_check.hpp"
#include "recording/measurement_csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string kFile = "measurements.csv";
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size), std::ios::binary);
  rutd::MeasurementCsv csv;
  try {
    csv = rutd::read_measurement_csv(in, kFile);
  } catch (const rutd::InputError& e) {
    rutd::fuzz::check_input_error(e, kFile);
    return 0;
  }
  std::stringstream text;
  rutd::MeasurementCsvWriter writer(text);
  for (const auto& row : csv.rows) writer.write(row.seq, row.t_ns, row.measurement);
  const rutd::MeasurementCsv again = rutd::read_measurement_csv(text, "rewritten.csv");
  if (again.rows.size() != csv.rows.size() || again.truncated_tail) rutd::fuzz::fail("rewritten rows differ", "");
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    if (again.rows[i].seq != csv.rows[i].seq || again.rows[i].t_ns != csv.rows[i].t_ns ||
        again.rows[i].measurement.status != csv.rows[i].measurement.status) {
      rutd::fuzz::fail("rewritten row " + std::to_string(i) + " differs", "");
    }
  }
  return 0;
}
