// Path aggregation (shaders/aggregate.comp): workgroup (line, direction, segment), one subgroup walking
// a line, each invocation a block of words of four disparities.
#include <algorithm>

#include "stages.hpp"

namespace rutd::gpu::vk {
namespace {

const std::uint32_t kAggregateSpv[] =
#include "aggregate.comp.inc"
    ;

struct AggregatePush {
  std::int32_t width, height, num_disparities, p1, p2, words, segment, run_in;
};

}  // namespace

void AggregateStage::create(const KernelFactory& f, int threads, int max_disparities) {
  // Each invocation a block of words of four disparities, enough for max_disparities.
  threads_ = threads;
  words_each_ = (cost_words(max_disparities) + threads - 1) / threads;
  kernel_ = f.make(
      kAggregateSpv, sizeof kAggregateSpv, sizeof(AggregatePush),
      [](const FrameBuffers& b) -> Bindings {
        std::vector<const Buffer*> costs;
        for (const Buffer& c : b.costs) costs.push_back(&c);
        return {{&b.match_cost}, costs};
      },
      {threads_, words_each_}, VK_PIPELINE_CREATE_DISPATCH_BASE_BIT);
}

void AggregateStage::resize(const Device& device, const KernelFactory& f, int max_disparities) {
  if ((cost_words(max_disparities) + threads_ - 1) / threads_ == words_each_) {
    f.rebind(kernel_);
    return;
  }
  destroy(device);
  create(f, threads_, max_disparities);
}

void AggregateStage::record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band,
                            const SgmConfig& params) const {
  const int w = image.width, h = image.height;
  const int lines = params.paths == 2 ? h : params.paths == 4 ? std::max(w, h) : w + h - 1;
  // Workgroups (line, direction, segment): the two horizontal directions (0, 1) have a segment per
  // workgroup z when rows are segmented; the others one, dispatched on their own from direction 2.
  const int segments = params.segment > 0 ? (w + params.segment - 1) / params.segment : 1;
  const AggregatePush push{w,
                           h,
                           band.num_disparities,
                           params.p1,
                           params.p2,
                           cost_words(band.num_disparities),
                           params.segment,
                           params.segment_run_in};
  dispatch(cb, slot, kernel_, push, static_cast<std::uint32_t>(h), 2, static_cast<std::uint32_t>(segments));
  if (params.paths > 2)
    vkCmdDispatchBase(cb, 0, 2, 0, static_cast<std::uint32_t>(lines), static_cast<std::uint32_t>(params.paths - 2), 1);
}

}  // namespace rutd::gpu::vk
