// libFuzzer target: the CAN input rutd decodes, i.e. what SocketCanBus::poll_errors reads from its
// socket: raw struct can_frame records (error frames and anything else the kernel hands over), run
// through classify_error_frame and CanBusState, and from_kernel_frame. The input is a sequence of
// 16-byte kernel frames. Checked against the contracts in can/socketcan_bus.hpp: only CAN_ERR_FLAG
// frames are events, every event counts, bus-off follows the last bus-off or restart event, and
// from_kernel_frame accepts only classic data frames whose fields survive to_kernel_frame.
#include <linux/can.h>
#include <linux/can/error.h>

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "can/socketcan_bus.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  rutd::CanBusState state;
  std::uint64_t error_frames = 0, bus_offs = 0;
  bool bus_off = false;
  for (std::size_t at = 0; at + sizeof(can_frame) <= size; at += sizeof(can_frame)) {
    can_frame frame;
    std::memcpy(&frame, data + at, sizeof frame);
    const auto event = rutd::classify_error_frame(frame);
    if (event.has_value() != ((frame.can_id & CAN_ERR_FLAG) != 0)) rutd::fuzz::fail("error flag misread", "");
    if (event) {
      state.on_error_frame(*event);
      ++error_frames;
      if (event->bus_off != ((frame.can_id & CAN_ERR_BUSOFF) != 0)) rutd::fuzz::fail("bus-off bit misread", "");
      if (event->bus_off) {
        ++bus_offs;
        bus_off = true;
      } else if (event->restarted) {
        bus_off = false;
      }
    }
    if (state.stats().error_frames != error_frames || state.stats().bus_off_events != bus_offs ||
        state.bus_off() != bus_off) {
      rutd::fuzz::fail("bus state differs from the error frames seen", "");
    }
    const auto decoded = rutd::from_kernel_frame(frame);
    if (decoded) {
      if ((frame.can_id & (CAN_ERR_FLAG | CAN_RTR_FLAG)) != 0 || frame.len > 8 || decoded->len != frame.len)
        rutd::fuzz::fail("decoded a frame rutd never sends", "");
      // Identifier bits beyond the frame's width are not part of it (the kernel never sets them).
      const canid_t id = frame.can_id & ((frame.can_id & CAN_EFF_FLAG) ? CAN_EFF_FLAG | CAN_EFF_MASK : CAN_SFF_MASK);
      const can_frame back = rutd::to_kernel_frame(*decoded);
      if (back.can_id != id || back.len != frame.len || std::memcmp(back.data, frame.data, frame.len) != 0)
        rutd::fuzz::fail("a decoded frame does not encode back to itself", "");
    }
  }
  return 0;
}
