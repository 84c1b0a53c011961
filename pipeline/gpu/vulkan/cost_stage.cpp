// Matching costs (shaders/cost.comp): one invocation per word of four disparities of a pixel.
#include "stages.hpp"

namespace rutd::gpu::vk {
namespace {

const std::uint32_t kCostSpv[] =
#include "cost.comp.inc"
    ;

// words: 32-bit words of byte costs per pixel (cost_words()).
struct CostPush {
  std::int32_t width, height, min_disparity, num_disparities, words;
};

}  // namespace

void CostStage::create(const KernelFactory& f) {
  kernel_ = f.make(kCostSpv, sizeof kCostSpv, sizeof(CostPush), [](const FrameBuffers& b) -> Bindings {
    return {{&b.census_left}, {&b.census_right}, {&b.match_cost}};
  });
}

void CostStage::record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band) const {
  const int words = cost_words(band.num_disparities);
  dispatch(cb, slot, kernel_, CostPush{image.width, image.height, band.min_disparity, band.num_disparities, words},
           groups(image.width * words, 64), static_cast<std::uint32_t>(image.height), 1);
}

}  // namespace rutd::gpu::vk
