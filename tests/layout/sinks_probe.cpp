// A program that links the output libraries (the CAN, measurement CSV and plot sinks) and nothing else of
// rutd: its link line is what check_layering.sh inspects (no pipeline library, no rut extraction). It
// publishes one frame through each sink so that the linker really pulls their objects in.
#include <stdlib.h>

#include <sstream>
#include <string>

#include "can/can_sink.hpp"
#include "plots/plot_sink.hpp"
#include "recording/measurement_csv_sink.hpp"

int main() {
  char dir[] = "/tmp/rutd-sinks-probe-XXXXXX";
  if (mkdtemp(dir) == nullptr) return 2;
  rutd::PublishedFrame frame;
  frame.seq = 1;
  frame.measurement.status = rutd::RutStatus::NoRut;

  std::ostringstream log_text;
  rutd::CandumpLogWriter log(log_text);
  rutd::CanSink can(rutd::CanIdConfig{}, nullptr, &log, &log_text);
  rutd::MeasurementCsvSink csv(std::string(dir) + "/m.csv", "probe");
  rutd::PlotConfig plot_config;
  plot_config.dir = dir;
  rutd::PlotSink plots(plot_config, rutd::PlotContext{});
  rutd::SinkFanout sinks({&can, &csv, &plots});
  sinks.publish(frame);
  sinks.publish_status(rutd::SensorHealth{}, 0);
  plots.finish();
  const bool ok = log_text.str().find("can0") != std::string::npos && csv.stats().rows_written == 1;
  std::system((std::string("rm -rf ") + dir).c_str());
  return ok ? 0 : 1;
}
