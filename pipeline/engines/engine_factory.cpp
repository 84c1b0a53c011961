#include "engines/engine_factory.hpp"

#include <stdexcept>

#include "gpu_engine.hpp"
#include "opencv_engines.hpp"

namespace rutd {

std::unique_ptr<DisparityEngine> make_cpu_engine(EngineKind kind, const EngineConfig& params) {
  if (kind == EngineKind::Bm) return std::make_unique<OpenCvBmEngine>(params);
  if (kind == EngineKind::SgmRef) return std::make_unique<SgmReferenceEngine>(params);
  if (kind == EngineKind::Gpu) throw std::invalid_argument("disparity engine: gpu is not a CPU engine");
  return std::make_unique<OpenCvSgbmEngine>(kind, params);
}

std::unique_ptr<DisparityEngine> make_engine(EngineKind kind, const EngineConfig& params) {
  if (kind == EngineKind::Gpu) return make_gpu_engine(params);
  return make_cpu_engine(kind, params);
}

void check_engine(EngineKind kind, const EngineConfig& params) {
  if (kind == EngineKind::Gpu) sgm_params(params);  // the device is looked for when the engine is made
  else make_cpu_engine(kind, params);               // OpenCV checks its parameters as the matcher is made
}

}  // namespace rutd
