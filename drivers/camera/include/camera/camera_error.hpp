#pragma once
#include <stdexcept>
#include <string>
#include <utility>

namespace rutd {

// A camera could not be opened or configured. `field` is the configuration key at fault (e.g. "roi",
// "pixel_format"; empty when the camera itself failed); what() says which camera and why.
class CameraError : public std::runtime_error {
 public:
  CameraError(std::string field, const std::string& message) : std::runtime_error(message), field_(std::move(field)) {}
  const std::string& field() const noexcept { return field_; }

 private:
  std::string field_;
};

}  // namespace rutd
