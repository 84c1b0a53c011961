// rutd calibrate: stereo calibration from chessboard pairs, written in the calibration format that
// replay, record and run read (DESIGN.md, Formats).
#include <cmath>
#include <memory>
#include <sstream>

#include <spdlog/spdlog.h>

#include "daemon/commands.hpp"
#include "daemon/dimensions.hpp"
#include "geometry/stereo_calibrate.hpp"
#include "recording/calibration_file.hpp"

namespace rutd {
namespace {

struct CalibrateOptions {
  std::string image_list;
  std::vector<std::string> left, right;
  std::string board = "9x6";
  double square_mm = 25.0;
  std::string out;
};

cv::Size parse_board(const std::string& text) {
  const auto board = parse_dimensions(text, 2, 100);
  if (!board) throw CLI::ValidationError("--board", "expected inner corners COLSxROWS such as 9x6, got '" + text + "'");
  return *board;
}

int run_calibrate(CalibrateOptions o) {
  if (!o.image_list.empty()) read_image_list(o.image_list, o.left, o.right);
  if (o.left.size() != o.right.size())
    throw CLI::ValidationError("--left/--right", "need as many left as right images");
  const ChessboardSpec board{parse_board(o.board), o.square_mm};
  const StereoCalibrationReport report = calibrate_stereo(o.left, o.right, board);
  for (const auto& name : report.rejected) spdlog::warn("{}: chessboard not found in both views; pair skipped", name);
  save_calibration(o.out, report.calibration);
  const cv::Vec3d& t = report.calibration.T;
  spdlog::info(
      "{} pairs used, {} skipped; RMS reprojection error {:.3f} px, rectified row error {:.3f} px RMS; "
      "baseline {:.2f} mm; written to {}",
      report.used.size(), report.rejected.size(), report.rms_px, report.epipolar_rms_px, std::sqrt(t.dot(t)), o.out);
  return 0;
}

}  // namespace

void add_calibrate_command(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<CalibrateOptions>();
  CLI::App* cmd = app.add_subcommand("calibrate", "Stereo calibration from chessboard image pairs");
  auto* list = cmd->add_option("--imagelist", options->image_list,
                               "OpenCV image list (XML/YAML) of alternating left and right images");
  auto* left = cmd->add_option("--left", options->left, "Left images, in pair order");
  cmd->add_option("--right", options->right, "Right images, in pair order")->needs(left);
  left->excludes(list);
  cmd->add_option("--board", options->board, "Inner corners of the chessboard, COLSxROWS")->capture_default_str();
  cmd->add_option("--square-mm", options->square_mm, "Side of one chessboard square, mm")
      ->check(CLI::Range(0.1, 1000.0))
      ->capture_default_str();
  cmd->add_option("--out", options->out, "Calibration file to write")->required();
  cmd->callback([options, &exit_code] {
    if (options->image_list.empty() && options->left.empty())
      throw CLI::ValidationError("calibrate", "give --imagelist or --left/--right");
    exit_code = run_calibrate(*options);
  });
}

}  // namespace rutd
