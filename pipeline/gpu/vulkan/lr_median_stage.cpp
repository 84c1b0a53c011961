// Left-right check and median (shaders/lr_median.comp): one invocation per pixel.
#include "stages.hpp"

namespace rutd::gpu::vk {
namespace {

const std::uint32_t kLrMedianSpv[] =
#include "lr_median.comp.inc"
    ;

// outputs: bit 0 the float disparity, bit 1 the fixed-point one.
struct LrMedianPush {
  std::int32_t width, height, max_diff, median, min_disparity, outputs, base, scale;
};

}  // namespace

void LrMedianStage::create(const KernelFactory& f) {
  kernel_ = f.make(kLrMedianSpv, sizeof kLrMedianSpv, sizeof(LrMedianPush), [](const FrameBuffers& b) -> Bindings {
    return {{&b.disp_left}, {&b.right_key}, {&b.disparity}, {&b.fixed}};
  });
}

void LrMedianStage::record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band, const SgmConfig& params,
                           bool float_out, bool fixed_out, FixedPoint fixed) const {
  dispatch(cb, slot, kernel_,
           LrMedianPush{image.width, image.height, params.lr_max_diff, params.median ? 1 : 0, band.min_disparity,
                        (float_out ? 1 : 0) | (fixed_out ? 2 : 0), fixed.base, fixed.scale},
           groups(image.width, 64), static_cast<std::uint32_t>(image.height), 1);
}

}  // namespace rutd::gpu::vk
