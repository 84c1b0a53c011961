// Path aggregation (shaders/aggregate.comp): workgroup (line, direction, segment), one subgroup walking
// a line, each invocation a block of words of four disparities.
#include <algorithm>

#include "stages.hpp"

namespace rutd::gpu::vk {
namespace {

const std::uint32_t kAggregateSpv[] =
#include "aggregate.comp.inc"
    ;
const std::uint32_t kAggregateHalfSpv[] =
#include "aggregate_half.comp.inc"
    ;

struct AggregatePush {
  std::int32_t width, height, p1, p2, words, segment, run_in;
};

// The shader's specialization constants: the workgroup size, and the words of four disparities of a band
// of `disparities` each invocation owns.
std::vector<std::int32_t> aggregate_spec(int threads, int disparities) {
  const int words = (disparities + 3) / 4;
  return {threads, (words + threads - 1) / threads};
}

}  // namespace

void AggregateStage::create(const KernelFactory& f, int threads, bool half) {
  threads_ = threads;
  const auto bindings = [](const FrameBuffers& b) -> Bindings {
    std::vector<const Buffer*> costs;
    for (const Buffer& c : b.costs) costs.push_back(&c);
    return {{&b.match_cost}, costs};
  };
  kernel_ = half ? f.make(kAggregateHalfSpv, sizeof kAggregateHalfSpv, sizeof(AggregatePush), bindings,
                          aggregate_spec(threads, 128), VK_PIPELINE_CREATE_DISPATCH_BASE_BIT)
                 : f.make(kAggregateSpv, sizeof kAggregateSpv, sizeof(AggregatePush), bindings,
                          aggregate_spec(threads, 128), VK_PIPELINE_CREATE_DISPATCH_BASE_BIT);
}

VkResult AggregateStage::record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band, const SgmConfig& params) {
  VkPipeline pipeline = VK_NULL_HANDLE;
  const VkResult r = variant(kernel_, aggregate_spec(threads_, band.num_disparities), pipeline);
  if (r != VK_SUCCESS) return r;
  const int w = image.width, h = image.height;
  const int lines = params.paths == 2 ? h : params.paths == 4 ? std::max(w, h) : w + h - 1;
  // Workgroups (line, direction, segment): the two horizontal directions (0, 1) have a segment per
  // workgroup z when rows are segmented; the others one, dispatched on their own from direction 2.
  const int segments = params.segment > 0 ? (w + params.segment - 1) / params.segment : 1;
  const AggregatePush push{
      w, h, params.p1, params.p2, cost_words(band.num_disparities), params.segment, params.segment_run_in};
  dispatch(cb, slot, kernel_, pipeline, push, static_cast<std::uint32_t>(h), 2, static_cast<std::uint32_t>(segments));
  if (params.paths > 2)
    vkCmdDispatchBase(cb, 0, 2, 0, static_cast<std::uint32_t>(lines), static_cast<std::uint32_t>(params.paths - 2), 1);
  return VK_SUCCESS;
}

}  // namespace rutd::gpu::vk
