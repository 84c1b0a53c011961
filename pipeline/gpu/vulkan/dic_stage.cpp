// Sub-pixel refinement on the device: the B-spline prefilter of both images (shaders/bspline.comp, one
// invocation per pixel) and the DIC (shaders/dic.comp, one subgroup per window), per pixel or with column
// windows (specialization constant 0).
#include <algorithm>

#include "stages.hpp"

namespace rutd::gpu::vk {
namespace {

const std::uint32_t kBsplineSpv[] =
#include "bspline.comp.inc"
    ;
const std::uint32_t kDicSpv[] =
#include "dic.comp.inc"
    ;

struct BsplinePush {
  std::int32_t width, height, words_per_row;
};

struct DicPush {
  std::int32_t width, height, words_per_row, h, hh, max_iterations, step, row_step, first_row, last_row, first_order;
  float tolerance, max_shift, max_gradient, min_gradient, min_zncc, max_sigma;
  std::int32_t rows, blocks;  // column windows
  std::int32_t base, scale;   // the output's fixed point
};

}  // namespace

void DicStage::create(const KernelFactory& f, std::uint32_t subgroup_size, int window_subgroups) {
  subgroup_size_ = std::max<std::uint32_t>(subgroup_size, 1);
  window_subgroups_ = window_subgroups;
  bspline_ = f.make(kBsplineSpv, sizeof kBsplineSpv, sizeof(BsplinePush), [](const FrameBuffers& b) -> Bindings {
    return {{&b.image_left}, {&b.image_right}, {&b.spline_left}, {&b.spline_right}};
  });
  const auto dic_bindings = [](const FrameBuffers& b) -> Bindings {
    return {{&b.image_left}, {&b.spline_left}, {&b.spline_right}, {&b.disparity}, {&b.fixed}};
  };
  // Specialization: column windows, subgroups a window, workgroup size (dic.comp).
  pixels_ = f.make(kDicSpv, sizeof kDicSpv, sizeof(DicPush), dic_bindings, {0, 1, 64});
  columns_ = f.make(kDicSpv, sizeof kDicSpv, sizeof(DicPush), dic_bindings, {1, 1, 64});
}

void DicStage::rebind(const KernelFactory& f) const {
  for (const Kernel* k : {&bspline_, &pixels_, &columns_}) f.rebind(*k);
}

void DicStage::destroy(const Device& device) {
  for (Kernel* k : {&bspline_, &pixels_, &columns_}) vk::destroy(device, *k);
}

void DicStage::record_prefilter(VkCommandBuffer cb, int slot, ImageSize image) const {
  dispatch(cb, slot, bspline_, BsplinePush{image.width, image.height, image.words_per_row}, groups(image.width, 64),
           static_cast<std::uint32_t>(image.height), 2);
}

int DicStage::subgroups_per_window(const DicKernelConfig& d, int height) const {
  if (!d.column_windows || subgroup_size_ < 4) return 1;
  if (window_subgroups_ > 0) return window_subgroups_;
  // Auto: the subgroups of 128 invocations where a block has 32 rows or more (a strip's windows of its
  // whole height: 11 x 48 px on the daemon's strip, few of them), else one (16-row blocks of a frame: a
  // window of 176 px is 6 a lane of 32, and the frame has windows enough to fill the device).
  const ColumnBlocks blocks(d, height);
  const bool tall = blocks.count > 0 && blocks.rows / blocks.count >= 32;
  return tall ? std::max(1, 128 / static_cast<int>(subgroup_size_)) : 1;
}

VkResult DicStage::record(VkCommandBuffer cb, int slot, ImageSize image, const DicKernelConfig& d, FixedPoint fixed) {
  // One subgroup per window (dic.comp), at most 64 / subgroup_size of them per workgroup; a subgroup
  // smaller than the reported size only means fewer workgroups would have done.
  const int per_group = std::max(1, 64 / static_cast<int>(subgroup_size_));
  const int width = image.width, height = image.height;
  DicPush push{};
  push.width = width;
  push.height = height;
  push.words_per_row = image.words_per_row;
  push.h = d.half_window;
  push.hh = d.half_height;
  push.max_iterations = d.max_iterations;
  push.step = d.step;
  push.row_step = d.row_step;
  push.first_order = d.first_order ? 1 : 0;
  push.tolerance = d.tolerance_px;
  push.max_shift = d.max_shift_px;
  push.max_gradient = d.max_gradient;
  push.min_gradient = d.min_gradient;
  push.min_zncc = d.min_zncc;
  push.max_sigma = d.max_sigma_px;
  push.base = fixed.base;
  push.scale = fixed.scale;
  // Every pixel is written: refined, or invalid (dic.comp).
  if (d.column_windows) {
    // Every column of every row block (workgroup y); one workgroup row where there is no block.
    const ColumnBlocks blocks(d, height);
    push.hh = blocks.half_height();
    push.first_row = blocks.row_begin;
    push.rows = blocks.rows;
    push.blocks = blocks.count;
    const int k = subgroups_per_window(d, height);
    VkPipeline pipeline = VK_NULL_HANDLE;
    const int size = k == 1 ? 64 : k * static_cast<int>(subgroup_size_);
    const VkResult r = variant(columns_, {1, k, size}, pipeline);
    if (r != VK_SUCCESS) return r;
    dispatch(cb, slot, columns_, pipeline, push, k == 1 ? groups(width, per_group) : static_cast<std::uint32_t>(width),
             static_cast<std::uint32_t>(std::max(blocks.count, 1)), 1);
  } else {
    // The grid: columns x % step == 0, rows y % row_step == 0 in [row_begin, row_end); workgroup y a row.
    const int begin = std::max(d.row_begin, 0);
    push.first_row = (begin + d.row_step - 1) / d.row_step * d.row_step;
    push.last_row = std::min(d.row_end, height);
    dispatch(cb, slot, pixels_, push, groups(width, per_group), static_cast<std::uint32_t>(height), 1);
  }
  return VK_SUCCESS;
}

}  // namespace rutd::gpu::vk
