#pragma once
// Disparity engines (DESIGN.md §3): the interface every engine (CPU here, a GPU engine later) implements,
// the CPU factory, and the choice of the search band from the working range of distances.
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "pipeline/dic_refine.hpp"
#include "pipeline/stereo_geometry.hpp"

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

// Plausible distances from the left camera to the terrain along the rectified optical axis, mm.
struct WorkingRange {
  double near_mm = 150.0;
  double far_mm = 1500.0;
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

// Throws std::invalid_argument for parameters OpenCV would refuse (even block size, p2 <= p1, ...), and for
// EngineKind::Gpu (not a CPU engine).
std::unique_ptr<DisparityEngine> make_cpu_engine(EngineKind kind, const EngineConfig& params = {});

// Any engine. Gpu: when the build has no Vulkan engine or no usable Vulkan device exists (or the device
// fails later), the engine logs the reason once on stderr and computes with the SgmRef engine instead
// (same disparities, slower). Throws std::invalid_argument for bad parameters.
std::unique_ptr<DisparityEngine> make_engine(EngineKind kind, const EngineConfig& params = {});

// Throws std::invalid_argument where make_engine would, without making the engine (no GPU device is
// opened): a start-up check for objects that make their engine later.
void check_engine(EngineKind kind, const EngineConfig& params = {});

// The band that covers every disparity of `range` (far end rounded down, near end up), min_disparity
// >= 0. Can be wide (hundreds of px) for a wide range; see estimate_band.
DisparityBand band_for_range(const StereoGeometry& g, WorkingRange range);

// The terrain is near a plane at an unknown distance in `range`: a coarse pass (strips downsampled
// horizontally by a power of two so the band of `range` fits in at most 128 coarse px, and to every second
// row; StereoSGBM 3-way) finds the disparities present at textured pixels; returns a narrow band around
// them (2nd..98th percentile plus a margin of max(4 px, 2 coarse px, 25% of the spread)), clamped to
// band_for_range(range). Returns band_for_range(range) when fewer than 5% of the coarse pixels get a
// disparity. BandEstimator keeps the coarse matcher and its buffers between calls, for the per-frame path
// (one per thread); estimate_band is the one-off form and builds them each call.
class BandEstimator {
 public:
  DisparityBand estimate(const cv::Mat& left_strip, const cv::Mat& right_strip, const StereoGeometry& g,
                         WorkingRange range);
  // The same estimate with the coarse pass on `engine`'s device from the raw pair (coarse_match: the
  // device's census matcher instead of StereoSGBM, the strips rectified there and returned in
  // left_strip/right_strip). std::nullopt when the engine cannot, or the range needs no coarse pass:
  // then rectify and call estimate().
  std::optional<DisparityBand> estimate_on_device(DisparityEngine& engine, const cv::Mat& left_raw,
                                                  const cv::Mat& right_raw, const StereoGeometry& g, WorkingRange range,
                                                  cv::Mat& left_strip, cv::Mat& right_strip);

 private:
  struct Plan {
    DisparityBand full;   // band_for_range
    int scale = 1;        // columns averaged per coarse pixel
    bool coarse = false;  // false: the full band is the answer
    DisparityBand coarse_band;
    cv::Size coarse_size;
  };
  static Plan plan(const StereoGeometry& g, WorkingRange range, cv::Size strip);
  // From coarse_ and left_ (the coarse pair's disparity and left image).
  DisparityBand band_from_coarse(const Plan& p);

  std::unique_ptr<DisparityEngine> engine_;
  int engine_block_ = 0;  // block size engine_ was made with
  cv::Mat left_, right_, coarse_, texture_;
  std::vector<float> found_;
};

// Keeps the last estimated band while the frames measured in it say it still fits, so that the coarse
// pass of BandEstimator runs once every few frames instead of on every one (it costs about as much as
// the narrow-band match itself). Terrain moves little between frames at camera rates, and a band that
// stops fitting shows at once: matches pile up against its edges or disappear. One per match thread.
class BandTracker {
 public:
  // The most frames measured in one estimated band: a refresh that bounds how long a band chosen on
  // an unusual frame can stay.
  static constexpr int kMaxFrames = 30;

  // The band to match this frame in, if the last one still fits; std::nullopt: estimate a new one.
  std::optional<DisparityBand> band() const;
  // After matching in `band`: the frame's disparities (CV_32FC1 px, NaN invalid), rows
  // [row_begin, row_end) measured. Keeps the band for the next frame when their 2..98 percentiles stay
  // at least kEdgePx inside it and the valid share is at least 0.8 of the share on the band's first
  // frame (and at least 0.25 overall).
  void update(DisparityBand band, bool estimated, const cv::Mat& disparity, int row_begin, int row_end);

 private:
  static constexpr double kEdgePx = 2.0;
  DisparityBand band_;
  int frames_ = 0;  // frames measured in band_; 0: none to keep
  double first_valid_ = 0;
  std::vector<float> values_;
};

DisparityBand estimate_band(const cv::Mat& left_strip, const cv::Mat& right_strip, const StereoGeometry& g,
                            WorkingRange range);

}  // namespace rutd
