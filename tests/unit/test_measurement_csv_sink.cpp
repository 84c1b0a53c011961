// The measurement CSV sink of `rutd run` against the kernel's own failures: a file-size limit
// (RLIMIT_FSIZE) makes write(2) write part of a row and then fail with EFBIG, exactly as a filling disk
// does. The rows before must stay a valid CSV (read back by read_measurement_csv), the failure must be
// reported once per status period, and rows must be written again once the limit is lifted.
#include <sys/resource.h>

#include <csignal>
#include <cstdint>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "core/input_error.hpp"
#include "recording/measurement_csv.hpp"
#include "recording/measurement_csv_sink.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;

PublishedFrame frame_for(std::uint64_t seq) {
  PublishedFrame w;
  w.seq = seq;
  w.t_ns = static_cast<std::int64_t>(seq) * 33'333'333;
  w.measurement.status = RutStatus::Ok;
  w.measurement.depth_mm = 40.0 + static_cast<double>(seq);
  w.measurement.width_mm = 300.0;
  w.measurement.left_pile_mm = 5.0;
  w.measurement.right_pile_mm = 6.0;
  w.measurement.area_mm2 = 9000.0;
  w.measurement.ground_slope_deg = 1.0;
  w.measurement.center_x_mm = 0.0;
  w.measurement.quality = 0.9;
  w.measurement.valid_fraction = 0.95;
  return w;
}

// Sets the soft file-size limit for this process and puts the old one back at scope exit.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    std::signal(SIGXFSZ, SIG_IGN);  // as rutd run does: EFBIG instead of a kill
    getrlimit(RLIMIT_FSIZE, &old_);
    rlimit limit = old_;
    limit.rlim_cur = bytes;
    EXPECT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
  }
  ~FileSizeLimit() { setrlimit(RLIMIT_FSIZE, &old_); }

 private:
  rlimit old_{};
};

TEST(MeasurementCsvSink, PartialRowsAreCutOffAndWritingResumes) {
  test::TempDir tmp;
  const fs::path path = tmp.path() / "m.csv";
  MeasurementCsvSink sink(path.string(), "sinks.csv");
  const SensorHealth health;
  for (std::uint64_t seq = 1; seq <= 5; ++seq) sink.publish(frame_for(seq));
  EXPECT_FALSE(sink.failed_since_last_check());
  const auto good_size = fs::file_size(path);
  {
    // Room for 30 more bytes: the next row (about 90 bytes) gets partly written, then EFBIG.
    FileSizeLimit limit(good_size + 30);
    sink.publish(frame_for(6));
    EXPECT_EQ(fs::file_size(path), good_size) << "the partial row was not cut off";
    sink.publish(frame_for(7));
  }
  EXPECT_TRUE(sink.failed_since_last_check());
  EXPECT_FALSE(sink.failed_since_last_check()) << "reported twice for one period";
  sink.publish(frame_for(8));
  EXPECT_FALSE(sink.failed_since_last_check());

  EXPECT_EQ(sink.stats().rows_written, 6u);
  EXPECT_EQ(sink.stats().rows_lost, 2u);
  EXPECT_FALSE(sink.stats().stopped);
  EXPECT_NE(sink.stats().last_error.find("cannot write the row of seq 7: File too large"), std::string::npos)
      << sink.stats().last_error;
  const MeasurementCsv csv = read_measurement_csv(path.string());
  EXPECT_FALSE(csv.truncated_tail);
  ASSERT_EQ(csv.rows.size(), 6u);
  const std::uint64_t expected[] = {1, 2, 3, 4, 5, 8};
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(csv.rows[i].seq, expected[i]);
    EXPECT_DOUBLE_EQ(csv.rows[i].measurement.depth_mm, 40.0 + static_cast<double>(expected[i]));
  }
}

// A device that refuses every write (/dev/full: ENOSPC) is not a regular file: a row cannot be taken
// back there, so the header already fails at start-up with the file and key named.
TEST(MeasurementCsvSink, UnwritableOutputIsRefusedAtStartWithFileAndKey) {
  try {
    MeasurementCsvSink sink("/dev/full", "sinks.csv");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "/dev/full");
    EXPECT_EQ(e.field(), "sinks.csv");
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rutd
