#pragma once
// The census-SGM engines behind DisparityEngine: SgmReferenceEngine (the plain C++ reference, CPU) and the
// Vulkan engine made by make_gpu_engine (with the reference as its fallback). cv::Mat adapters only; the
// matching lives in gpu/ (OpenCV-free).
#include <memory>
#include <string>

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
  // gpu_unavailable: why the GPU engine runs as this one (device() says so), empty when chosen as such.
  explicit SgmReferenceEngine(const EngineConfig& config, std::string gpu_unavailable = {});
  EngineKind kind() const override { return EngineKind::SgmRef; }
  std::string device() const override;
  // NaN everywhere for input the matcher cannot take (band, type); never throws.
  void compute(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& disparity) override;

 private:
  gpu::SgmConfig params_;
  gpu::SgmStages stages_;
  std::string gpu_unavailable_;
};

namespace gpu {
class VulkanFaults;
}

// The Vulkan engine, or the reference after one line on stderr saying why (no GPU build, no usable device).
// The engine opens one device for its lifetime and says so in one line on stderr ("rutd: GPU engine on
// ..."). faults: tests only (gpu/vulkan_faults.hpp), kept alive by the caller while the engine exists.
std::unique_ptr<DisparityEngine> make_gpu_engine(const EngineConfig& config, gpu::VulkanFaults* faults = nullptr);

}  // namespace rutd
