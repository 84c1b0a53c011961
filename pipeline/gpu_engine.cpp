#include "gpu_engine.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#ifdef RUTD_HAVE_GPU
#include "gpu/vulkan_sgm.hpp"
#endif

namespace rutd {
namespace {

gpu::ImageView view(const cv::Mat& m) { return gpu::ImageView{m.data, m.cols, m.rows, m.step[0]}; }

bool matchable(const cv::Mat& left, const cv::Mat& right, DisparityBand band, const gpu::SgmParams& params) {
  return left.type() == CV_8UC1 && right.type() == CV_8UC1 && left.size() == right.size() &&
         gpu::check_sgm_input(left.cols, left.rows, gpu::SgmBand{band.min_disparity, band.num_disparities}, params)
             .empty();
}

void log_fallback(const std::string& reason) {
  // pipeline/ has no logger; stderr reaches the journal under systemd.
  std::fprintf(stderr, "rutd: GPU engine unavailable (%s); using the CPU reference engine sgmref\n", reason.c_str());
}

#ifdef RUTD_HAVE_GPU
class GpuEngine : public DisparityEngine {
 public:
  GpuEngine(const EngineConfig& config, std::unique_ptr<gpu::VulkanSgm> probe)
      : config_(config), params_(sgm_params(config)), sgm_(std::move(probe)) {}
  // SgmRef once the engine has fallen back to the reference.
  EngineKind kind() const override { return fallback_ ? EngineKind::SgmRef : EngineKind::Gpu; }

  void compute(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& disparity) override {
    run(left, right, band, nullptr, disparity);
  }

  bool compute_refined(const cv::Mat& left, const cv::Mat& right, DisparityBand band, const DicConfig& dic,
                       cv::Mat& disparity, DicStats& stats) override {
    const gpu::DicParams p = dic_params(dic, left.rows);
    if (fallback_ || !gpu::check_dic_params(p).empty()) return false;
    if (!run(left, right, band, &p, disparity)) return false;
    // Refined windows, as the CPU DIC counts them: pixels, or columns of each row block (a block's rows
    // are all refined or all NaN).
    stats = DicStats{};
    if (p.column_windows) {
      const gpu::ColumnBlocks blocks(p, disparity.rows);
      for (int b = 0; b < blocks.count; ++b) {
        const float* d = disparity.ptr<float>(blocks.begin(b));
        for (int x = 0; x < disparity.cols; ++x) stats.refined += !std::isnan(d[x]);
      }
    } else {
      for (int y = 0; y < disparity.rows; ++y) {
        const float* d = disparity.ptr<float>(y);
        for (int x = 0; x < disparity.cols; ++x) stats.refined += !std::isnan(d[x]);
      }
    }
    return true;
  }

 private:
  // False when the frame went to the fallback (unrefined).
  bool run(const cv::Mat& left, const cv::Mat& right, DisparityBand band, const gpu::DicParams* dic,
           cv::Mat& disparity) {
    disparity.create(left.size(), CV_32FC1);
    if (fallback_) {
      fallback_->compute(left, right, band, disparity);
      return false;
    }
    if (!matchable(left, right, band, params_)) {
      disparity.setTo(std::numeric_limits<float>::quiet_NaN());
      return true;
    }
    // Buffers are sized for the strip and the widest band seen; a new size or a wider band reallocates
    // once (start-up, or the band estimate widening), never per frame in steady state.
    if (sgm_->width() != left.cols || sgm_->height() != left.rows || band.num_disparities > max_disparities_) {
      max_disparities_ = std::max({max_disparities_, band.num_disparities, 128});
      try {
        sgm_.reset();
        sgm_ = std::make_unique<gpu::VulkanSgm>(config_.gpu_device, left.cols, left.rows,
                                                std::min(max_disparities_, gpu::kMaxDisparities));
      } catch (const gpu::GpuError& e) {
        fall_back(e.what(), left, right, band, disparity);
        return false;
      }
    }
    const gpu::GpuStatus s = sgm_->compute(view(left), view(right), {band.min_disparity, band.num_disparities}, params_,
                                           dic, disparity.ptr<float>(), disparity.step1());
    if (s == gpu::GpuStatus::Ok) return true;
    fall_back(sgm_->device().name + ": " + std::string(gpu::to_string(s)), left, right, band, disparity);
    return false;
  }

  // A device that failed once is not trusted again: this frame and every later one go to the reference.
  void fall_back(const std::string& reason, const cv::Mat& left, const cv::Mat& right, DisparityBand band,
                 cv::Mat& disparity) {
    log_fallback(reason);
    fallback_ = std::make_unique<SgmReferenceEngine>(config_);
    sgm_.reset();
    fallback_->compute(left, right, band, disparity);
  }

  EngineConfig config_;
  gpu::SgmParams params_;
  std::unique_ptr<gpu::VulkanSgm> sgm_;
  std::unique_ptr<SgmReferenceEngine> fallback_;
  int max_disparities_ = 0;
};
#endif

}  // namespace

gpu::SgmParams sgm_params(const EngineConfig& c) {
  gpu::SgmParams p;
  p.paths = c.sgm_paths;
  if (c.p1 >= 0) p.p1 = c.p1;
  if (c.p2 >= 0) p.p2 = c.p2;
  if (c.uniqueness_ratio >= 0) p.uniqueness = c.uniqueness_ratio;
  if (c.disp12_max_diff >= 0) p.lr_max_diff = c.disp12_max_diff;
  if (c.disp12_max_diff == -2) p.lr_max_diff = -1;
  const std::string error = gpu::check_sgm_input(1, 1, gpu::SgmBand{0, 2}, p);
  if (!error.empty()) throw std::invalid_argument("disparity engine: " + error);
  return p;
}

gpu::DicParams dic_params(const DicConfig& c, int rows) {
  gpu::DicParams p;
  p.half_window = c.half_window;
  p.half_height = c.half_height > 0 ? c.half_height : c.half_window;
  p.max_iterations = c.max_iterations;
  p.tolerance_px = static_cast<float>(c.tolerance_px);
  p.step = c.step;
  p.row_step = c.row_step > 0 ? c.row_step : c.step;
  p.row_begin = std::clamp(c.row_begin, 0, rows);
  p.row_end = c.row_end < 0 ? rows : std::clamp(c.row_end, p.row_begin, rows);
  p.first_order = c.first_order;
  p.max_shift_px = static_cast<float>(c.max_shift_px);
  p.max_gradient = static_cast<float>(c.max_gradient);
  p.min_gradient = static_cast<float>(c.min_gradient);
  p.min_zncc = static_cast<float>(c.min_zncc);
  p.max_sigma_px = static_cast<float>(c.max_sigma_px);
  p.column_windows = c.column_windows;
  p.column_block_rows = c.column_block_rows;
  return p;
}

SgmReferenceEngine::SgmReferenceEngine(const EngineConfig& config) : params_(sgm_params(config)) {}

void SgmReferenceEngine::compute(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& disparity) {
  disparity.create(left.size(), CV_32FC1);
  if (!matchable(left, right, band, params_)) {
    disparity.setTo(std::numeric_limits<float>::quiet_NaN());
    return;
  }
  gpu::sgm_reference(view(left), view(right), {band.min_disparity, band.num_disparities}, params_, stages_);
  for (int y = 0; y < left.rows; ++y)
    std::copy_n(stages_.disparity.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(left.cols), left.cols,
                disparity.ptr<float>(y));
}

std::unique_ptr<DisparityEngine> make_gpu_engine(const EngineConfig& config) {
  sgm_params(config);  // bad parameters throw, whichever engine runs
#ifdef RUTD_HAVE_GPU
  try {
    // A small probe: finds the device, builds the pipelines; the first frame sizes the buffers.
    auto probe = std::make_unique<gpu::VulkanSgm>(config.gpu_device, 16, 1, 2);
    return std::make_unique<GpuEngine>(config, std::move(probe));
  } catch (const gpu::GpuError& e) {
    log_fallback(e.what());
  }
#else
  log_fallback("built without Vulkan");
#endif
  return std::make_unique<SgmReferenceEngine>(config);
}

}  // namespace rutd
