#pragma once
// What `source.aravis` in the configuration says about the two cameras (config/rutd.yaml documents every
// key). Plain data with no Aravis types, so the configuration loader and tests need no camera library.
#include <cstdint>
#include <string>

namespace rutd {

// How the two cameras take the same instant.
enum class CameraSync : std::uint8_t {
  FreeRun,          // each camera runs at `fps`; timestamps share a clock through PTP (GevIEEE1588 or
                    // PtpEnable, whichever the camera has); pairs are found by timestamp
  SoftwareTrigger,  // rutd fires TriggerSoftware on both cameras from one thread at `fps`; pairs by frame id
  HardwareTrigger,  // both cameras wired to one trigger line (`trigger_line`); pairs by frame id
};

// Pixel format asked of the cameras. Bayer images are converted to grey on arrival (the measurement only
// needs intensity); the camera's own Bayer pattern is used (BayerRG8, BayerGR8, BayerBG8 or BayerGB8).
enum class CameraPixelFormat : std::uint8_t { Mono8, Mono16, Bayer8 };

// A sensor rectangle in pixels (before binning). width/height 0: the largest the camera allows.
struct SensorRegion {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;

  bool whole() const noexcept { return width == 0 && height == 0; }
};

struct AravisSourceConfig {
  // Camera selectors: an Aravis device id, a serial number or an IP address (`rutd cameras` lists them).
  std::string left;
  std::string right;
  CameraPixelFormat pixel_format = CameraPixelFormat::Mono8;
  SensorRegion roi;   // the images must then have the calibration's size
  int binning = 1;    // horizontal and vertical, 1..8
  double fps = 30.0;  // free-run rate, or software trigger rate
  CameraSync sync = CameraSync::FreeRun;
  std::string trigger_line = "Line0";  // HardwareTrigger input line

  // Exposure and gain: fixed values, or the camera's auto functions within limits, metering only the
  // region where the terrain is (metering_region; empty: the whole image).
  bool exposure_auto = false;
  double exposure_us = 4000.0;    // fixed exposure
  double exposure_min_us = 50.0;  // auto limits
  double exposure_max_us = 10000.0;
  bool gain_auto = false;
  double gain_db = 0.0;       // fixed gain
  double gain_max_db = 12.0;  // auto limit
  SensorRegion metering_region;

  // Pairing and fault handling.
  double pairing_window_ms = 2.0;   // largest |left - right| timestamp difference of a pair
  double stall_timeout_ms = 120.0;  // a camera with no frame for this long is declared lost; 0: off
  double reconnect_min_ms = 100.0;  // reconnect backoff, doubling from min to max
  double reconnect_max_ms = 1000.0;
  int buffers = 8;  // stream buffers per camera, preallocated and recycled

  // GigE Vision only.
  int packet_size = 0;          // bytes; 0: negotiate the largest the path carries
  int packet_delay_ns = 0;      // inter-packet delay (GevSCPD), 0: none
  int socket_buffer_bytes = 0;  // receive buffer asked of the kernel; 0: four frames
  bool packet_resend = true;
  // Aravis's AF_PACKET receiver (needs CAP_NET_RAW) costs less CPU per packet, but Aravis 0.8 binds it to
  // the interface before attaching its filter: a stream (re)opened while the other camera streams on the
  // same interface can take one of that camera's frame ids as its latest, then discard its own frames as
  // late until their ids pass it (seen: seconds). Off: the UDP socket sees only its own port.
  bool packet_socket = false;
};

}  // namespace rutd
