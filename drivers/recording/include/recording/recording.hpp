#pragma once
// The recording folder (DESIGN.md, Formats): what `record` writes and `replay` reads.
//
//   calibration.yaml   the rig's calibration (recording/calibration_file.hpp)
//   frames.csv         header `seq,t_ns,skew_ns,left,right`, one line per pair, skew_ns the right camera's
//                      capture time minus the left's (older recordings lack the column: skew 0), image
//                      paths relative to the folder
//   left/*.png         raw (unrectified) 8-bit or 16-bit grey images, named by seq
//   right/*.png
//
// Anything else in the folder is ignored. A recording cut off by a crash or a power loss replays up to
// its last complete pair: the writer makes each pair's images durable before the line that lists them.
#include <cstdint>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "core/frame_source.hpp"
#include "core/io_faults.hpp"
#include "core/stereo_calibration.hpp"
#include "core/stereo_frame.hpp"

namespace rutd {

struct RecordingWriterConfig {
  // fdatasync each image and each frames.csv line before the next step, so that a power loss (not only
  // a killed process) leaves every listed pair replayable. Off: safe against a killed process only.
  bool sync_to_disk = true;
  // PNG zlib level 0..9. Low levels keep encoding within a frame period; PNG stays lossless at any level.
  int png_compression = 1;
  // Tests only (core/io_faults.hpp): faults at every write() of the recording, IoPoint::RecordWrite.
  // Not owned; must outlive the writer.
  IoFaults* faults = nullptr;
};

// Writes a new recording. Not thread-safe: one writer thread. Allocation happens on the first pairs
// only; later pairs of the same size reuse the encode and path buffers (OpenCV's PNG encoder itself
// still allocates internally).
class RecordingWriter {
 public:
  // Creates dir (and left/, right/) if needed, writes calibration.yaml and the frames.csv header.
  // Throws InputError(dir or file, ...) if the folder cannot be written or already holds a recording
  // (a frames.csv or calibration.yaml), so an earlier recording is never overwritten.
  RecordingWriter(const std::string& dir, const StereoCalibration& calibration, RecordingWriterConfig options = {});
  ~RecordingWriter();
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  // Crash-safe append: both images are fully written (temp file + rename) before the frames.csv line is
  // appended and flushed, so a kill at any moment leaves a folder that replays every listed pair.
  // Returns false (and sets error()) on failure: disk full, unwritable, or a pair the reader would
  // refuse (not CV_8UC1/CV_16UC1, left/right differ, size differs from the calibration, seq not
  // increasing, t_ns going backwards). Nothing of a failed pair stays listed; the caller keeps
  // measuring and may call append again (e.g. once space is freed).
  bool append(const StereoFrame& frame);

  // Why the last append failed; empty after a successful one.
  const std::string& error() const { return error_; }
  std::uint64_t pairs_written() const { return pairs_written_; }
  const std::string& directory() const { return dir_; }

 private:
  bool check_frame(const StereoFrame& frame);
  bool write_image(const cv::Mat& image, const char* side, std::uint64_t seq, std::string& final_path);
  bool append_line(const StereoFrame& frame);
  bool fail(const std::string& message);

  std::string dir_;
  std::string frames_path_;
  StereoCalibration calibration_;
  RecordingWriterConfig options_;
  int csv_fd_ = -1;
  std::uint64_t csv_size_ = 0;  // bytes of frames.csv that are complete lines
  std::uint64_t pairs_written_ = 0;
  std::uint64_t last_seq_ = 0;
  std::int64_t last_t_ns_ = 0;
  std::string error_;
  // Reused per pair.
  std::vector<unsigned char> encoded_;
  std::vector<int> png_params_;
  std::string tmp_path_, left_path_, right_path_, line_;
};

// Replays a recording as fast as it can read. Not thread-safe: one thread owns it. The frame's image
// buffers are reused when size and type fit; the reader's file buffer is reused across pairs (the decoded
// image is not: OpenCV's decoder allocates it).
class ReplaySource : public FrameSource {
 public:
  // Opens dir: reads and checks calibration.yaml (load_calibration) and the frames.csv header. Throws
  // InputError naming the file and field/line for a missing folder or file or a bad header.
  // faults: tests only (core/io_faults.hpp), IoPoint::ImageDecode: an image read that fails, or bytes
  // cut short or corrupted before the decoder sees them. Not owned.
  explicit ReplaySource(const std::string& dir, IoFaults* faults = nullptr);

  // Streams frames.csv line by line. Error (error_message() = "FILE: line N: message") for a malformed
  // line, a missing or unreadable image, left/right size or type mismatch, a size that differs from the
  // calibration, seq or t_ns going backwards; the next call goes on with the next line. On Error the
  // frame's contents are unspecified. A last line cut off by a power loss (no terminating newline and
  // not replayable, or too few fields) ends the stream: EndOfStream and truncated_tail() == true.
  // Colour images are converted to grey. frame.clock is Monotonic (the recording's own time base).
  SourceStatus next(StereoFrame& frame) override;

  const StereoCalibration& calibration() const override { return calibration_; }
  const std::string& error_message() const override { return error_; }
  const std::string& directory() const { return dir_; }
  // True once the stream ended at a cut-off last line; truncation_note() then says which line.
  bool truncated_tail() const { return truncated_tail_; }
  const std::string& truncation_note() const { return truncation_note_; }
  std::uint64_t pairs_read() const { return pairs_read_; }

 private:
  enum class LineResult { Ok, TooFewFields, Bad };
  LineResult read_pair(std::string_view line, StereoFrame& frame);
  bool load_image(std::string_view relative, const char* side, cv::Mat& out);
  bool check_pair(const StereoFrame& frame);
  // Set error_ to "FILE: line N: message"; bad() returns `kind`, reject() returns false.
  LineResult bad(LineResult kind, const std::string& message);
  bool reject(const std::string& message);

  std::string dir_;
  std::string frames_path_;
  StereoCalibration calibration_;
  std::ifstream csv_;
  std::uint64_t line_number_ = 1;  // of the line last read; the header is line 1
  int fields_ = 5;                 // per line: 5, or 4 in a recording made before skew_ns
  bool have_previous_ = false;
  std::uint64_t previous_seq_ = 0;
  std::int64_t previous_t_ns_ = 0;
  std::uint64_t pairs_read_ = 0;
  bool truncated_tail_ = false;
  std::string truncation_note_;
  std::string error_;
  // Reused per pair.
  std::string line_, image_path_;
  std::vector<char> file_bytes_;
  cv::Mat decoded_;
  IoFaults* faults_;
};

}  // namespace rutd
