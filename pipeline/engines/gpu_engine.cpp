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

bool matchable(const cv::Mat& left, const cv::Mat& right, DisparityBand band, const gpu::SgmConfig& params) {
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
      : config_(config), params_(sgm_params(config)), sgm_(std::move(probe)), device_(gpu::describe(sgm_->device())) {}
  // SgmRef once the engine has fallen back to the reference.
  EngineKind kind() const override { return fallback_ ? EngineKind::SgmRef : EngineKind::Gpu; }
  std::string device() const override { return fallback_ ? fallback_->device() : device_; }

  void compute(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& disparity) override {
    run(left, right, band, nullptr, disparity);
  }

  bool compute_refined(const cv::Mat& left, const cv::Mat& right, DisparityBand band, const DicConfig& dic,
                       cv::Mat& disparity, DicStats& stats) override {
    const gpu::DicKernelConfig p = dic_params(dic, left.rows);
    if (fallback_ || !gpu::check_dic_kernel_config(p).empty()) return false;
    if (!run(left, right, band, &p, disparity)) return false;
    stats = count_refined(p, disparity);
    return true;
  }

  bool rectify_and_match(const cv::Mat& left_raw, const cv::Mat& right_raw, const StereoGeometry& geometry,
                         const DisparityBand* band, const DicConfig* dic, cv::Mat& left_strip, cv::Mat& right_strip,
                         cv::Mat& disparity, DicStats& stats) override {
    const cv::Size strip(geometry.rectified_size().width, geometry.roi().rows);
    if (!takes_raw(left_raw, right_raw, geometry)) return false;
    gpu::DicKernelConfig p;
    if (band) {
      // A band the matcher refuses takes the caller's path, which gives the NaN disparity.
      if (!gpu::check_sgm_input(strip.width, strip.height, {band->min_disparity, band->num_disparities}, params_)
               .empty())
        return false;
      if (dic) {
        p = dic_params(*dic, strip.height);
        if (!gpu::check_dic_kernel_config(p).empty()) return false;
      }
    }
    if (!ready(strip, band ? band->num_disparities : 0, &geometry)) return false;
    left_strip.create(strip, CV_8UC1);
    right_strip.create(strip, CV_8UC1);
    if (band) disparity.create(strip, CV_32FC1);
    const gpu::SgmBand b = band ? gpu::SgmBand{band->min_disparity, band->num_disparities} : gpu::SgmBand{};
    int ticket = 0;
    gpu::GpuStatus s = sgm_->submit_raw(view(left_raw), view(right_raw), band ? &b : nullptr, params_,
                                        band && dic ? &p : nullptr, ticket);
    const gpu::StripsOut strips{left_strip.data, right_strip.data, left_strip.step[0]};
    if (s == gpu::GpuStatus::Ok)
      s = sgm_->collect(ticket, band ? disparity.ptr<float>() : nullptr, band ? disparity.step1() : 0, nullptr,
                        &strips);
    if (s != gpu::GpuStatus::Ok) {
      give_up(sgm_->device().name + ": " + std::string(gpu::to_string(s)));
      return false;
    }
    stats = band && dic ? count_refined(p, disparity) : DicStats{};
    return true;
  }

  bool coarse_match(const cv::Mat& left_raw, const cv::Mat& right_raw, const StereoGeometry& geometry, int scale,
                    DisparityBand coarse_band, cv::Mat& left_strip, cv::Mat& right_strip, cv::Mat& coarse_left,
                    cv::Mat& coarse_disparity) override {
    const cv::Size strip(geometry.rectified_size().width, geometry.roi().rows);
    const gpu::CoarseGrid grid = gpu::coarse_grid(strip.width, strip.height, scale);
    const gpu::SgmBand b{coarse_band.min_disparity, coarse_band.num_disparities};
    if (!takes_raw(left_raw, right_raw, geometry) || grid.width < 1 || grid.height < 1 ||
        !gpu::check_sgm_input(grid.width, grid.height, b, params_).empty())
      return false;
    if (!ready(strip, coarse_band.num_disparities, &geometry)) return false;
    left_strip.create(strip, CV_8UC1);
    right_strip.create(strip, CV_8UC1);
    coarse_left.create(grid.height, grid.width, CV_8UC1);
    coarse_disparity.create(grid.height, grid.width, CV_32FC1);
    gpu::StripsOut out{left_strip.data, right_strip.data, left_strip.step[0]};
    out.coarse_left = coarse_left.data;
    out.coarse_stride = coarse_left.step[0];
    int ticket = 0;
    gpu::GpuStatus s = sgm_->submit_coarse(view(left_raw), view(right_raw), scale, b, params_, ticket);
    if (s == gpu::GpuStatus::Ok)
      s = sgm_->collect(ticket, coarse_disparity.ptr<float>(), coarse_disparity.step1(), nullptr, &out);
    if (s != gpu::GpuStatus::Ok) {
      give_up(sgm_->device().name + ": " + std::string(gpu::to_string(s)));
      return false;
    }
    return true;
  }

 private:
  // Raw images the device rectifies: 8-bit, of the geometry's raw size, and a device not given up on.
  bool takes_raw(const cv::Mat& left_raw, const cv::Mat& right_raw, const StereoGeometry& geometry) const {
    return !fallback_ && left_raw.type() == CV_8UC1 && right_raw.type() == CV_8UC1 &&
           left_raw.size() == geometry.raw_size() && right_raw.size() == geometry.raw_size();
  }

  // Refined windows, as the CPU DIC counts them: pixels, or columns of each row block (a block's rows
  // are all refined or all NaN).
  static DicStats count_refined(const gpu::DicKernelConfig& p, const cv::Mat& disparity) {
    DicStats stats;
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
    return stats;
  }

  // Device buffers for `size` and at least `disparities`, and, with a geometry, its maps loaded. Buffers are
  // sized for the strip and the widest band seen; a new size or a wider band reallocates once (start-up,
  // or the band estimate widening) on the same device, never per frame in steady state. False after
  // falling back.
  bool ready(cv::Size size, int disparities, const StereoGeometry* geometry) {
    try {
      if (sgm_->width() != size.width || sgm_->height() != size.height || disparities > max_disparities_) {
        max_disparities_ = std::max({max_disparities_, disparities, 128});
        maps_ = nullptr;
        sgm_->resize(size.width, size.height, std::min(max_disparities_, gpu::kMaxDisparities));
      }
      if (geometry && maps_ != geometry) {
        const cv::Size raw = geometry->raw_size();
        sgm_->set_rectification(gpu::RectifyMaps{raw.width, raw.height, size.width, size.height, geometry->left_map(),
                                                 geometry->right_map()});
        maps_ = geometry;
      }
    } catch (const gpu::GpuError& e) {
      give_up(e.what());
      return false;
    }
    return true;
  }

  // False when the frame went to the fallback (unrefined).
  bool run(const cv::Mat& left, const cv::Mat& right, DisparityBand band, const gpu::DicKernelConfig* dic,
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
    if (!ready(left.size(), band.num_disparities, nullptr)) {
      fallback_->compute(left, right, band, disparity);
      return false;
    }
    const gpu::GpuStatus s = sgm_->compute(view(left), view(right), {band.min_disparity, band.num_disparities}, params_,
                                           dic, disparity.ptr<float>(), disparity.step1());
    if (s == gpu::GpuStatus::Ok) return true;
    fall_back(sgm_->device().name + ": " + std::string(gpu::to_string(s)), left, right, band, disparity);
    return false;
  }

  // A device that failed once is not trusted again: this frame and every later one go to the reference.
  void give_up(const std::string& reason) {
    log_fallback(reason);
    fallback_ = std::make_unique<SgmReferenceEngine>(config_, reason);
    sgm_.reset();
    maps_ = nullptr;
  }
  void fall_back(const std::string& reason, const cv::Mat& left, const cv::Mat& right, DisparityBand band,
                 cv::Mat& disparity) {
    give_up(reason);
    fallback_->compute(left, right, band, disparity);
  }

  EngineConfig config_;
  gpu::SgmConfig params_;
  std::unique_ptr<gpu::VulkanSgm> sgm_;
  std::string device_;  // gpu::describe() of sgm_'s device
  std::unique_ptr<SgmReferenceEngine> fallback_;
  int max_disparities_ = 0;
  // The geometry whose maps sgm_ holds (set_rectification); the caller keeps it alive and unchanged while
  // it passes it (a StereoMeasurer's own geometry).
  const StereoGeometry* maps_ = nullptr;
};
#endif

}  // namespace

gpu::SgmConfig sgm_params(const EngineConfig& c) {
  gpu::SgmConfig p;
  p.paths = c.sgm_paths;
  p.segment = c.sgm_segment;
  if (c.p1 >= 0) p.p1 = c.p1;
  if (c.p2 >= 0) p.p2 = c.p2;
  if (c.uniqueness_ratio >= 0) p.uniqueness = c.uniqueness_ratio;
  if (c.disp12_max_diff >= 0) p.lr_max_diff = c.disp12_max_diff;
  if (c.disp12_max_diff == -2) p.lr_max_diff = -1;
  const std::string error = gpu::check_sgm_input(1, 1, gpu::SgmBand{0, 2}, p);
  if (!error.empty()) throw std::invalid_argument("disparity engine: " + error);
  return p;
}

gpu::DicKernelConfig dic_params(const DicConfig& c, int rows) {
  gpu::DicKernelConfig p;
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

SgmReferenceEngine::SgmReferenceEngine(const EngineConfig& config, std::string gpu_unavailable)
    : params_(sgm_params(config)), gpu_unavailable_(std::move(gpu_unavailable)) {}

std::string SgmReferenceEngine::device() const {
  return gpu_unavailable_.empty() ? "CPU" : "CPU (the GPU engine runs as sgmref: " + gpu_unavailable_ + ")";
}

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

std::unique_ptr<DisparityEngine> make_gpu_engine(const EngineConfig& config, gpu::VulkanFaults* faults) {
  sgm_params(config);  // bad parameters throw, whichever engine runs
  std::string reason;
#ifdef RUTD_HAVE_GPU
  try {
    // The engine's one device, its pipelines built here; the first frame sizes the buffers (resize()).
    gpu::VulkanSgmOptions options;
    options.faults = faults;
    auto sgm = std::make_unique<gpu::VulkanSgm>(config.gpu_device, 16, 1, 2, options);
    // pipeline/ has no logger; stderr reaches the journal under systemd.
    std::fprintf(stderr, "rutd: GPU engine on %s\n", gpu::describe(sgm->device()).c_str());
    return std::make_unique<GpuEngine>(config, std::move(sgm));
  } catch (const gpu::GpuError& e) {
    reason = e.what();
  }
#else
  (void)faults;
  reason = "built without Vulkan";
#endif
  log_fallback(reason);
  return std::make_unique<SgmReferenceEngine>(config, reason);
}

}  // namespace rutd
