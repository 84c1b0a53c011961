// Path aggregation (shaders/aggregate.comp): workgroup (lines, direction, segment), one subgroup walking
// one line or several, each invocation a block of words of four disparities.
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
const std::uint32_t kAggregateLinesSpv[] =
#include "aggregate_lines.comp.inc"
    ;
const std::uint32_t kAggregateLinesHalfSpv[] =
#include "aggregate_lines_half.comp.inc"
    ;

struct AggregatePush {
  std::int32_t width, height, p1, p2, words, segment, run_in;
};

// The shader's specialization constants: the workgroup size, the words of four disparities of a band of
// `disparities` each invocation owns, and the invocations of a line.
std::vector<std::int32_t> aggregate_spec(int threads, int lanes, int disparities) {
  const int words = (disparities + 3) / 4;
  return {threads, (words + lanes - 1) / lanes, lanes};
}

}  // namespace

void AggregateStage::create(const KernelFactory& f, int threads, int lanes, bool half) {
  threads_ = threads;
  lanes_ = lanes;
  const auto bindings = [](const FrameBuffers& b) -> Bindings {
    std::vector<const Buffer*> costs;
    for (const Buffer& c : b.costs) costs.push_back(&c);
    return {{&b.match_cost}, costs};
  };
  // The one-line walk (lanes == threads) and the several-lines walk are separate builds (aggregate.comp).
  const bool lines = lanes < threads;
  const std::uint32_t* spv =
      lines ? (half ? kAggregateLinesHalfSpv : kAggregateLinesSpv) : (half ? kAggregateHalfSpv : kAggregateSpv);
  const std::size_t bytes = lines ? (half ? sizeof kAggregateLinesHalfSpv : sizeof kAggregateLinesSpv)
                                  : (half ? sizeof kAggregateHalfSpv : sizeof kAggregateSpv);
  kernel_ = f.make(spv, bytes, sizeof(AggregatePush), bindings, aggregate_spec(threads, lanes, 128),
                   VK_PIPELINE_CREATE_DISPATCH_BASE_BIT);
}

VkResult AggregateStage::record(VkCommandBuffer cb, int slot, ImageSize image, SgmBand band, const SgmConfig& params) {
  VkPipeline pipeline = VK_NULL_HANDLE;
  const VkResult r = variant(kernel_, aggregate_spec(threads_, lanes_, band.num_disparities), pipeline);
  if (r != VK_SUCCESS) return r;
  const int w = image.width, h = image.height;
  const int lines = params.paths == 2 ? h : params.paths == 4 ? std::max(w, h) : w + h - 1;
  // Workgroups (line, direction, segment): the two horizontal directions (0, 1) have a segment per
  // workgroup z when rows are segmented; the others one, dispatched on their own from direction 2.
  const int segments = params.segment > 0 ? (w + params.segment - 1) / params.segment : 1;
  const AggregatePush push{
      w, h, params.p1, params.p2, cost_words(band.num_disparities), params.segment, params.segment_run_in};
  const int per_group = threads_ / lanes_;  // lines a workgroup walks
  dispatch(cb, slot, kernel_, pipeline, push, groups(h, per_group), 2, static_cast<std::uint32_t>(segments));
  if (params.paths > 2)
    vkCmdDispatchBase(cb, 0, 2, 0, groups(lines, per_group), static_cast<std::uint32_t>(params.paths - 2), 1);
  return VK_SUCCESS;
}

}  // namespace rutd::gpu::vk
