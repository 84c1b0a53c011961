#pragma once
// Camera discovery and inspection for people wiring a bench (`rutd cameras`). Not for the per-frame path:
// every call blocks on the network or the USB bus.
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace rutd {

// What discovery says of one camera (`rutd cameras`).
struct CameraListing {
  std::string id;        // Aravis device id, what AravisCamera opens
  std::string protocol;  // GigEVision, USB3Vision
  std::string vendor;
  std::string model;
  std::string serial;
  std::string address;  // IP address (GigE) or bus path (USB)
  std::string physical_id;
};

// Discovers every camera on every interface. Blocks about a second (GigE discovery waits for replies).
// Not thread-safe with other Aravis discovery or open calls.
std::vector<CameraListing> list_cameras();

// The listing a selector (device id, serial number, IP address or physical id) names; nullopt if none.
std::optional<CameraListing> find_camera(const std::vector<CameraListing>& cameras, const std::string& selector);

// Opens the camera `listing` names (labelled `label` in messages) and returns the name and current
// value of every feature rutd sets. Takes control of the camera for the moment of the call. Throws
// CameraError when it cannot be opened.
std::vector<std::pair<std::string, std::string>> read_camera_features(const CameraListing& listing,
                                                                      const std::string& label);

}  // namespace rutd
