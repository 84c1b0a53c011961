// Measurement CSV: the exact text of known rows (hand-written expectations), field validity per status,
// locale independence, flushing, a write -> read round trip, and one error per malformed input.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <locale>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "core/input_error.hpp"
#include "recording/measurement_csv.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;

const std::string kHeader =
    "seq,t_ns,status,rut_depth_mm,rut_width_mm,left_pile_mm,right_pile_mm,area_mm2,ground_slope_deg,"
    "center_x_mm,quality,valid_fraction";

RutMeasurement full(RutStatus status) {
  RutMeasurement m;
  m.status = status;
  m.depth_mm = 42.12345;
  m.width_mm = 310.9996;
  m.left_pile_mm = 8.5;
  m.right_pile_mm = 0.0;
  m.area_mm2 = 9876.54321;
  m.ground_slope_deg = -2.25;
  m.center_x_mm = -15.0004;
  m.quality = 0.87654;
  m.valid_fraction = 1.0;
  return m;
}

std::string write_rows(const std::vector<std::tuple<std::uint64_t, std::int64_t, RutMeasurement>>& rows) {
  std::ostringstream out;
  MeasurementCsvWriter writer(out);
  for (const auto& [seq, t_ns, m] : rows) EXPECT_TRUE(writer.write(seq, t_ns, m));
  EXPECT_EQ(writer.rows_written(), rows.size());
  return out.str();
}

TEST(MeasurementCsvTest, HeaderIsExactlyTheDocumentedOne) {
  EXPECT_EQ(kMeasurementCsvHeader, kHeader);
  EXPECT_EQ(write_rows({}), kHeader + "\n");
}

TEST(MeasurementCsvTest, RowsHoldOnlyTheFieldsValidForTheirStatus) {
  RutMeasurement tiny_negative = full(RutStatus::Ok);
  tiny_negative.center_x_mm = -0.0004;
  RutMeasurement not_finite = full(RutStatus::Ok);
  not_finite.area_mm2 = std::nan("");
  not_finite.width_mm = INFINITY;
  const std::string text = write_rows({
      {1, 1700000000000000000, full(RutStatus::Ok)},
      {2, 1700000000033333333, full(RutStatus::NoRut)},
      {3, 3, full(RutStatus::TooFewPoints)},
      {4, 4, full(RutStatus::NoGround)},
      {5, 5, full(RutStatus::RutAtEdge)},
      {6, -6, full(RutStatus::NoMeasurement)},
      {7, 7, tiny_negative},
      {8, 8, not_finite},
  });
  EXPECT_EQ(text, kHeader + "\n" +
                      "1,1700000000000000000,OK,42.123,311.000,8.500,0.000,9876.543,-2.250,-15.000,0.8765,1.0000\n"
                      "2,1700000000033333333,NO_RUT,,,,,,-2.250,,0.8765,1.0000\n"
                      "3,3,TOO_FEW_POINTS,,,,,,,,0.8765,1.0000\n"
                      "4,4,NO_GROUND,,,,,,,,0.8765,1.0000\n"
                      "5,5,RUT_AT_EDGE,,,,,,-2.250,,0.8765,1.0000\n"
                      "6,-6,NO_MEASUREMENT,,,,,,,,,\n"
                      "7,7,OK,42.123,311.000,8.500,0.000,9876.543,-2.250,0.000,0.8765,1.0000\n"
                      "8,8,OK,42.123,,8.500,0.000,,-2.250,-15.000,0.8765,1.0000\n");
}

TEST(MeasurementCsvTest, FieldValidityTable) {
  using F = MeasurementField;
  EXPECT_TRUE(measurement_field_valid(RutStatus::Ok, F::DepthMm));
  EXPECT_FALSE(measurement_field_valid(RutStatus::RutAtEdge, F::DepthMm));
  EXPECT_FALSE(measurement_field_valid(RutStatus::NoRut, F::CenterXMm));
  EXPECT_TRUE(measurement_field_valid(RutStatus::NoRut, F::GroundSlopeDeg));
  EXPECT_FALSE(measurement_field_valid(RutStatus::NoGround, F::GroundSlopeDeg));
  EXPECT_TRUE(measurement_field_valid(RutStatus::TooFewPoints, F::ValidFraction));
  EXPECT_FALSE(measurement_field_valid(RutStatus::NoMeasurement, F::Quality));
}

// A stream whose locale writes decimal commas: the CSV must not follow it.
struct CommaDecimal : std::numpunct<char> {
  char do_decimal_point() const override { return ','; }
  char do_thousands_sep() const override { return '.'; }
  std::string do_grouping() const override { return "\3"; }
};

TEST(MeasurementCsvTest, IgnoresTheStreamLocale) {
  std::ostringstream out;
  out.imbue(std::locale(out.getloc(), new CommaDecimal));
  MeasurementCsvWriter writer(out);
  ASSERT_TRUE(writer.write(1234567, 1234567, full(RutStatus::Ok)));
  EXPECT_EQ(out.str(),
            kHeader + "\n1234567,1234567,OK,42.123,311.000,8.500,0.000,9876.543,-2.250,-15.000,0.8765,1.0000\n");
}

class SyncCounter : public std::stringbuf {
 public:
  int syncs = 0;

 protected:
  int sync() override {
    ++syncs;
    return std::stringbuf::sync();
  }
};

TEST(MeasurementCsvTest, FlushesEachLineOnlyWhenAsked) {
  for (bool flush : {false, true}) {
    SyncCounter buffer;
    std::ostream out(&buffer);
    MeasurementCsvWriter writer(out, flush);
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(writer.write(i, i, full(RutStatus::Ok)));
    EXPECT_EQ(buffer.syncs, flush ? 4 : 0);  // header + 3 rows
  }
}

TEST(MeasurementCsvTest, FailedStreamIsReported) {
  std::ostringstream out;
  MeasurementCsvWriter writer(out);
  out.setstate(std::ios::badbit);  // as after a disk-full write
  EXPECT_FALSE(writer.write(1, 1, full(RutStatus::Ok)));
  EXPECT_EQ(writer.rows_written(), 0u);
}

class MeasurementCsvFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = (fs::temp_directory_path() / ("rutd_measurements_" + std::to_string(::getpid()) + "_" +
                                          ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".csv"))
                .string();
  }
  void TearDown() override { fs::remove(path_); }
  void write(const std::string& text) { std::ofstream(path_, std::ios::binary) << text; }

  void expect_error(const std::string& text, const std::string& field, const std::string& message) {
    write(text);
    try {
      read_measurement_csv(path_);
      ADD_FAILURE() << "no error for:\n" << text;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path_);
      EXPECT_EQ(e.field(), field);
      EXPECT_EQ(std::string(e.what()), path_ + ": " + field + ": " + message);
    }
  }

  std::string path_;
};

TEST_F(MeasurementCsvFileTest, RoundTripKeepsValuesToTheirPrecision) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-500.0, 500.0);
  std::vector<std::tuple<std::uint64_t, std::int64_t, RutMeasurement>> rows;
  for (std::uint64_t i = 0; i < 200; ++i) {
    RutMeasurement m;
    m.status = static_cast<RutStatus>(i % 6);
    m.depth_mm = u(rng);
    m.width_mm = u(rng);
    m.left_pile_mm = u(rng);
    m.right_pile_mm = u(rng);
    m.area_mm2 = 1000 * u(rng);
    m.ground_slope_deg = u(rng) / 50;
    m.center_x_mm = u(rng);
    m.quality = std::abs(u(rng)) / 500;
    m.valid_fraction = std::abs(u(rng)) / 500;
    rows.emplace_back(i * 3, static_cast<std::int64_t>(i) * 33'333'333 + 1'700'000'000'000'000'000, m);
  }
  write(write_rows(rows));
  const MeasurementCsv csv = read_measurement_csv(path_);
  EXPECT_FALSE(csv.truncated_tail);
  ASSERT_EQ(csv.rows.size(), rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& [seq, t_ns, m] = rows[i];
    const MeasurementRow& row = csv.rows[i];
    EXPECT_EQ(row.seq, seq);
    EXPECT_EQ(row.t_ns, t_ns);
    ASSERT_EQ(row.measurement.status, m.status);
    const std::pair<double, double> fields[] = {{m.depth_mm, row.measurement.depth_mm},
                                                {m.width_mm, row.measurement.width_mm},
                                                {m.left_pile_mm, row.measurement.left_pile_mm},
                                                {m.right_pile_mm, row.measurement.right_pile_mm},
                                                {m.area_mm2, row.measurement.area_mm2},
                                                {m.ground_slope_deg, row.measurement.ground_slope_deg},
                                                {m.center_x_mm, row.measurement.center_x_mm},
                                                {m.quality, row.measurement.quality},
                                                {m.valid_fraction, row.measurement.valid_fraction}};
    for (int f = 0; f < kMeasurementFieldCount; ++f) {
      SCOPED_TRACE(std::to_string(i) + "/" + std::to_string(f));
      const auto [written, read] = fields[f];
      if (measurement_field_valid(m.status, static_cast<MeasurementField>(f))) {
        EXPECT_NEAR(read, written, f >= 7 ? 0.5e-4 : 0.5e-3);
      } else {
        EXPECT_TRUE(std::isnan(read));
      }
    }
  }
}

TEST_F(MeasurementCsvFileTest, CutOffLastLineIsDroppedWithANote) {
  const std::string rows = write_rows({{1, 10, full(RutStatus::Ok)}, {2, 20, full(RutStatus::Ok)}});
  write(rows + "3,30,OK,42.1");
  MeasurementCsv csv = read_measurement_csv(path_);
  EXPECT_TRUE(csv.truncated_tail);
  ASSERT_EQ(csv.rows.size(), 2u);
  EXPECT_EQ(csv.rows[1].seq, 2u);
  write(rows + "3,30,NO_MEASUREMENT,,,,,,,,,");  // complete but for the newline
  csv = read_measurement_csv(path_);
  EXPECT_FALSE(csv.truncated_tail);
  ASSERT_EQ(csv.rows.size(), 3u);
  EXPECT_EQ(csv.rows[2].measurement.status, RutStatus::NoMeasurement);
}

TEST_F(MeasurementCsvFileTest, MalformedInputNamesFileAndLine) {
  const std::string ok_row = "1,10,OK,42.123,311.000,8.500,0.000,9876.543,-2.250,-15.000,0.8765,1.0000\n";
  expect_error("", "line 1", "missing header (file is empty)");
  expect_error("seq,t_ns,status\n", "line 1", "header is 'seq,t_ns,status' but must be '" + kHeader + "'");
  expect_error(kHeader + "\n" + ok_row + "2,20,OK,1,2\n" + ok_row, "line 3", "expected 12 fields, found 5");
  expect_error(kHeader + "\n" + "-1,10,NO_MEASUREMENT,,,,,,,,,\n", "line 2", "seq '-1' is not a non-negative integer");
  expect_error(kHeader + "\n" + "1,ten,NO_MEASUREMENT,,,,,,,,,\n", "line 2", "t_ns 'ten' is not an integer");
  expect_error(kHeader + "\n" + "1,10,FINE,,,,,,,,,\n", "line 2", "unknown status 'FINE'");
  expect_error(kHeader + "\n" + "1,10,OK,4x,311.000,8.500,0.000,9876.543,-2.250,-15.000,0.8765,1.0000\n", "line 2",
               "rut_depth_mm '4x' is not a finite number");
  expect_error(kHeader + "\n" + "1,10,OK,42.1,311.000,8.500,0.000,9876.543,-2.250,-15.000,0.8765,inf\n", "line 2",
               "valid_fraction 'inf' is not a finite number");
  expect_error(kHeader + "\n" + "1,10,NO_RUT,42.1,,,,,-2.250,,0.8765,1.0000\n", "line 2",
               "rut_depth_mm holds a value but must be empty when status is NO_RUT");
}

TEST_F(MeasurementCsvFileTest, MissingFileNamesTheFile) {
  try {
    read_measurement_csv(path_);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path_ + ": file: cannot open");
  }
}

}  // namespace
}  // namespace rutd

namespace rutd {
namespace {

const std::string kPositionHeader = kHeader +
                                    ",fix_mode,latitude_deg,longitude_deg,altitude_m,horizontal_error_m,"
                                    "heading_deg";

TEST(MeasurementCsvPositionTest, PositionColumnsHoldOnlyAFixsFields) {
  GeoFix fix;
  fix.mode = GeoFix::Mode::Fix3d;
  fix.latitude_deg = -25.754494667;
  fix.longitude_deg = 28.231410333;
  fix.altitude_m = 1340.0;
  fix.horizontal_error_m = 15.2;
  std::string line;
  format_measurement_row(line, 7, 70, RutMeasurement{}, &fix);
  EXPECT_EQ(line, "7,70,NO_MEASUREMENT,,,,,,,,,,3D,-25.754494667,28.231410333,1340.000,15.200,\n");
  GeoFix stale = fix;
  stale.mode = GeoFix::Mode::NoFix;  // fields left from a fix are not written without one
  format_measurement_row(line, 8, 80, RutMeasurement{}, &stale);
  EXPECT_EQ(line, "8,80,NO_MEASUREMENT,,,,,,,,,,NO_FIX,,,,,\n");
  format_measurement_row(line, 9, 90, RutMeasurement{}, nullptr);
  EXPECT_EQ(line, "9,90,NO_MEASUREMENT,,,,,,,,,\n");
}

TEST_F(MeasurementCsvFileTest, PositionsRoundTripAndBadOnesAreNamed) {
  write(kPositionHeader + "\n" + "1,10,NO_MEASUREMENT,,,,,,,,,,2D,-25.123456789,28.987654321,,3.500,271.25\n" +
        "2,20,NO_MEASUREMENT,,,,,,,,,,NONE,,,,,\n");
  const MeasurementCsv csv = read_measurement_csv(path_);
  ASSERT_TRUE(csv.has_positions);
  ASSERT_EQ(csv.rows.size(), 2u);
  EXPECT_EQ(csv.rows[0].position.mode, GeoFix::Mode::Fix2d);
  EXPECT_DOUBLE_EQ(csv.rows[0].position.latitude_deg, -25.123456789);
  EXPECT_DOUBLE_EQ(csv.rows[0].position.longitude_deg, 28.987654321);
  EXPECT_TRUE(std::isnan(csv.rows[0].position.altitude_m));
  EXPECT_DOUBLE_EQ(csv.rows[0].position.heading_deg, 271.25);
  EXPECT_EQ(csv.rows[1].position.mode, GeoFix::Mode::None);
  const std::string h = kPositionHeader + "\n";
  expect_error(h + "1,10,NO_MEASUREMENT,,,,,,,,,,4D,,,,,\n", "line 2", "unknown fix_mode '4D'");
  expect_error(h + "1,10,NO_MEASUREMENT,,,,,,,,,,NO_FIX,-25.1,28.1,,,\n", "line 2",
               "latitude_deg holds a value but must be empty without a fix");
  expect_error(h + "1,10,NO_MEASUREMENT,,,,,,,,,,3D,,28.1,,,\n", "line 2",
               "a fix needs latitude_deg and longitude_deg");
  expect_error(h + "1,10,NO_MEASUREMENT,,,,,,,,,,3D,95.0,28.1,,,\n", "line 2",
               "latitude_deg or longitude_deg out of range");
  expect_error(h + "1,10,NO_MEASUREMENT,,,,,,,,,\n", "line 2", "expected 18 fields, found 12");
}

}  // namespace
}  // namespace rutd
