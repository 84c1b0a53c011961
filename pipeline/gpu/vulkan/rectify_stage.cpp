// Rectification on the device (shaders/rectify.comp): one invocation per word of four strip pixels, both
// cameras (workgroup z), reading the uploaded raw rows through the maps.
#include "stages.hpp"

namespace rutd::gpu::vk {
namespace {

const std::uint32_t kRectifySpv[] =
#include "rectify.comp.inc"
    ;

struct RectifyPush {
  std::int32_t width, height, words_per_row, raw_width, raw_height, raw_words_per_row, raw_row0;
};

Bindings rectify_bindings(const FrameBuffers& f, const Buffer& map_left, const Buffer& map_right) {
  return {{&f.raw_left}, {&f.raw_right}, {&map_left}, {&map_right}, {&f.image_left}, {&f.image_right}};
}

}  // namespace

void RectifyStage::create(const KernelFactory& f, const Buffer& map_left, const Buffer& map_right) {
  kernel_ = f.make(kRectifySpv, sizeof kRectifySpv, sizeof(RectifyPush),
                   [l = &map_left, r = &map_right](const FrameBuffers& b) { return rectify_bindings(b, *l, *r); });
}

void RectifyStage::record(VkCommandBuffer cb, int slot, ImageSize strip, const RawRows& raw) const {
  dispatch(
      cb, slot, kernel_,
      RectifyPush{strip.width, strip.height, strip.words_per_row, raw.width, raw.height, raw.words_per_row, raw.row0},
      groups(strip.words_per_row, 64), static_cast<std::uint32_t>(strip.height), 2);
}

}  // namespace rutd::gpu::vk
