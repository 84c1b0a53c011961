#pragma once
// A camera's protective window and what lies on it (synthetic/scene_conditions.hpp, LensFault), for the
// synthetic renderer. Private to drivers/synthetic.
//
// The window sits a few millimetres in front of the lens, far out of focus: the rays that reach one
// pixel cross it over a disc of radius LensConfig::defocus (normalised image coordinates) around the
// pixel's own direction, and the scene is in focus, so every ray of that disc brings the same scene
// radiance unless something on the window bends it. Per pixel, with A the opacity of what lies on the
// window, S its own radiance (premultiplied by A), D the drops and the mean taken over the disc:
//   L_out = mean((1 - A)(1 - D)) L(n) + mean(D (1 - A) L(n + deflection)) + mean(S)
// then a dust film of haze h: L = (1 - h) L_out + h veil. Opaque mud and translucent snow are A and S;
// a drop is a spherical cap of water that deflects each ray crossing it by Snell's law at its curved
// face (towards its centre, as a converging lens does), or reflects it back inside beyond the critical
// angle (the drop's dark rim); the veil is the light the film scatters into the lens, the mean scene
// radiance with a gradient across the image (brighter on the side of the open sky).
#include <cstdint>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "synthetic/scene_conditions.hpp"

namespace rutd {

class LensWindow {
 public:
  // The window of `camera` with the faults of `config` that concern it; null when none does. centres:
  // the camera's undistorted normalised pixel centres (CV_64FC2, the image's size); focal_px: its focal
  // length. Patterns are drawn from `seed` and the fault's place in the list (LensSide::Both: the same
  // for both cameras).
  static std::shared_ptr<const LensWindow> make(const LensConfig& config, Camera camera, const cv::Mat& centres,
                                                double focal_px, std::uint64_t seed);

  // radiance: the in-focus scene radiance of this camera (CV_64F); out: what reaches the sensor (may not
  // alias radiance). Thread-safe.
  void apply(const cv::Mat& radiance, cv::Mat& out) const;

  // Share of the light of pixel (u, v) that the window lets through undeflected, 0..1.
  double transmission(int u, int v) const { return transmitted_.at<float>(v, u) * (1 - haze_); }

 private:
  LensWindow() = default;
  cv::Mat transmitted_;  // CV_32F per pixel: mean((1 - A)(1 - D)) over its disc
  cv::Mat glow_;         // CV_32F per pixel: mean(S)
  // Drops: on the window grid (one cell per pixel of focal length), the deflection of a ray crossing
  // there (px, x and y) and its weight (1 - A) D; the pixels whose disc crosses a drop, and where each
  // pixel's disc is centred on the grid.
  cv::Mat deflection_;             // CV_32FC3
  std::vector<int> drop_pixels_;   // v * width + u
  cv::Mat grid_position_;          // CV_32FC2 per pixel
  std::vector<cv::Point2f> disc_;  // aperture samples on the grid, cells from the disc's centre
  double haze_ = 0;
  cv::Mat veil_shape_;  // CV_32F per pixel: the veil's relative brightness (mean 1)
};

}  // namespace rutd
