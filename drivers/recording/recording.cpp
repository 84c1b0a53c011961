// Recording writer and reader (DESIGN.md, Formats). Crash safety rests on ordering: an image reaches its
// final name only by rename after it is completely written (and synced when sync_to_disk), and a
// frames.csv line is appended only after both renames. On ext4/xfs the fdatasync of frames.csv also
// commits the earlier renames, because they sit in the same (or an earlier) journal transaction.
#include "recording/recording.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/csv_fields.hpp"
#include "core/input_error.hpp"
#include "fd_write.hpp"
#include "recording/calibration_file.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;

// skew_ns: the right camera's capture time minus the left's (StereoFrame::skew_ns). Recordings made before
// it lack the column (kHeaderWithoutSkew): their pairs read as skew 0, unknown. The image paths stay last,
// so that a line cut off by a crash ends in a path that names no file, never in a number that parses.
constexpr std::string_view kHeader = "seq,t_ns,skew_ns,left,right";
constexpr std::string_view kHeaderWithoutSkew = "seq,t_ns,left,right";
constexpr const char* kFramesFile = "frames.csv";
constexpr const char* kCalibrationFile = "calibration.yaml";

std::string errno_text() { return std::strerror(errno); }

// Writes `size` bytes to `tmp`, syncs when asked, renames to `path`. On failure removes `tmp`, sets
// `error` and returns false.
bool write_file_atomically(const std::string& tmp, const std::string& path, const void* data, std::size_t size,
                           bool sync, std::string& error, IoFaults* faults) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    error = "cannot create " + tmp + ": " + errno_text();
    return false;
  }
  bool ok = fd_write_all(fd, data, size, faults) && (!sync || ::fdatasync(fd) == 0);
  if (!ok) error = "cannot write " + tmp + ": " + errno_text();
  if (::close(fd) != 0 && ok) {
    ok = false;
    error = "cannot write " + tmp + ": " + errno_text();
  }
  if (ok && ::rename(tmp.c_str(), path.c_str()) != 0) {
    ok = false;
    error = "cannot rename " + tmp + " to " + path + ": " + errno_text();
  }
  if (!ok) ::unlink(tmp.c_str());
  return ok;
}

void make_directory(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw InputError(dir, "folder", "cannot create: " + ec.message());
  if (!fs::is_directory(dir, ec)) throw InputError(dir, "folder", "exists but is not a folder");
}

const char* depth_name(int depth) { return depth == CV_16U ? "16-bit" : depth == CV_8U ? "8-bit" : "non-8/16-bit"; }

std::string describe(const cv::Mat& m) {
  return std::to_string(m.cols) + "x" + std::to_string(m.rows) + " " + depth_name(m.depth()) + " " +
         std::to_string(m.channels()) + "-channel";
}

bool is_grey_8_or_16(const cv::Mat& m) { return m.type() == CV_8UC1 || m.type() == CV_16UC1; }

// Sets `out` to "<dir>/<side>/<seq padded to 8 digits>.png", or to the hidden temporary
// "<dir>/<side>/.<seq>.png.tmp" that replay never lists.
void image_path(std::string& out, const std::string& dir, const char* side, std::uint64_t seq, bool temporary) {
  char name[64];
  std::snprintf(name, sizeof name, temporary ? "/%s/.%08llu.png.tmp" : "/%s/%08llu.png", side,
                static_cast<unsigned long long>(seq));
  out.assign(dir);
  out.append(name);
}

// Reads a whole file into `bytes` (capacity reused). On failure returns false with errno set: EFBIG for
// a file larger than `max_bytes`, which is refused before anything is allocated for it.
bool read_file(const std::string& path, std::vector<char>& bytes, std::uint64_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  struct stat info {};
  bool ok = ::fstat(fd, &info) == 0;
  if (ok && info.st_size <= 0) {
    errno = S_ISREG(info.st_mode) ? ENODATA : EISDIR;
    ok = false;
  }
  if (ok && static_cast<std::uint64_t>(info.st_size) > max_bytes) {
    errno = EFBIG;
    ok = false;
  }
  if (ok) {
    bytes.resize(static_cast<std::size_t>(info.st_size));
    std::size_t done = 0;
    while (ok && done < bytes.size()) {
      const ssize_t n = ::read(fd, bytes.data() + done, bytes.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        if (n == 0) errno = EIO;  // shrank while reading
        ok = false;
      } else {
        done += static_cast<std::size_t>(n);
      }
    }
  }
  const int saved = errno;
  ::close(fd);
  errno = saved;
  return ok;
}

// The PNG signature, then the IHDR chunk: length 13, "IHDR", width and height (big-endian, 31 bits).
constexpr unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};

bool is_png(const std::vector<char>& bytes) {
  return bytes.size() >= sizeof kPngSignature && std::memcmp(bytes.data(), kPngSignature, sizeof kPngSignature) == 0;
}

// The size a PNG's header declares, or nothing when the header is cut off (the decoder then refuses it).
std::optional<cv::Size> png_header_size(const std::vector<char>& bytes) {
  if (bytes.size() < 24 || std::memcmp(bytes.data() + 12, "IHDR", 4) != 0) return std::nullopt;
  const auto be32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < 4; ++i) v = v << 8 | static_cast<unsigned char>(bytes[at + i]);
    return v;
  };
  const std::uint32_t width = be32(16), height = be32(20);
  if (width > 0x7FFFFFFF || height > 0x7FFFFFFF) return std::nullopt;
  return cv::Size(static_cast<int>(width), static_cast<int>(height));
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// RecordingWriter

RecordingWriter::RecordingWriter(const std::string& dir, const StereoCalibration& calibration,
                                 RecordingWriterConfig options)
    : dir_(dir), frames_path_(dir + "/" + kFramesFile), calibration_(calibration), options_(options) {
  make_directory(dir_);
  std::error_code ec;
  for (const char* existing : {kFramesFile, kCalibrationFile}) {
    if (fs::exists(fs::path(dir_) / existing, ec)) {
      throw InputError(dir_, "folder",
                       std::string("already holds a recording (") + existing + " exists); record into a new folder");
    }
  }
  make_directory(dir_ + "/left");
  make_directory(dir_ + "/right");
  save_calibration(dir_ + "/" + kCalibrationFile, calibration_);

  const std::string header = std::string(kHeader) + "\n";
  std::string error;
  if (!write_file_atomically(frames_path_ + ".tmp", frames_path_, header.data(), header.size(), true, error,
                             options_.faults)) {
    throw InputError(frames_path_, "file", error);
  }
  csv_fd_ = ::open(frames_path_.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  if (csv_fd_ < 0) throw InputError(frames_path_, "file", "cannot open for appending: " + errno_text());
  csv_size_ = header.size();
  png_params_ = {cv::IMWRITE_PNG_COMPRESSION, options_.png_compression};
}

RecordingWriter::~RecordingWriter() {
  if (csv_fd_ >= 0) ::close(csv_fd_);
}

bool RecordingWriter::fail(const std::string& message) {
  error_ = message;
  return false;
}

bool RecordingWriter::check_frame(const StereoFrame& frame) {
  // Built only on failure: a good pair allocates nothing here.
  const auto pair = [&] { return "pair seq " + std::to_string(frame.seq) + ": "; };
  if (!is_grey_8_or_16(frame.left) || !is_grey_8_or_16(frame.right)) {
    return fail(pair() + "images must be 8-bit or 16-bit grey, found left " + describe(frame.left) + ", right " +
                describe(frame.right));
  }
  if (frame.left.size() != frame.right.size() || frame.left.type() != frame.right.type()) {
    return fail(pair() + "left is " + describe(frame.left) + " but right is " + describe(frame.right));
  }
  if (frame.left.size() != calibration_.image_size) {
    return fail(pair() + "images are " + describe(frame.left) + " but the calibration says " +
                std::to_string(calibration_.image_size.width) + "x" + std::to_string(calibration_.image_size.height));
  }
  if (pairs_written_ > 0 && frame.seq <= last_seq_) {
    return fail(pair() + "seq does not increase (previous pair was seq " + std::to_string(last_seq_) + ")");
  }
  if (pairs_written_ > 0 && frame.t_ns < last_t_ns_) {
    return fail(pair() + "t_ns " + std::to_string(frame.t_ns) + " is before the previous pair's " +
                std::to_string(last_t_ns_));
  }
  return true;
}

bool RecordingWriter::write_image(const cv::Mat& image, const char* side, std::uint64_t seq, std::string& final_path) {
  try {
    if (!cv::imencode(".png", image, encoded_, png_params_)) {
      return fail(std::string("cannot encode the ") + side + " image of seq " + std::to_string(seq));
    }
  } catch (const cv::Exception& e) {
    return fail(std::string("cannot encode the ") + side + " image of seq " + std::to_string(seq) + ": " + e.err);
  }
  image_path(tmp_path_, dir_, side, seq, true);
  image_path(final_path, dir_, side, seq, false);
  return write_file_atomically(tmp_path_, final_path, encoded_.data(), encoded_.size(), options_.sync_to_disk, error_,
                               options_.faults);
}

bool RecordingWriter::append_line(const StereoFrame& frame) {
  char numbers[48];
  std::snprintf(numbers, sizeof numbers, "%llu,%lld,%lld,", static_cast<unsigned long long>(frame.seq),
                static_cast<long long>(frame.t_ns), static_cast<long long>(frame.skew_ns));
  line_.assign(numbers);
  line_.append(left_path_, dir_.size() + 1);
  line_.push_back(',');
  line_.append(right_path_, dir_.size() + 1);
  line_.push_back('\n');
  const bool ok = fd_write_all(csv_fd_, line_.data(), line_.size(), options_.faults) &&
                  (!options_.sync_to_disk || ::fdatasync(csv_fd_) == 0);
  if (ok) {
    csv_size_ += line_.size();
    return true;
  }
  error_ = frames_path_ + ": cannot append the line of seq " + std::to_string(frame.seq) + ": " + errno_text();
  // Drop a partial line so the next append does not glue onto it.
  if (::ftruncate(csv_fd_, static_cast<off_t>(csv_size_)) != 0) {
    error_ += " (and cannot remove the partial line: " + errno_text() + ")";
  }
  return false;
}

bool RecordingWriter::append(const StereoFrame& frame) {
  error_.clear();
  if (!check_frame(frame)) return false;
  if (!write_image(frame.left, "left", frame.seq, left_path_)) return false;
  if (!write_image(frame.right, "right", frame.seq, right_path_)) {
    ::unlink(left_path_.c_str());
    return false;
  }
  if (!append_line(frame)) {
    ::unlink(left_path_.c_str());
    ::unlink(right_path_.c_str());
    return false;
  }
  ++pairs_written_;
  last_seq_ = frame.seq;
  last_t_ns_ = frame.t_ns;
  return true;
}

// ---------------------------------------------------------------------------------------------------
// ReplaySource

ReplaySource::ReplaySource(const std::string& dir, IoFaults* faults)
    : dir_(dir), frames_path_(dir + "/" + kFramesFile), faults_(faults) {
  std::error_code ec;
  if (!fs::exists(dir_, ec)) throw InputError(dir_, "folder", "does not exist");
  if (!fs::is_directory(dir_, ec)) throw InputError(dir_, "folder", "is not a folder");
  calibration_ = load_calibration(dir_ + "/" + kCalibrationFile);
  csv_.open(frames_path_, std::ios::binary);
  if (!csv_) throw InputError(frames_path_, "file", "cannot open: " + errno_text());
  if (!std::getline(csv_, line_)) throw InputError(frames_path_, "line 1", "missing header (file is empty)");
  if (!line_.empty() && line_.back() == '\r') line_.pop_back();
  if (line_ != kHeader && line_ != kHeaderWithoutSkew) {
    throw InputError(frames_path_, "line 1",
                     "header is '" + line_ + "' but must be '" + std::string(kHeader) +
                         "' (or, recorded before skew_ns, '" + std::string(kHeaderWithoutSkew) + "')");
  }
  fields_ = line_ == kHeader ? 5 : 4;
}

bool ReplaySource::reject(const std::string& message) {
  bad(LineResult::Bad, message);
  return false;
}

ReplaySource::LineResult ReplaySource::bad(LineResult kind, const std::string& message) {
  error_ = one_line(frames_path_) + ": line " + std::to_string(line_number_) + ": " + one_line(message);
  return kind;
}

bool ReplaySource::load_image(std::string_view relative, const char* side, cv::Mat& out) {
  // Messages are built only on failure: the success path allocates nothing once buffers have grown.
  const auto image = [&] { return std::string(side) + " image " + image_path_; };
  if (relative.empty()) return reject(std::string("empty ") + side + " image path");
  if (relative.front() == '/') {
    return reject(std::string(side) + " image path '" + std::string(relative) +
                  "' must be relative to the recording folder");
  }
  image_path_.assign(dir_).append("/").append(relative);
  // No PNG of the calibrated size comes near this (16-bit RGBA stored uncompressed is 8 bytes a pixel):
  // a frames.csv listing some huge file gets an error instead of an allocation of its size.
  const std::uint64_t max_bytes = 16ull * static_cast<std::uint64_t>(calibration_.image_size.area()) + (1u << 20);
  if (!read_file(image_path_, file_bytes_, max_bytes)) return reject("cannot read " + image() + ": " + errno_text());
  std::size_t decode_bytes = file_bytes_.size();
  if (const int fault = faults_ != nullptr ? faults_->check(IoPoint::ImageDecode) : 0) {
    // Tests only: the decoder gets what a damaged file would hand it. An errno: the read failed.
    if (fault > 0) {
      errno = fault;
      return reject("cannot read " + image() + ": " + errno_text());
    }
    if (fault == io_fault::kShort) decode_bytes /= 2;  // a file cut off mid-way
    if (fault == io_fault::kCorrupt) {                 // bit rot over the signature and the header chunk
      for (std::size_t i = 0; i < std::min<std::size_t>(decode_bytes, 32); ++i) file_bytes_[i] ^= 0x5A;
    }
  }
  // Recordings hold PNG only. Anything else is refused before OpenCV sees it: imdecode would hand it to
  // whichever of its other decoders (JPEG 2000, TIFF, OpenEXR ...) claims it, each a parser of its own
  // that writes to stderr. A header larger than the calibration is refused before decoding too, so a
  // corrupt header cannot make replay allocate gigabytes (smaller ones get check_pair's message).
  if (!is_png(file_bytes_)) return reject(image() + " is not a PNG image");
  if (const auto header = png_header_size(file_bytes_);
      header && (header->width > calibration_.image_size.width || header->height > calibration_.image_size.height)) {
    return reject(image() + " is " + std::to_string(header->width) + "x" + std::to_string(header->height) +
                  " (PNG header) but calibration says " + std::to_string(calibration_.image_size.width) + "x" +
                  std::to_string(calibration_.image_size.height));
  }
  // cv::imdecode leaves its destination untouched when the bytes do not decode: without this release a
  // corrupt image would silently come out as the previous pair's.
  decoded_.release();
  try {
    cv::imdecode(cv::_InputArray(file_bytes_.data(), static_cast<int>(decode_bytes)), cv::IMREAD_UNCHANGED, &decoded_);
  } catch (const cv::Exception&) {
    decoded_.release();
  }
  if (decoded_.empty()) return reject(image() + " is not a readable image");
  if (decoded_.depth() != CV_8U && decoded_.depth() != CV_16U) {
    return reject(image() + " is " + describe(decoded_) + "; expected 8-bit or 16-bit");
  }
  switch (decoded_.channels()) {
    case 1: decoded_.copyTo(out); break;
    case 3: cv::cvtColor(decoded_, out, cv::COLOR_BGR2GRAY); break;
    case 4: cv::cvtColor(decoded_, out, cv::COLOR_BGRA2GRAY); break;
    default: return reject(image() + " has " + std::to_string(decoded_.channels()) + " channels");
  }
  return true;
}

bool ReplaySource::check_pair(const StereoFrame& frame) {
  if (frame.left.size() != frame.right.size() || frame.left.type() != frame.right.type()) {
    return reject("left image is " + describe(frame.left) + " but right image is " + describe(frame.right));
  }
  if (frame.left.size() == calibration_.image_size) return true;
  try {
    check_frame_size(calibration_, frame.left.size(), image_path_);
  } catch (const InputError& e) {
    return reject(e.what());
  }
  return true;
}

ReplaySource::LineResult ReplaySource::read_pair(std::string_view line, StereoFrame& frame) {
  std::string_view fields[5];
  const std::size_t count = split_csv_fields(line, fields, 5);
  const auto expected = static_cast<std::size_t>(fields_);
  if (count != expected) {
    return bad(count < expected ? LineResult::TooFewFields : LineResult::Bad,
               "expected " + std::to_string(expected) + " fields (" +
                   std::string(expected == 5 ? kHeader : kHeaderWithoutSkew) + "), found " + std::to_string(count));
  }
  std::uint64_t seq = 0;
  std::int64_t t_ns = 0;
  if (!parse_csv_number(fields[0], seq)) {
    return bad(LineResult::Bad, "seq '" + std::string(fields[0]) + "' is not a non-negative integer");
  }
  if (!parse_csv_number(fields[1], t_ns)) {
    return bad(LineResult::Bad, "t_ns '" + std::string(fields[1]) + "' is not an integer");
  }
  std::int64_t skew_ns = 0;
  const std::size_t paths = fields_ == 5 ? 3 : 2;  // where the image paths begin
  if (fields_ == 5 && !parse_csv_number(fields[2], skew_ns)) {
    return bad(LineResult::Bad, "skew_ns '" + std::string(fields[2]) + "' is not an integer");
  }
  if (have_previous_ && seq <= previous_seq_) {
    return bad(LineResult::Bad, "seq " + std::to_string(seq) + " does not increase (previous pair was seq " +
                                    std::to_string(previous_seq_) + ")");
  }
  if (have_previous_ && t_ns < previous_t_ns_) {
    return bad(LineResult::Bad, "t_ns " + std::to_string(t_ns) + " goes backwards (previous pair was at " +
                                    std::to_string(previous_t_ns_) + ")");
  }
  if (!load_image(fields[paths], "left", frame.left) || !load_image(fields[paths + 1], "right", frame.right) ||
      !check_pair(frame)) {
    return LineResult::Bad;
  }
  frame.seq = seq;
  frame.t_ns = t_ns;
  frame.skew_ns = skew_ns;
  frame.clock = ClockKind::Monotonic;
  return LineResult::Ok;
}

SourceStatus ReplaySource::next(StereoFrame& frame) {
  error_.clear();
  while (!truncated_tail_ && std::getline(csv_, line_)) {
    ++line_number_;
    const bool has_newline = !csv_.eof();
    const bool last_line = !has_newline || csv_.peek() == std::char_traits<char>::eof();
    if (!line_.empty() && line_.back() == '\r') line_.pop_back();
    if (line_.find_first_not_of(" \t") == std::string::npos) continue;  // blank line: nothing listed

    const LineResult result = read_pair(line_, frame);
    if (result == LineResult::Ok) {
      have_previous_ = true;
      previous_seq_ = frame.seq;
      previous_t_ns_ = frame.t_ns;
      ++pairs_read_;
      return SourceStatus::Ok;
    }
    if (last_line && (!has_newline || result == LineResult::TooFewFields)) {
      truncated_tail_ = true;
      truncation_note_ = error_ + " (last line cut off; replay stopped at the last complete pair)";
      error_.clear();
      return SourceStatus::EndOfStream;
    }
    return SourceStatus::Error;
  }
  if (csv_.bad()) {
    error_ = frames_path_ + ": line " + std::to_string(line_number_ + 1) + ": read error";
    return SourceStatus::Error;
  }
  return SourceStatus::EndOfStream;
}

}  // namespace rutd
