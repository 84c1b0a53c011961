// Winner-takes-all (shaders/wta.comp): workgroup (segment of 16 pixels, row); the right view's keys go
// to FrameBuffers::right_key by atomic minimum, which frame.cpp fills with "none" first.
#include "stages.hpp"

namespace rutd::gpu::vk {
namespace {

const std::uint32_t kWtaSpv[] =
#include "wta.comp.inc"
    ;

constexpr int kWtaSegment = 16;  // pixels per workgroup of wta.comp

struct WtaPush {
  std::int32_t width, height, min_disparity, num_disparities, uniqueness, paths, words;
};

}  // namespace

void WtaStage::create(const KernelFactory& f) {
  kernel_ = f.make(kWtaSpv, sizeof kWtaSpv, sizeof(WtaPush), [](const FrameBuffers& b) -> Bindings {
    std::vector<const Buffer*> costs;
    for (const Buffer& c : b.costs) costs.push_back(&c);
    return {costs, {&b.disp_left}, {&b.right_key}};
  });
}

void WtaStage::record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band, const SgmConfig& params) const {
  dispatch(cb, slot, kernel_,
           WtaPush{image.width, image.height, band.min_disparity, band.num_disparities, params.uniqueness, params.paths,
                   cost_words(band.num_disparities)},
           groups(image.width, kWtaSegment), static_cast<std::uint32_t>(image.height), 1);
}

}  // namespace rutd::gpu::vk
