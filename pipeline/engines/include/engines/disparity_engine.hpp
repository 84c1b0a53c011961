#pragma once
// Disparity engines (DESIGN.md §3): the interface every engine implements (OpenCV's on the CPU, census SGM
// on the CPU or a Vulkan device), the engine kinds and their tuning. The engines themselves are private
// to this library; engines/engine_factory.hpp makes them.
#include <optional>
#include <string>
#include <string_view>

#include <opencv2/core.hpp>

#include "geometry/stereo_geometry.hpp"
#include "refinement/dic_refine.hpp"

namespace rutd {

// Bm: OpenCV StereoBM. Sgbm/Sgbm3Way/Hh4/Hh: OpenCV StereoSGBM in its MODE_SGBM (5 paths),
// MODE_SGBM_3WAY, MODE_HH4 (4 paths) and MODE_HH (8 paths, full-image memory) modes.
// Gpu: census semi-global matching in Vulkan compute (pipeline/gpu/); SgmRef: its plain C++ reference on
// the CPU, the same arithmetic and the same disparities (and the GPU engine's fallback).
enum class EngineKind { Bm, Sgbm, Sgbm3Way, Hh4, Hh, Gpu, SgmRef };

// "bm", "sgbm", "sgbm3way", "hh4", "hh", "gpu", "sgmref"; nullopt for anything else.
std::optional<EngineKind> parse_engine(std::string_view name);
std::string_view to_string(EngineKind kind);

// Disparities searched: min_disparity .. min_disparity + num_disparities - 1, pixels. num_disparities
// is a positive multiple of 16 (what the OpenCV engines require).
struct DisparityBand {
  int min_disparity = 0;
  int num_disparities = 16;
};

// One engine per thread; not thread-safe. Engines keep their scratch between calls.
class DisparityEngine {
 public:
  virtual ~DisparityEngine() = default;
  virtual EngineKind kind() const = 0;
  // Where the engine computes, for logs and reports: "CPU" for the CPU engines; the GPU engine names its
  // device and driver, or says that it runs on the CPU reference instead and why.
  virtual std::string device() const { return "CPU"; }
  // left/right: rectified CV_8UC1 strips of equal size. disparity: CV_32FC1 of the same size in pixels,
  // with the engine's sub-pixel precision kept (1/16 px for OpenCV), NaN where invalid (including the
  // left min_disparity + num_disparities columns, which have no match in the right strip). Reuses
  // `disparity` when it already fits.
  virtual void compute(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& disparity) = 0;
  // Engines that also refine on their own device (Gpu): compute(), then the DIC of refine_disparity_dic
  // with `dic` there, in one call (stats.refined counted, the rest 0). Returns false, doing nothing, when
  // the engine cannot; the caller then refines on the CPU.
  virtual bool compute_refined(const cv::Mat& /*left*/, const cv::Mat& /*right*/, DisparityBand /*band*/,
                               const DicConfig& /*dic*/, cv::Mat& /*disparity*/, DicStats& /*stats*/) {
    return false;
  }
  // Engines that rectify on their own device (Gpu, 8-bit raw images): rectifies the raw pair there through
  // geometry's maps (the rectified strips come back in left_strip/right_strip, CV_8UC1, for the frame
  // checks), then, when band is given, matches in it and refines with `dic` as compute_refined() does
  // (dic == nullptr: compute() only; stats.refined counted). band == nullptr: rectification only.
  // Returns false, doing nothing, when the engine cannot; the caller then rectifies on the CPU.
  virtual bool rectify_and_match(const cv::Mat& /*left_raw*/, const cv::Mat& /*right_raw*/,
                                 const StereoGeometry& /*geometry*/, const DisparityBand* /*band*/,
                                 const DicConfig* /*dic*/, cv::Mat& /*left_strip*/, cv::Mat& /*right_strip*/,
                                 cv::Mat& /*disparity*/, DicStats& /*stats*/) {
    return false;
  }
  // The coarse pass of BandEstimator on the engine's device (Gpu, 8-bit raw images): rectifies the raw pair
  // as rectify_and_match() does (strips back in left_strip/right_strip), averages the strips over blocks
  // of `scale` columns by 2 rows (1 row for strips under 10 rows; gpu::coarse_grid) into coarse_left
  // (CV_8UC1), and matches the coarse pair in coarse_band (coarse px) into coarse_disparity (CV_32FC1,
  // coarse px, NaN invalid). Returns false, doing nothing, when the engine cannot.
  virtual bool coarse_match(const cv::Mat& /*left_raw*/, const cv::Mat& /*right_raw*/,
                            const StereoGeometry& /*geometry*/, int /*scale*/, DisparityBand /*coarse_band*/,
                            cv::Mat& /*left_strip*/, cv::Mat& /*right_strip*/, cv::Mat& /*coarse_left*/,
                            cv::Mat& /*coarse_disparity*/) {
    return false;
  }
};

// Engine tuning. block_size 0 and every other field -1 mean "the engine's default" (given per field).
struct EngineConfig {
  int block_size = 0;          // odd, px. Default: 15 for Bm, 5 for the SGBM modes (clamped to the strip)
  int uniqueness_ratio = -1;   // percent margin of the best cost over the second best. Default 15 / 10
  int speckle_window = -1;     // px; connected regions smaller than this are invalidated, 0 = off. Default 100
  int speckle_range = -1;      // px; max disparity step inside one speckle region. Default 2
  int disp12_max_diff = -1;    // px; left-right consistency tolerance. Default 1; -2 switches the check off
  int pre_filter_cap = -1;     // clipping of the prefiltered image. Default 31 (Bm) / 63 (SGBM)
  int texture_threshold = -1;  // Bm only: minimum texture in the block. Default 10
  int p1 = -1;                 // SGBM smoothness penalty for +-1 px steps. Default 8 * block_size^2
  int p2 = -1;                 // SGBM smoothness penalty for larger steps. Default 32 * block_size^2
  // Gpu/SgmRef: block_size, speckle and pre-filter fields do not apply (9x7 census); p1/p2 are in census
  // bits (default 10/120), uniqueness_ratio defaults to 10, disp12_max_diff as above.
  int sgm_paths = 8;       // Gpu/SgmRef: 2, 4 or 8 aggregation paths
  int sgm_segment = 0;     // Gpu/SgmRef: rows aggregated in segments of this many px (gpu::SgmConfig), 0 off
  std::string gpu_device;  // Gpu: "" the first GPU; a number: that Vulkan device index; else a name part
};

}  // namespace rutd
