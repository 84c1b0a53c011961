// gpsd reports read by libgps (GpsdReportParser), the recorded gps.jsonl (writer and reader: a malformed
// line and a cut-off last line are skipped and counted, never the rest), and which fix is in force at a
// time (FixHistory live, RecordedPositions in replay: the same answers; stale, before the first fix, an
// epoch's GGA and RMC merged).
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "core/input_error.hpp"
#include "gps/fix_history.hpp"
#include "gps/gps_jsonl.hpp"
#include "gps/gpsd_report.hpp"
#include "gps/position_source.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;

// gpsd 3.22's own lines (gpspipe -w against gpsfake playing tests/gps/nmea_drive.py's log).
const std::string kGga =
    R"({"class":"TPV","device":"/dev/pts/1","mode":3,"time":"2026-11-25T12:00:00.600Z","ept":0.005,)"
    R"("lat":-25.754494667,"lon":28.231410333,"altHAE":1340.0000,"altMSL":1340.0000,"alt":1340.0000,)"
    R"("magvar":-18.5,"speed":1.984,"climb":0.000,"geoidSep":0.000,"eph":15.200})";
const std::string kRmc =
    R"({"class":"TPV","device":"/dev/pts/1","mode":3,"time":"2026-11-25T12:00:00.600Z","ept":0.005,)"
    R"("lat":-25.754494667,"lon":28.231410333,"altHAE":1340.0000,"altMSL":1340.0000,"alt":1340.0000,)"
    R"("track":60.0000,"magtrack":41.5405,"magvar":-18.5,"speed":2.001,"climb":0.000,"geoidSep":0.000,"eph":15.200})";
const std::string kVersion = R"({"class":"VERSION","release":"3.22","rev":"3.22","proto_major":3,"proto_minor":14})";

TEST(GpsdReport, LibgpsReadsGpsdsLines) {
  GpsdReportParser parser;
  GeoFix fix;
  ASSERT_EQ(parser.parse(kRmc, 123, fix), GpsdReportKind::Fix);
  EXPECT_EQ(fix.mode, GeoFix::Mode::Fix3d);
  EXPECT_EQ(fix.t_ns, 123);
  EXPECT_DOUBLE_EQ(fix.latitude_deg, -25.754494667);
  EXPECT_DOUBLE_EQ(fix.longitude_deg, 28.231410333);
  EXPECT_DOUBLE_EQ(fix.altitude_m, 1340.0);
  EXPECT_DOUBLE_EQ(fix.horizontal_error_m, 15.2);
  EXPECT_DOUBLE_EQ(fix.heading_deg, 60.0);
  EXPECT_EQ(fix.utc_ns, 1795608000600000000);  // 2026-11-25T12:00:00.600Z
  // A GGA's report has no track: it must not keep the RMC's from the parser's previous report.
  ASSERT_EQ(parser.parse(kGga, 124, fix), GpsdReportKind::Fix);
  EXPECT_TRUE(std::isnan(fix.heading_deg));
  EXPECT_EQ(parser.parse(kVersion, 125, fix), GpsdReportKind::Other);
  EXPECT_EQ(parser.parse(R"({"class":"TPV","mode":1})", 126, fix), GpsdReportKind::Fix);
  EXPECT_EQ(fix.mode, GeoFix::Mode::NoFix);
  EXPECT_EQ(parser.parse(R"({"class":"TPV","mode":3,"lat":-25.)", 127, fix), GpsdReportKind::Malformed);
  EXPECT_EQ(parser.parse("GPS receiver says hello", 128, fix), GpsdReportKind::Malformed);
  EXPECT_EQ(parser.parse("", 129, fix), GpsdReportKind::Malformed);
}

GeoFix fix_at(std::int64_t t_ns, double lat, std::int64_t utc_ns = 0, double heading = NAN) {
  GeoFix f;
  f.mode = GeoFix::Mode::Fix3d;
  f.t_ns = t_ns;
  f.latitude_deg = lat;
  f.longitude_deg = 28.0;
  f.utc_ns = utc_ns;
  f.heading_deg = heading;
  return f;
}

TEST(FixInForce, LiveAndRecordedAgree) {
  constexpr std::int64_t ms = 1'000'000;
  GeoFix nofix;
  nofix.mode = GeoFix::Mode::NoFix;
  nofix.t_ns = 400 * ms;
  const std::vector<GeoFix> fixes{fix_at(100 * ms, -25.1, 1, 90.0), fix_at(110 * ms, -25.1, 1),
                                  fix_at(300 * ms, -25.3, 2), nofix, fix_at(2000 * ms, -25.5, 3)};
  FixHistory live;
  for (const GeoFix& f : fixes) live.add(f);
  const RecordedPositions recorded(fixes, 1000 * ms);
  struct Case {
    std::int64_t t_ms;
    GeoFix::Mode mode;
    double lat;
  };
  const Case cases[] = {
      {50, GeoFix::Mode::NoFix, NAN},                                        // before the first fix
      {105, GeoFix::Mode::Fix3d, -25.1},                                     // the first
      {350, GeoFix::Mode::Fix3d, -25.3},                                     // the one at 300 ms
      {450, GeoFix::Mode::NoFix, NAN},                                       // the receiver lost its fix at 400 ms
      {1999, GeoFix::Mode::NoFix, NAN},                                      // still none
      {2500, GeoFix::Mode::Fix3d, -25.5}, {3001, GeoFix::Mode::NoFix, NAN},  // stale: over 1000 ms old
  };
  for (const Case& c : cases) {
    const GeoFix a = live.at(c.t_ms * ms, 1000 * ms), b = recorded.position_at(c.t_ms * ms);
    EXPECT_EQ(a.mode, c.mode) << c.t_ms << " ms";
    EXPECT_EQ(b.mode, c.mode) << c.t_ms << " ms";
    if (c.mode == GeoFix::Mode::Fix3d) {
      EXPECT_DOUBLE_EQ(a.latitude_deg, c.lat);
      EXPECT_DOUBLE_EQ(b.latitude_deg, c.lat);
    }
  }
  // The epoch's second report (GGA after RMC, same fix time) keeps the first's heading; the next epoch's
  // report 190 ms later carries it too; after the gap of 1.7 s it is unknown.
  EXPECT_DOUBLE_EQ(live.at(115 * ms, 1000 * ms).heading_deg, 90.0);
  EXPECT_DOUBLE_EQ(recorded.position_at(115 * ms).heading_deg, 90.0);
  EXPECT_DOUBLE_EQ(recorded.position_at(310 * ms).heading_deg, 90.0);
  EXPECT_TRUE(std::isnan(recorded.position_at(2100 * ms).heading_deg));
  // A fix received earlier than the last one added is dropped.
  EXPECT_FALSE(live.add(fix_at(50 * ms, -25.0)));
}

TEST(GpsJsonl, WrittenReportsReadBackAndBadLinesAreSkipped) {
  const fs::path path = fs::temp_directory_path() / ("rutd_gps_" + std::to_string(::getpid()) + ".jsonl");
  fs::remove(path);
  {
    GpsJsonlWriter writer(path.string());
    ASSERT_TRUE(writer.append(1000, kVersion + "\n"));
    ASSERT_TRUE(writer.append(2000, kRmc));
    EXPECT_THROW(GpsJsonlWriter again(path.string()), InputError);  // never overwritten
  }
  {
    std::ofstream out(path, std::ios::app);
    out << "{\"t_ns\":x,\"report\":{}}\n";  // malformed
    out << "{\"t_ns\":3000,\"report\":" << kGga << "}\n";
    out << "{\"t_ns\":4000,\"report\":{\"class\":\"TP";  // cut off by a crash
  }
  const GpsJsonl read = read_gps_jsonl(path.string());
  ASSERT_EQ(read.lines.size(), 3u);
  EXPECT_EQ(read.lines[0].t_ns, 1000);
  EXPECT_EQ(read.lines[0].report, kVersion);
  EXPECT_EQ(read.lines[1].report, kRmc);
  EXPECT_EQ(read.malformed, 1u);
  EXPECT_TRUE(read.truncated_tail);
  const RecordedFixes fixes = read_recorded_fixes(path.string());
  ASSERT_EQ(fixes.fixes.size(), 2u);
  EXPECT_EQ(fixes.fixes[0].t_ns, 2000);
  EXPECT_EQ(fixes.fixes[1].t_ns, 3000);
  EXPECT_EQ(fixes.reports, 3u);
  fs::remove(path);
}

}  // namespace
}  // namespace rutd
