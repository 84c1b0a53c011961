#include "camera/camera_list.hpp"

#include "aravis_camera.hpp"

namespace rutd {

std::vector<std::pair<std::string, std::string>> read_camera_features(const CameraListing& listing,
                                                                      const std::string& label) {
  AravisCamera camera(listing.id, label);
  return camera.feature_values();
}

}  // namespace rutd
