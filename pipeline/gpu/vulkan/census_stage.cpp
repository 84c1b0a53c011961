// The census transform of both images (shaders/census.comp): 16 x 8 pixels a workgroup, both cameras
// (workgroup z).
#include "stages.hpp"

namespace rutd::gpu::vk {
namespace {

const std::uint32_t kCensusSpv[] =
#include "census.comp.inc"
    ;

struct CensusPush {
  std::int32_t width, height, words_per_row;
};

}  // namespace

void CensusStage::create(const KernelFactory& f) {
  kernel_ = f.make(kCensusSpv, sizeof kCensusSpv, sizeof(CensusPush), [](const FrameBuffers& b) -> Bindings {
    return {{&b.image_left}, {&b.image_right}, {&b.census_left}, {&b.census_right}};
  });
}

void CensusStage::record(VkCommandBuffer cb, int slot, ImageSize image) const {
  dispatch(cb, slot, kernel_, CensusPush{image.width, image.height, image.words_per_row}, groups(image.width, 16),
           groups(image.height, 8), 2);
}

}  // namespace rutd::gpu::vk
