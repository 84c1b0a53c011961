#pragma once
// The live view's pictures: the raw camera images with the measured strip, the rut edges and the deepest
// point drawn where they lie in each camera (through its rectification and lens distortion), and the
// rectified strips with the same marks. View thread; allocates (it is off the measurement's path).
#include <string>

#include "web/web_frame.hpp"
#include "web/web_view.hpp"

namespace rutd {

// Widest picture sent to the page, pixels; larger camera images are scaled down.
inline constexpr int kWebImageMaxWidth = 640;

// Raw pixel (column, row) of a rectified pixel of the left (left = true) or right camera.
cv::Point2d raw_from_rectified(const WebContext& context, bool left, cv::Point2d rectified);

// JPEG of one camera's raw image (8-bit, scaled to `top`) with the marks; "" when the pair has no images.
std::string camera_jpeg(const WebContext& context, const WebFrame& frame, bool left, int top);

// PNG of the rectified strips, left above right, the measured rows and the rut marked; "" when the pair
// was not measured.
std::string strip_png(const WebContext& context, const WebFrame& frame);

}  // namespace rutd
