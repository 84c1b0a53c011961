#pragma once
// The census-SGM engines behind DisparityEngine: SgmReferenceEngine (the plain C++ reference, CPU) and the
// Vulkan engine made by make_gpu_engine (with the reference as its fallback). cv::Mat adapters only; the
// matching lives in gpu/ (OpenCV-free).
#include <memory>

#include "engines/disparity_engine.hpp"
#include "gpu/dic.hpp"
#include "gpu/sgm.hpp"

namespace rutd {

// Throws std::invalid_argument for parameters the matcher refuses.
gpu::SgmConfig sgm_params(const EngineConfig& config);

// DicConfig resolved for the GPU's DIC on a strip of `rows` rows (half_height, row_step, row_end given).
gpu::DicKernelConfig dic_params(const DicConfig& config, int rows);

class SgmReferenceEngine : public DisparityEngine {
 public:
  explicit SgmReferenceEngine(const EngineConfig& config);
  EngineKind kind() const override { return EngineKind::SgmRef; }
  // NaN everywhere for input the matcher cannot take (band, type); never throws.
  void compute(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& disparity) override;

 private:
  gpu::SgmConfig params_;
  gpu::SgmStages stages_;
};

// The Vulkan engine, or the reference after one line on stderr saying why (no GPU build, no usable device).
std::unique_ptr<DisparityEngine> make_gpu_engine(const EngineConfig& config);

}  // namespace rutd
