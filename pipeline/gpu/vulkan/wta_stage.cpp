// Winner-takes-all (shaders/wta.comp): workgroup (segment, row), a row walker of `threads` invocations, a
// pipeline per disparity count and number of directions (specialization constants); whole rows, or
// segments that gather the right view by atomicMin (the wta_segmented build).
#include "stages.hpp"

namespace rutd::gpu::vk {
namespace {

const std::uint32_t kWtaSpv[] =
#include "wta.comp.inc"
    ;
const std::uint32_t kWtaSegmentedSpv[] =
#include "wta_segmented.comp.inc"
    ;

// words: words of four byte costs per pixel (cost_words()); segment: px per workgroup, 0 whole rows.
struct WtaPush {
  std::int32_t width, height, min_disparity, uniqueness, words, segment;
};

// The shader's specialization constants for a band of `disparities` and `paths` directions.
std::vector<std::int32_t> wta_spec(int threads, int disparities, int paths) {
  const int words = (disparities + 3) / 4;
  return {threads, (words + threads - 1) / threads, disparities, paths};
}

}  // namespace

void WtaStage::create(const KernelFactory& f, int threads, int segment) {
  threads_ = threads;
  segment_ = segment;
  // Whole rows and segmented rows are separate builds (wta.comp).
  kernel_ = f.make(
      segment > 0 ? kWtaSegmentedSpv : kWtaSpv, segment > 0 ? sizeof kWtaSegmentedSpv : sizeof kWtaSpv, sizeof(WtaPush),
      [](const FrameBuffers& b) -> Bindings {
        std::vector<const Buffer*> costs;
        for (const Buffer& c : b.costs) costs.push_back(&c);
        return {costs, {&b.disp_left}, {&b.right_key}};
      },
      wta_spec(threads, 128, 8));
}

VkResult WtaStage::record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band, const SgmConfig& params) {
  VkPipeline pipeline = VK_NULL_HANDLE;
  const VkResult r = variant(kernel_, wta_spec(threads_, band.num_disparities, params.paths), pipeline);
  if (r != VK_SUCCESS) return r;
  const int segments = segment_ > 0 ? (image.width + segment_ - 1) / segment_ : 1;
  dispatch(cb, slot, kernel_, pipeline,
           WtaPush{image.width, image.height, band.min_disparity, params.uniqueness, cost_words(band.num_disparities),
                   segment_},
           static_cast<std::uint32_t>(segments), static_cast<std::uint32_t>(image.height), 1);
  return VK_SUCCESS;
}

}  // namespace rutd::gpu::vk
