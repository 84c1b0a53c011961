// The band estimate's coarse pass on the device (shaders/downsample.comp): the rectified strips averaged
// over blocks of columns and rows into the census buffers, which serve as scratch; frame.cpp copies them
// over the strips and matches them there.
#include "stages.hpp"

namespace rutd::gpu::vk {
namespace {

const std::uint32_t kDownsampleSpv[] =
#include "downsample.comp.inc"
    ;

struct DownsamplePush {
  std::int32_t width, height, words_per_row, coarse_width, coarse_height, coarse_words_per_row, scale, row_factor;
};

}  // namespace

void BandStage::create(const KernelFactory& f) {
  kernel_ =
      f.make(kDownsampleSpv, sizeof kDownsampleSpv, sizeof(DownsamplePush), [](const FrameBuffers& b) -> Bindings {
        return {{&b.image_left}, {&b.image_right}, {&b.census_left}, {&b.census_right}};
      });
}

void BandStage::record(VkCommandBuffer cb, int slot, ImageSize strip, const CoarseGrid& grid) const {
  const int wpr = (grid.width + 3) / 4;
  dispatch(cb, slot, kernel_,
           DownsamplePush{strip.width, strip.height, strip.words_per_row, grid.width, grid.height, wpr, grid.scale,
                          grid.row_factor},
           groups(wpr, 64), static_cast<std::uint32_t>(grid.height), 2);
}

}  // namespace rutd::gpu::vk
