// The frame path: a slot's command buffer recorded from the stages (again only when the frame's
// parameters change), the pair packed into the slot's upload buffer and submitted, and collect() waiting
// for the slot and reading its download buffer.
#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <tuple>
#include <utility>

#include "engine.hpp"

namespace rutd::gpu {

using vk::Buffer;
using vk::Input;
using vk::kTimestamps;

namespace vk {
namespace {

constexpr std::uint32_t kNoMatch = 0xFFFFFFFFu;  // right_key: no disparity

// `rows` rows of `row_bytes` bytes each, from rows `src_stride` bytes apart to rows `dst_stride` bytes apart.
void copy_rows(void* dst, std::size_t dst_stride, const void* src, std::size_t src_stride, std::size_t row_bytes,
               int rows) {
  auto* d = static_cast<std::uint8_t*>(dst);
  const auto* s = static_cast<const std::uint8_t*>(src);
  for (std::size_t y = 0; y < static_cast<std::size_t>(rows); ++y)
    std::memcpy(d + y * dst_stride, s + y * src_stride, row_bytes);
}

}  // namespace

bool Recorded::operator==(const Recorded& o) const {
  const auto tie_sgm = [](const Recorded& r) {
    return std::tie(r.band.min_disparity, r.band.num_disparities, r.params.paths, r.params.p1, r.params.p2,
                    r.params.uniqueness, r.params.lr_max_diff, r.params.median, r.params.segment,
                    r.params.segment_run_in);
  };
  const auto tie_dic = [](const DicKernelConfig& d) {
    return std::tie(d.half_window, d.half_height, d.max_iterations, d.tolerance_px, d.step, d.row_step, d.row_begin,
                    d.row_end, d.first_order, d.max_shift_px, d.max_gradient, d.min_gradient, d.min_zncc,
                    d.max_sigma_px, d.column_windows, d.column_block_rows);
  };
  if (!valid || !o.valid || input != o.input || coarse_scale != o.coarse_scale) return false;
  if (input == Input::RawOnly) return true;
  return dic == o.dic && tie_sgm(*this) == tie_sgm(o) && (!dic || tie_dic(dic_params) == tie_dic(o.dic_params));
}

FixedPoint fixed_point(SgmBand band, const DicKernelConfig* dic, int height) {
  // The matcher's disparities lie within half a px of the band; a DIC window's within max_shift_px of its
  // start, and a column window's rows within its row slope (at most max_gradient) times the block's half
  // height of that.
  double margin = 1.0;
  if (dic) {
    double reach = dic->max_shift_px;
    if (dic->column_windows) reach += dic->max_gradient * ColumnBlocks(*dic, height).half_height();
    margin = std::max(margin, std::ceil(reach) + 1.0);
  }
  // Steps of 1/64 px must span it (DIC limits far beyond the defaults lose the values past that).
  margin = std::min(margin, std::floor((65534.0 / 64 - band.num_disparities) / 2));
  // The finest power of two (at least 64, the matcher's own steps) whose range holds the span: the 16 bits
  // cost the DIC as little as they can.
  const double span = band.num_disparities + 2 * margin;
  int scale = 64;
  while (span * scale * 2 <= 65534) scale *= 2;
  return FixedPoint{band.min_disparity - static_cast<int>(margin), scale};
}

}  // namespace vk

float DisparityView::at(int x, int y) const {
  const std::uint16_t v = data[static_cast<std::size_t>(y) * stride + static_cast<std::size_t>(x)];
  return v == kInvalid ? std::numeric_limits<float>::quiet_NaN() : offset_px + static_cast<float>(v) * step_px;
}

void DisparityView::decode_row(int y, float* out) const {
  // Locals and a bit mask rather than a branch, so that the compiler vectorises the loop: out could alias
  // the members, and a branch keeps it scalar (a 640x480 frame is 0.3 million pixels, on every frame).
  const std::uint16_t* row = data + static_cast<std::size_t>(y) * stride;
  const float offset = offset_px, step = step_px;
  const auto nan = std::bit_cast<std::uint32_t>(std::numeric_limits<float>::quiet_NaN());
  const int n = width;
  for (int x = 0; x < n; ++x) {
    const std::uint16_t v = row[x];
    const auto f = std::bit_cast<std::uint32_t>(offset + static_cast<float>(v) * step);
    const std::uint32_t invalid = 0u - static_cast<std::uint32_t>(v == kInvalid);  // all ones or zero
    out[x] = std::bit_cast<float>((f & ~invalid) | (nan & invalid));
  }
}

namespace {

void stamp(VkCommandBuffer cb, VkQueryPool queries, int slot, std::uint32_t i) {
  if (queries)
    vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries,
                        static_cast<std::uint32_t>(slot) * kTimestamps + i);
}

}  // namespace

VkResult VulkanSgm::Impl::record(int slot, Input input, SgmBand band, const SgmConfig& params,
                                 const DicKernelConfig* dic_params, const CoarseGrid& grid, vk::FixedPoint fixed) {
  const VkCommandBuffer cb = slots[static_cast<std::size_t>(slot)].commands;
  constexpr VkPipelineStageFlags compute = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT;
  constexpr VkPipelineStageFlags transfer = VK_PIPELINE_STAGE_TRANSFER_BIT;
  VkResult r = vkResetCommandBuffer(cb, 0);
  if (r != VK_SUCCESS) return r;
  auto bi = vk::info_struct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  if ((r = vkBeginCommandBuffer(cb, &bi)) != VK_SUCCESS) return r;
  if (queries) vkCmdResetQueryPool(cb, queries, static_cast<std::uint32_t>(slot) * kTimestamps, kTimestamps);
  // No barrier against the other slot's frame: it uses its own buffers. This slot's last frame is
  // complete: submit() waits for its fence before recording again.
  const vk::FrameBuffers& f = slots[static_cast<std::size_t>(slot)].dev;
  stamp(cb, queries, slot, 0);
  const Buffer& up = slots[static_cast<std::size_t>(slot)].upload;
  const Buffer& down = slots[static_cast<std::size_t>(slot)].download;
  const bool is_raw = input != Input::Rectified;
  const VkDeviceSize bytes = is_raw ? raw_bytes : image_bytes;
  VkBufferCopy copy{0, 0, bytes};
  vkCmdCopyBuffer(cb, up.buffer, (is_raw ? f.raw_left : f.image_left).buffer, 1, &copy);
  copy.srcOffset = upload_half;
  vkCmdCopyBuffer(cb, up.buffer, (is_raw ? f.raw_right : f.image_right).buffer, 1, &copy);
  // A segmented winner-takes-all gathers the right view by atomicMin (wta.comp).
  if (wta.segmented()) vkCmdFillBuffer(cb, f.right_key.buffer, 0, VK_WHOLE_SIZE, vk::kNoMatch);
  vk::barrier(cb, transfer, compute);
  stamp(cb, queries, slot, 1);
  const VkDeviceSize strips_at = fixed_bytes();
  if (is_raw) {
    rectify.record(cb, slot, strip_size(), raw);
    vk::barrier(cb, compute, compute | transfer);
    // The strips go back for the host's frame checks, copied while the matcher runs.
    copy = VkBufferCopy{0, strips_at, image_bytes};
    vkCmdCopyBuffer(cb, f.image_left.buffer, down.buffer, 1, &copy);
    copy.dstOffset = strips_at + image_bytes;
    vkCmdCopyBuffer(cb, f.image_right.buffer, down.buffer, 1, &copy);
  }
  // The matcher's size: the strips', or the coarse images' (band estimate), which replace the strips in
  // their buffers once the strips are on their way to the host.
  vk::ImageSize size = strip_size();
  if (input == Input::RawCoarse) {
    size = vk::ImageSize{grid.width, grid.height, (grid.width + 3) / 4};
    this->band.record(cb, slot, strip_size(), grid);
    vk::barrier(cb, compute | transfer, transfer);
    copy =
        VkBufferCopy{0, 0, static_cast<VkDeviceSize>(size.words_per_row) * static_cast<VkDeviceSize>(size.height) * 4};
    vkCmdCopyBuffer(cb, f.census_left.buffer, f.image_left.buffer, 1, &copy);
    vkCmdCopyBuffer(cb, f.census_right.buffer, f.image_right.buffer, 1, &copy);
    vk::barrier(cb, transfer, compute | transfer);
    copy.dstOffset = strips_at + 2 * image_bytes;
    vkCmdCopyBuffer(cb, f.image_left.buffer, down.buffer, 1, &copy);
  }
  stamp(cb, queries, slot, 2);
  if (input == Input::RawOnly) {
    vk::barrier(cb, transfer, VK_PIPELINE_STAGE_HOST_BIT);
    for (std::uint32_t i = 3; i < kTimestamps; ++i) stamp(cb, queries, slot, i);
    return vkEndCommandBuffer(cb);
  }
  census.record(cb, slot, size);
  if (dic_params) dic.record_prefilter(cb, slot, size);
  vk::barrier(cb, compute, compute);
  stamp(cb, queries, slot, 3);
  cost.record(cb, slot, size, band);
  vk::barrier(cb, compute, compute);
  if ((r = aggregate.record(cb, slot, size, band, params)) != VK_SUCCESS) return r;
  vk::barrier(cb, compute, compute);
  stamp(cb, queries, slot, 4);
  if ((r = wta.record(cb, slot, size, band, params)) != VK_SUCCESS) return r;
  vk::barrier(cb, compute, compute);
  stamp(cb, queries, slot, 5);
  // The matcher's disparity: in px for the DIC, else in the downloaded fixed point.
  lr_median.record(cb, slot, size, band, params, dic_params != nullptr, dic_params == nullptr, fixed);
  vk::barrier(cb, compute, compute | transfer);
  stamp(cb, queries, slot, 6);
  if (dic_params) {
    if ((r = dic.record(cb, slot, strip_size(), *dic_params, fixed)) != VK_SUCCESS) return r;
    vk::barrier(cb, compute, transfer);
  }
  stamp(cb, queries, slot, 7);
  copy = VkBufferCopy{0, 0, static_cast<VkDeviceSize>(size.width) * static_cast<VkDeviceSize>(size.height) * 2};
  vkCmdCopyBuffer(cb, f.fixed.buffer, down.buffer, 1, &copy);
  vk::barrier(cb, transfer, VK_PIPELINE_STAGE_HOST_BIT);
  stamp(cb, queries, slot, 8);
  return vkEndCommandBuffer(cb);
}

GpuStatus VulkanSgm::Impl::fail(VkResult r) {
  const GpuStatus s = vk::status_of(r);
  if (s == GpuStatus::DeviceLost) lost = true;
  return s;
}

GpuStatus VulkanSgm::Impl::submit(const ImageView& left, const ImageView& right, Input input, SgmBand band,
                                  const SgmConfig& params, const DicKernelConfig* dic_params, int& ticket,
                                  const CoarseGrid& grid) {
  if (lost) return GpuStatus::DeviceLost;
  const bool is_raw = input != Input::Rectified;
  const int w = is_raw ? raw.width : width, h = is_raw ? raw.height : height;
  if ((is_raw && raw_bytes == 0) || left.width != w || left.height != h || right.width != w || right.height != h ||
      !left.data || !right.data)
    return GpuStatus::InvalidInput;
  const bool coarse = input == Input::RawCoarse;
  if (coarse && (grid.scale < 1 || grid.row_factor < 1 || grid.width < 1 || grid.height < 1 ||
                 grid.width * grid.scale > width || grid.height * grid.row_factor > height || dic_params))
    return GpuStatus::InvalidInput;
  if (input != Input::RawOnly &&
      (band.num_disparities > max_disparities ||
       !check_sgm_input(coarse ? grid.width : width, coarse ? grid.height : height, band, params).empty() ||
       (dic_params && !check_dic_kernel_config(*dic_params).empty())))
    return GpuStatus::InvalidInput;
  ticket = next_slot;
  Slot& slot = slots[static_cast<std::size_t>(ticket)];
  if (slot.busy) return GpuStatus::InvalidInput;  // two frames already in flight
  // Pack both images straight into the mapped upload buffer: words of four pixels, rows padded to whole
  // words; one copy of the rows where the image's rows are already that (a width that is a multiple of 4,
  // contiguous rows).
  auto* words = static_cast<std::uint8_t*>(slot.upload.mapped);
  const std::size_t row_bytes = static_cast<std::size_t>(is_raw ? raw.words_per_row : words_per_row) * 4;
  const int row0 = is_raw ? raw.row0 : 0, rows = is_raw ? raw.rows : h;
  for (int i = 0; i < 2; ++i) {
    const ImageView& im = i == 0 ? left : right;
    std::uint8_t* to = words + static_cast<std::size_t>(i) * upload_half;
    const std::uint8_t* from = im.data + static_cast<std::size_t>(row0) * im.stride;
    if (im.stride == row_bytes && row_bytes == static_cast<std::size_t>(w)) {
      std::memcpy(to, from, row_bytes * static_cast<std::size_t>(rows));
      continue;
    }
    for (int y = 0; y < rows; ++y) {
      std::uint8_t* row = to + static_cast<std::size_t>(y) * row_bytes;
      std::memcpy(row, from + static_cast<std::size_t>(y) * im.stride, static_cast<std::size_t>(w));
      std::memset(row + w, 0, row_bytes - static_cast<std::size_t>(w));
    }
  }
  const vk::FixedPoint fixed = vk::fixed_point(band, dic_params, height);
  vk::Recorded wanted{true,
                      dic_params != nullptr,
                      input,
                      coarse ? grid.scale : 0,
                      band,
                      params,
                      dic_params ? *dic_params : DicKernelConfig{}};
  VkResult r = VK_SUCCESS;
  if (!(slot.recorded == wanted)) {
    slot.recorded = vk::Recorded{};
    r = record(ticket, input, band, params, dic_params, grid, fixed);
    if (r == VK_SUCCESS) slot.recorded = wanted;
  }
  if (r == VK_SUCCESS) r = vkResetFences(device->handle(), 1, &slot.fence);
  if (r == VK_SUCCESS) {
    auto si = vk::info_struct<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
    si.commandBufferCount = 1;
    si.pCommandBuffers = &slot.commands;
    r = device->injected(VulkanCall::QueueSubmit);
    if (r == VK_SUCCESS) r = vkQueueSubmit(device->queue(), 1, &si, slot.fence);
  }
  if (r != VK_SUCCESS) return fail(r);
  slot.busy = true;
  slot.input = input;
  slot.grid = grid;
  slot.fixed = fixed;
  next_slot = (next_slot + 1) % vk::kSlots;
  return GpuStatus::Ok;
}

GpuStatus VulkanSgm::Impl::collect(int ticket, FrameOutput& out, GpuStageTimes* times) {
  out = FrameOutput{};
  if (ticket < 0 || ticket >= vk::kSlots || !slots[static_cast<std::size_t>(ticket)].busy)
    return GpuStatus::InvalidInput;
  Slot& slot = slots[static_cast<std::size_t>(ticket)];
  const VkDevice d = device->handle();
  // Poll for up to a millisecond before sleeping in the driver: a frame takes about that long on a GPU,
  // and a sleeping wait adds its wake-up to every frame's latency.
  VkResult r = device->injected(VulkanCall::WaitForFrame);
  if (r == VK_SUCCESS) r = VK_NOT_READY;
  const auto spin_until = std::chrono::steady_clock::now() + std::chrono::milliseconds(1);
  while (r == VK_NOT_READY && std::chrono::steady_clock::now() < spin_until) r = vkGetFenceStatus(d, slot.fence);
  if (r == VK_NOT_READY) r = vkWaitForFences(d, 1, &slot.fence, VK_TRUE, timeout_ns);
  if (r != VK_SUCCESS) {
    // On a timeout the slot stays busy: its buffers may still be written.
    if (r != VK_TIMEOUT) slot.busy = false;
    return fail(r);
  }
  slot.busy = false;
  // The download buffer (record()): the fixed-point disparity (unpadded rows), then both packed strips,
  // then the packed coarse left image; read where it lies.
  const auto* down = static_cast<const std::uint8_t*>(slot.download.mapped);
  const std::size_t strips_at = fixed_bytes();
  const bool coarse = slot.input == Input::RawCoarse;
  if (slot.input != Input::RawOnly) {
    DisparityView& v = out.disparity;
    v.data = reinterpret_cast<const std::uint16_t*>(down);
    v.width = coarse ? slot.grid.width : width;
    v.height = coarse ? slot.grid.height : height;
    v.stride = static_cast<std::size_t>(v.width);
    v.offset_px = static_cast<float>(slot.fixed.base);
    v.step_px = 1.0f / static_cast<float>(slot.fixed.scale);
  }
  if (slot.input != Input::Rectified) {
    out.strip_left = down + strips_at;
    out.strip_right = down + strips_at + image_bytes;
    out.strip_stride = static_cast<std::size_t>(words_per_row) * 4;
  }
  if (coarse) {
    out.coarse_left = down + strips_at + 2 * image_bytes;
    out.coarse_stride = static_cast<std::size_t>((slot.grid.width + 3) / 4) * 4;
  }
  if (times) {
    *times = GpuStageTimes{};
    std::array<std::uint64_t, kTimestamps> t{};
    if (queries &&
        vkGetQueryPoolResults(d, queries, static_cast<std::uint32_t>(ticket) * kTimestamps, kTimestamps, sizeof t,
                              t.data(), sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT) == VK_SUCCESS) {
      const auto ms = [&](int a, int b) {
        return static_cast<double>(t[static_cast<std::size_t>(b)] - t[static_cast<std::size_t>(a)]) *
               device->timestamp_ns() * 1e-6;
      };
      *times = GpuStageTimes{ms(0, 1), ms(1, 2), ms(2, 3), ms(3, 4), ms(4, 5), ms(5, 6), ms(6, 7), ms(7, 8)};
    }
  }
  return GpuStatus::Ok;
}

GpuStatus VulkanSgm::collect(int ticket, FrameOutput& out, GpuStageTimes* times) {
  return impl_->collect(ticket, out, times);
}

GpuStatus VulkanSgm::collect(int ticket, float* disparity, std::size_t stride, GpuStageTimes* times,
                             const StripsOut* strips) {
  FrameOutput out;
  const GpuStatus s = impl_->collect(ticket, out, times);
  if (s != GpuStatus::Ok) return s;
  // A request the frame cannot answer: checked after the wait, so the slot is free again either way.
  if ((strips && !out.strip_left) || (!disparity && out.disparity.data)) return GpuStatus::InvalidInput;
  if (disparity && out.disparity.data)
    for (int y = 0; y < out.disparity.height; ++y)
      out.disparity.decode_row(y, disparity + static_cast<std::size_t>(y) * stride);
  if (strips && strips->coarse_left && out.coarse_left)
    vk::copy_rows(strips->coarse_left, strips->coarse_stride, out.coarse_left, out.coarse_stride,
                  static_cast<std::size_t>(out.disparity.width), out.disparity.height);
  if (strips) {
    for (auto [dst, src] : {std::pair{strips->left, out.strip_left}, std::pair{strips->right, out.strip_right}})
      if (dst)
        vk::copy_rows(dst, strips->stride, src, out.strip_stride, static_cast<std::size_t>(impl_->width),
                      impl_->height);
  }
  return GpuStatus::Ok;
}

GpuStatus VulkanSgm::Impl::read_stages(int ticket, SgmBand band, const SgmConfig& params, bool dic_on, SgmStages& st) {
  const vk::Device& dev = *device;
  const auto pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  const vk::FrameBuffers& f = slots[static_cast<std::size_t>(ticket)].dev;
  if (dic_on) {
    st.spline_left.resize(pixels);
    st.spline_right.resize(pixels);
    for (auto [buffer, dst] :
         {std::pair{&f.spline_left, st.spline_left.data()}, std::pair{&f.spline_right, st.spline_right.data()},
          std::pair{&f.disparity, st.disparity.data()}}) {
      const VkResult r = vk::read_back(dev, pool, *buffer, dst, pixels * 4);
      if (r != VK_SUCCESS) return fail(r);
    }
  }
  st.census_left.resize(pixels * 2);
  st.census_right.resize(pixels * 2);
  st.disparity_left.resize(pixels);
  const auto nd = static_cast<std::size_t>(band.num_disparities);
  const auto words = static_cast<std::size_t>(vk::cost_words(band.num_disparities));
  std::vector<std::uint8_t> costs(pixels * words * 4 * static_cast<std::size_t>(params.paths));
  std::vector<std::uint32_t> keys(pixels);
  for (std::size_t dir = 0; dir < static_cast<std::size_t>(params.paths); ++dir) {
    const VkResult r =
        vk::read_back(dev, pool, f.costs[dir], costs.data() + dir * pixels * words * 4, pixels * words * 4);
    if (r != VK_SUCCESS) return fail(r);
  }
  for (auto [buffer, dst, bytes] : {std::tuple{&f.census_left, static_cast<void*>(st.census_left.data()), pixels * 8},
                                    std::tuple{&f.census_right, static_cast<void*>(st.census_right.data()), pixels * 8},
                                    std::tuple{&f.disp_left, static_cast<void*>(st.disparity_left.data()), pixels * 4},
                                    std::tuple{&f.right_key, static_cast<void*>(keys.data()), pixels * 4}}) {
    const VkResult r = vk::read_back(dev, pool, *buffer, dst, bytes);
    if (r != VK_SUCCESS) return fail(r);
  }
  // The sums the reference keeps: every direction's byte costs added (as wta.comp does in shared memory).
  st.sums.assign(pixels * nd, 0);
  for (std::size_t dir = 0; dir < static_cast<std::size_t>(params.paths); ++dir)
    for (std::size_t p = 0; p < pixels; ++p)
      for (std::size_t d = 0; d < nd; ++d) st.sums[p * nd + d] += costs[(dir * pixels + p) * words * 4 + d];
  st.disparity_right.resize(pixels);
  for (std::size_t p = 0; p < pixels; ++p)
    st.disparity_right[p] = keys[p] == vk::kNoMatch ? -1 : band.min_disparity + static_cast<int>(keys[p] & 511u);
  return GpuStatus::Ok;
}

}  // namespace rutd::gpu
