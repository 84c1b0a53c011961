#pragma once
// Asks one GigE Vision camera, by IP address, whether it is on the network: a GVCP DISCOVERY_CMD sent to
// its UDP port 3956, answered by DISCOVERY_ACK. Reconnecting needs this because Aravis offers only two
// slower ways: opening a camera at an address that does not answer waits out its register timeouts
// (about 2.5 s), and a discovery of the whole network always waits its full second. A probe of a few
// tens of milliseconds lets a camera that comes back be seen at once.
//
// Wire format (GigE Vision 2.x, GVCP, big-endian, see Aravis's arvgvcp.h):
//   command  42 11 00 02 00 00 HH LL    key 0x42, flags 0x11 (acknowledge required, broadcast
//                                       acknowledge allowed), DISCOVERY_CMD 0x0002, no payload,
//                                       request id 0xHHLL
//   answer   00 00 00 03 00 f8 HH LL    status 0 (success), DISCOVERY_ACK 0x0003, 248 payload bytes
//            + 248 bytes                 (version, device mode, MAC, IP configuration, vendor, model, ...)
// Example: request id 1 is sent as 42 11 00 02 00 00 00 01; any datagram that starts 00 00 00 03 and
// echoes id 00 01 is the camera's answer.
#include <chrono>
#include <cstdint>
#include <span>
#include <string>

namespace rutd {

// The 8-byte command for `request_id`.
void gvcp_discovery_command(std::uint16_t request_id, std::span<std::uint8_t, 8> out) noexcept;
// True when `datagram` is a successful DISCOVERY_ACK for `request_id`.
bool gvcp_is_discovery_ack(std::span<const std::uint8_t> datagram, std::uint16_t request_id) noexcept;

// True when the camera at `ipv4` ("192.168.1.20") answers within `timeout`. Any failure (bad address,
// no route, no answer) is false. Blocks at most `timeout`; thread-safe (one socket per call).
bool gige_camera_answers(const std::string& ipv4, std::chrono::milliseconds timeout) noexcept;

}  // namespace rutd
