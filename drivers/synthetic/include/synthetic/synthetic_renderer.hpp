#pragma once
// The synthetic stereo renderer: the rutd test bench in software, and the ground-truth generator for
// every accuracy test. A calibrated stereo rig with lens distortion and a misaligned right camera looks
// down at the terrain of synthetic/synthetic_scene.hpp while the vehicle moves along +y.
//
// Rig (world frame of synthetic_scene.hpp): midpoint at (0, y_vehicle, height_mm), left camera at
// -baseline/2 and right camera at +baseline/2 along the rig's x axis. The rig is pitched by pitch_deg
// about world +x (positive: the view tilts forwards, towards +y), then rolled by roll_deg about world +y
// (positive: the right camera goes down). Left camera frame at zero roll and pitch: X = world +x,
// Y = world -y, Z = world -z (looking straight down). The right camera has the left camera's
// orientation followed by a small misalignment rotation, and slightly different intrinsics. The
// calibration follows DESIGN.md: X_right = R X_left + T, T in millimetres.
//
// Rendering a raw pixel: its centre is undistorted once, at construction, to a ray; the ray of each of
// the supersample x supersample sub-pixel samples is the centre ray moved by the inverse distortion
// Jacobian (error < 1e-3 px); by default one sample per pixel, n x n at silhouettes (see SyntheticRendererConfig).
// Each sample ray is intersected exactly with the height field (first hit, so a pile may occlude the
// wall behind it; < 1e-5 mm; see cast_ray).  The solid texture is evaluated at the hit point, band-limited to
// the sample spacing there (ray differentials on the tangent plane), and shaded (Lambert, fixed sun +
// ambient). A ray that meets standing water first is shaded by the water's optics (reflection, a
// refracted ray cast to the bottom, attenuation; synthetic/scene_conditions.hpp). The box-filtered
// radiance of the whole image then passes the camera's protective window (faults on it, out of focus)
// and the sensor model (exposure and gain, auto or set; shot and read noise from an RNG seeded by seed,
// frame index, camera and row).
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "core/stereo_calibration.hpp"
#include "core/stereo_frame.hpp"
#include "synthetic/scene_conditions.hpp"
#include "synthetic/synthetic_scene.hpp"

namespace rutd {

struct RigConfig {
  double baseline_mm = 60;        // > 0
  double height_mm = 350;         // rig midpoint above undisturbed ground, > highest terrain + 10 mm
  double roll_deg = 0;            // about world +y (travel); |roll| < 45
  double pitch_deg = 0;           // about world +x; |pitch| < 45
  double hfov_deg = 75;           // pinhole horizontal field of view: fx = (width/2) / tan(hfov/2); 5..150
  cv::Size image_size{640, 480};  // any size >= 16 x 16
  // OpenCV distortion (k1, k2, p1, p2, k3); must stay monotonic over the image.
  cv::Vec<double, 5> distortion_left{-0.05, 0.01, 0.0005, -0.0003, 0.0};
  cv::Vec<double, 5> distortion_right{-0.045, 0.008, -0.0004, 0.0002, 0.0};
  // Principal point offset from the image centre ((width - 1)/2, (height - 1)/2), pixels.
  cv::Point2d principal_offset_left{2.5, -1.5};
  cv::Point2d principal_offset_right{-3.0, 2.0};
  double focal_scale_right = 1.006;  // right focal length / left focal length, > 0
  // Right camera misalignment, applied in its own frame as Rz(roll) Ry(yaw) Rx(pitch); degrees.
  // Pitch moves rows, so an unrectified pair does not line up.
  double misalign_yaw_deg = 0.4;
  double misalign_pitch_deg = 0.3;
  double misalign_roll_deg = 0.2;
};

class WaterOptics;  // private to drivers/synthetic
class LensWindow;

// Auto exposure as a machine-vision camera does it: the median grey level of the left image is held at
// target (fraction of full scale) by the exposure first, up to max_exposure (the longest the vehicle's
// motion allows), then by the analog gain up to max_gain; beyond that the image darkens. The right
// camera takes the left's settings (one camera meters for the pair, as synchronised rigs do). The
// median is metered on the frame itself, noise-free: a loop that has settled.
struct AutoExposureConfig {
  bool enabled = false;
  double target = 0.4;      // (0, 1)
  double max_exposure = 2;  // > 0, in the units of SyntheticRendererConfig::exposure
  double max_gain = 16;     // >= 1 (24 dB)
};

// The exposure and gain a rendered pair was taken with.
struct CameraSettings {
  double exposure = 1;
  double gain = 1;
};

struct SyntheticRendererConfig {
  RigConfig rig;
  RutShape rut;
  Texture texture = Texture::Sand;
  double fps = 30;             // > 0; frame i is taken at t = i / fps
  double speed_mm_s = 1000;    // vehicle speed along +y; y_vehicle = i * speed / fps
  double noise_sigma = 1.5;    // read noise, grey levels of the 8-bit scale; 0 = none
  double full_well_e = 20000;  // electrons at full scale, sets the shot noise; 0 = no shot noise
  double exposure = 1.0;       // radiance 1 (white, facing the sun) maps to exposure * 255 grey levels
                               // at gain 1 (under 1/8: a dark scene; several: saturated)
  // Sensor: a pixel's grey level is gain * (signal + noise), signal = 255 * exposure * light * radiance
  // (times right_response for the right camera), noise of variance noise_sigma^2 (read) + signal * 255 /
  // full_well_e (shot): gain amplifies both, so the same grey level reached by gain instead of light
  // is noisier.
  double gain = 1.0;   // >= 1, analog gain (ignored when auto_exposure is on)
  double light = 1.0;  // > 0: the scene's illuminance relative to daylight (dusk 0.05, night far less)
  AutoExposureConfig auto_exposure;
  // Right camera's response relative to the left's (quantum efficiency, lens transmission, vignetting):
  // real pairs differ by a few percent; 1.04: the right image 4 % brighter.
  double right_response = 1.0;
  // Free-running cameras: the right exposure starts this long after the left's (negative: before), so
  // at speed the ground has moved between the two; 0 = triggered together. |delay| < 1 / fps.
  double right_delay_ms = 0;
  std::uint64_t seed = 1;      // texture and noise; same seed and frame index = same images
  DepthProfile depth_profile;  // (frame, depth_mm) knots; empty = rut.depth_mm for every frame
  // Samples per pixel side, 1..8 (box filter). Each sample sees the texture band-limited to the sample
  // spacing on the surface (band_limit), so one sample per pixel is already anti-aliased, better than
  // 3 x 3 point samples; only silhouettes need more (edge_supersample).
  int supersample = 1;
  // With supersample 1: pixels that straddle a silhouette (a jump in hit distance against their row
  // neighbours, e.g. a pile's crest in front of the wall behind it) get edge_supersample^2 samples.
  // 1..8; 1 = off.
  int edge_supersample = 3;
  // false: point samples of the full texture (aliases unless supersample is large; for comparisons).
  bool band_limit = true;
  int bit_depth = 8;  // 8 (CV_8UC1) or 16 (CV_16UC1, full scale 65535)
  SceneConditions conditions;
};

// Throws std::invalid_argument naming the field for impossible parameters: what SyntheticRenderer's
// constructor checks, without building anything.
void validate(const SyntheticRendererConfig& params);

// Immutable after construction; all const members are thread-safe. render() allocates only when the
// frame's buffers, or its calling thread's scratch images, do not already have the right size and type.
class SyntheticRenderer {
 public:
  // Throws std::invalid_argument naming the field for impossible parameters.
  explicit SyntheticRenderer(const SyntheticRendererConfig& params);

  const SyntheticRendererConfig& params() const noexcept { return params_; }
  const StereoCalibration& calibration() const noexcept { return calibration_; }
  // Rotation from the raw left camera frame to the frame RutTruth is expressed in: the left rectified
  // camera frame of cv::stereoRectify(calibration) (its R1, which depends only on R and T).
  const cv::Matx33d& truth_rotation() const noexcept { return truth_rotation_; }

  RutTruth truth(std::uint64_t index) const;
  // Fills out.left/out.right (reusing their buffers), seq = index, t_ns = round(index * 1e9 / fps) (the
  // left exposure's time), clock = Monotonic. Returns the exposure and gain used (auto exposure's, or
  // the configured ones). Keeps per-thread scratch of two floating-point images between calls.
  CameraSettings render(std::uint64_t index, StereoFrame& out) const;
  // Pairs 0 .. count-1, as render() gives them: the short cycle a CyclingSource plays.
  std::vector<StereoFrame> render_pairs(std::size_t count) const;

  // Exact first intersection of the ray from the left camera centre along `dir` (left camera frame,
  // any length) with frame `index`'s terrain: the hit point in the left camera frame, mm, or nullopt.
  std::optional<cv::Vec3d> intersect_left(std::uint64_t index, const cv::Vec3d& dir) const;

  // The ray the renderer uses for raw pixel (u, v) moved by (du, dv) pixels (|du|, |dv| <= 0.5), as
  // (x, y, 1) in that camera's frame: projecting it with the camera's M and D gives (u + du, v + dv).
  cv::Vec3d pixel_ray(Camera camera, int u, int v, double du = 0, double dv = 0) const;

  // Share of the scene's light that reaches raw pixel (u, v) of `camera` through its protective window
  // undeflected, 0..1 (1: a clean window; SceneConditions::lens): an obstruction's truth, per pixel.
  double lens_transmission(Camera camera, int u, int v) const;

  // World pose of a camera at its exposure of frame `index`: X_world = rotation * X_camera + centre.
  // The right camera's centre is where it was right_delay_ms after the left exposure.
  cv::Matx33d camera_rotation(Camera camera) const;
  cv::Vec3d camera_centre(Camera camera, std::uint64_t index) const;
  double vehicle_y(std::uint64_t index) const noexcept;
  double depth_mm(std::uint64_t index) const noexcept;

 private:
  struct CameraModel {
    cv::Matx33d K;
    cv::Vec<double, 5> dist;
    cv::Matx33d world_from_camera;
    cv::Vec3d rig_offset;  // centre - rig midpoint, world mm
    cv::Mat centres;       // height x width CV_64FC2: undistorted normalised (x, y) of each pixel centre
  };

  // One camera's exposure of one frame.
  struct Exposure {
    const CameraModel& model;
    const RutTerrain& terrain;
    cv::Vec3d origin;  // the camera centre, world mm
    double time_s;     // exposure time since frame 0
    double rig_y;      // world y of the rig midpoint then
    double water_z;    // world z of the water surface; NaN: no water
  };
  // What a sample ray saw first; a pixel whose kind differs from a row neighbour's is supersampled.
  enum class SampleKind : std::uint8_t { Nothing, Soil, Water, Blade };

  // Radiance (before the sensor) of one row of one camera into `out` (width doubles).
  void render_row(const Exposure& e, int row, double* out) const;
  // Mean radiance of n x n samples over the pixel whose undistorted centre is `centre`; t_centre: the
  // distance (mm) to the centre sample's terrain hit when n is odd (< 0: no hit), else -1; kind: what the
  // centre sample saw.
  double pixel_radiance(const Exposure& e, const cv::Vec2d& centre, int n, double& t_centre,
                        SampleKind& kind) const noexcept;
  // Radiance along one sample ray; dd_u, dd_v: the ray's change to the next sample along u and v.
  double sample_radiance(const Exposure& e, const cv::Vec3d& dir, const cv::Vec3d& dd_u, const cv::Vec3d& dd_v,
                         double& t, SampleKind& kind) const noexcept;
  // Shaded albedo (0..1) of the soil at hit p with terrain gradient g, for samples footprint_mm apart
  // there; wet below water_z and over the capillary fringe above it.
  double radiance(const cv::Vec3d& p, const cv::Vec2d& g, double footprint_mm, double water_z) const noexcept;
  // Radiance of the nearest grass blade on origin + t dir before t_limit, or negative for none.
  double blade_radiance(const RutTerrain& terrain, const cv::Vec3d& origin, const cv::Vec3d& dir,
                        double t_limit) const noexcept;
  // The sensor: exposure, gain, response, noise and quantisation of one camera's radiance image.
  void expose(Camera camera, std::uint64_t index, const cv::Mat& radiance, CameraSettings settings,
              cv::Mat& image) const;
  CameraSettings settle_exposure(const cv::Mat& left_radiance) const;
  const CameraModel& model(Camera camera) const noexcept { return camera == Camera::Left ? left_ : right_; }

  SyntheticRendererConfig params_;
  StereoCalibration calibration_;
  cv::Matx33d truth_rotation_;
  CameraModel left_, right_;
  SolidTexture texture_;
  cv::Vec3d sun_;  // unit vector towards the sun, world frame
  // Immutable after construction, shared by copies. Null when the scene has no water / no window fault.
  std::shared_ptr<const WaterOptics> water_;
  std::shared_ptr<const LensWindow> window_[2];  // left, right
};

// First t > 0 where origin + t * dir meets the terrain (dir need not be unit; dir.z < 0 required for a
// hit), to 1e-7 mm along z, or a negative value for no hit. A straight rut without tread is solved
// exactly piece by piece (RutTerrain::piece: no marching, nothing can be stepped over); otherwise
// Lipschitz-safe marching never steps past a surface (bolder steps are kept only when a curvature bound
// proves them safe; only a sliver of terrain thinner than 0.01 mm could be stepped over). Brackets are
// narrowed on the tabulated terrain and the root is polished on the exact one. Thread-safe,
// allocation-free.
double cast_ray(const RutTerrain& terrain, const cv::Vec3d& origin, const cv::Vec3d& dir) noexcept;

}  // namespace rutd
