#include "recording/measurement_csv_sink.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <spdlog/spdlog.h>

#include "core/input_error.hpp"
#include "fd_write.hpp"
#include "recording/measurement_csv.hpp"

namespace rutd {

MeasurementCsvSink::MeasurementCsvSink(const std::string& path, const std::string& key, IoFaults* faults,
                                       bool positions)
    : path_(path), positions_(positions), faults_(faults) {
  if (path == "-") {
    fd_ = STDOUT_FILENO;
  } else {
    // O_APPEND: after a partial row is cut off, the next row goes to the new end, not past it.
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_APPEND | O_CLOEXEC, 0644);
    if (fd_ < 0) throw InputError(path, key, std::string("cannot open for writing: ") + std::strerror(errno));
    owns_fd_ = true;
  }
  struct stat info {};
  regular_file_ = ::fstat(fd_, &info) == 0 && S_ISREG(info.st_mode);
  line_.reserve(256);
  line_.assign(kMeasurementCsvHeader);
  if (positions_) {
    line_.push_back(',');
    line_.append(kMeasurementCsvPositionColumns);
  }
  line_.push_back('\n');
  if (!fd_write_all(fd_, line_.data(), line_.size())) {
    const std::string reason = std::strerror(errno);
    if (owns_fd_) ::close(fd_);
    throw InputError(path, key, "cannot write the header: " + reason);
  }
  size_ = line_.size();
}

MeasurementCsvSink::~MeasurementCsvSink() {
  if (owns_fd_) ::close(fd_);
}

void MeasurementCsvSink::publish(const PublishedFrame& frame) {
  if (stats_.stopped) {
    ++stats_.rows_lost;
    return;
  }
  format_measurement_row(line_, frame.seq, frame.t_ns, frame.measurement, positions_ ? &frame.position : nullptr);
  if (fd_write_all(fd_, line_.data(), line_.size(), faults_, IoPoint::MeasurementWrite)) {
    size_ += line_.size();
    ++stats_.rows_written;
    if (failing_) spdlog::info("measurement CSV {}: writing again from seq {}", path_, frame.seq);
    failing_ = false;
    return;
  }
  const int error = errno;
  ++stats_.rows_lost;
  stats_.last_error =
      path_ + ": cannot write the row of seq " + std::to_string(frame.seq) + ": " + std::strerror(error);
  // Take back whatever part of the row got out, so the rows before it stay a valid CSV.
  if (!regular_file_ || ::ftruncate(fd_, static_cast<off_t>(size_)) != 0) {
    stats_.stopped = true;
    stats_.last_error += "; a partial row may remain, no more rows are written";
  }
  if (!failing_ || stats_.stopped) spdlog::error("measurement CSV {}", stats_.last_error);
  failing_ = true;
}

bool MeasurementCsvSink::failed_since_last_check() {
  const bool failed = stats_.rows_lost != lost_at_last_check_;
  lost_at_last_check_ = stats_.rows_lost;
  return failed;
}

}  // namespace rutd
