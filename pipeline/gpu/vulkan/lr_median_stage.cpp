// Left-right check and median (shaders/lr_median.comp): one invocation per pixel.
#include "stages.hpp"

namespace rutd::gpu::vk {
namespace {

const std::uint32_t kLrMedianSpv[] =
#include "lr_median.comp.inc"
    ;

struct LrMedianPush {
  std::int32_t width, height, max_diff, median, min_disparity;
};

}  // namespace

void LrMedianStage::create(const KernelFactory& f) {
  kernel_ = f.make(kLrMedianSpv, sizeof kLrMedianSpv, sizeof(LrMedianPush), [](const FrameBuffers& b) -> Bindings {
    return {{&b.disp_left}, {&b.right_key}, {&b.disparity}};
  });
}

void LrMedianStage::record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band, const SgmConfig& params) const {
  dispatch(cb, slot, kernel_,
           LrMedianPush{image.width, image.height, params.lr_max_diff, params.median ? 1 : 0, band.min_disparity},
           groups(image.width, 64), static_cast<std::uint32_t>(image.height), 1);
}

}  // namespace rutd::gpu::vk
