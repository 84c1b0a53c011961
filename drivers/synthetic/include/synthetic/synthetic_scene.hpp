#pragma once
// The synthetic test bench's world: a terrain height field with one rut, its world-fixed texture, and
// the ground truth a perfect measurement of it would report. The camera rig that looks at it lives in
// synthetic/synthetic_renderer.hpp.
//
// World frame (millimetres): x lateral, y along travel, z up; undisturbed ground is z = 0. The rut
// centreline runs along y at x = lateral_offset + wander_amplitude * sin(2 pi y / wander_wavelength).
// Cross-section h(s) of the lateral (world x) distance s from the centreline, with D = depth, W = top
// width, b = bottom width, H = pile height of that side, Pw = pile width:
//   |s| <= b/2                 -D                                          (flat bottom)
//   b/2 < |s| <= W/2           -D * 0.5 * (1 + cos(pi (|s| - b/2) / ((W - b)/2)))   (raised-cosine wall)
//   W/2 < |s| <= W/2 + Pw      H * sin^2(pi (|s| - W/2) / Pw)              (pile)
//   elsewhere                  0
// so the profile crosses ground level exactly at |s| = W/2. Optional tread grooves run across the rut
// bottom, periodic along y (see RutShape::tread).
#include <cstdint>
#include <limits>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace rutd {

enum class Texture { Sand, Mud, Snow, Grass };

// "sand", "mud", "snow" or "grass", in any letter case; nullopt for anything else.
std::optional<Texture> parse_texture(std::string_view name);
std::string_view to_string(Texture texture) noexcept;

// The rut, in world millimetres. Defaults: a 50 mm deep, 200 mm wide rut with 12 mm piles.
struct RutShape {
  double depth_mm = 50;                // D, > 0: flat bottom below undisturbed ground
  double width_mm = 200;               // W: top width (ground-level crossings), > bottom_width_mm
  double bottom_width_mm = 100;        // b, >= 0: width of the flat bottom
  double pile_left_mm = 12;            // H of the pile on the side of smaller world x, >= 0
  double pile_right_mm = 12;           // H of the pile on the side of larger world x, >= 0
  double pile_width_mm = 50;           // Pw, > 0: width of each pile outside the rut
  double lateral_offset_mm = 0;        // mean world x of the centreline
  double wander_amplitude_mm = 0;      // >= 0; 0 = straight rut
  double wander_wavelength_mm = 4000;  // > 0
  // Tread grooves: the bottom is lowered by tread_depth_mm * 0.5 * (1 - cos(2 pi y / tread_pitch_mm)),
  // faded to 0 by a raised cosine over the outer tread_taper_mm of each side of the bottom so the
  // surface stays continuous. Off by default. They are not part of depth_mm, width_mm or area_mm2.
  bool tread = false;
  double tread_depth_mm = 3;   // > 0 when tread is on
  double tread_pitch_mm = 30;  // > 0: groove period along y
  double tread_taper_mm = 10;  // > 0 and <= bottom_width_mm / 2 when tread is on
};

// Throws std::invalid_argument naming the field when the shape is impossible (see the field comments).
// `depth_mm` is checked by the caller's depth source instead when `check_depth` is false.
void validate(const RutShape& shape, bool check_depth = true);

// Rut depth over time: piecewise-linear in the frame index between (frame, depth_mm) knots, constant
// before the first and after the last knot. Empty = RutShape::depth_mm for every frame.
using DepthProfile = std::vector<std::pair<std::uint64_t, double>>;

// Throws std::invalid_argument unless frames strictly increase and every depth is finite and > 0.
void validate(const DepthProfile& profile);
double depth_at(const DepthProfile& profile, double constant_depth_mm, std::uint64_t index) noexcept;

// Ground truth of one frame, with exactly the definitions of core/rut_measurement.hpp, in the frame that
// RutMeasurement uses: the left rectified camera frame (SyntheticRenderer::truth_rotation()), on the
// cross-section in its plane Y = 0 (the rectified image row through the principal point). Millimetres.
struct RutTruth {
  std::uint64_t index = 0;      // frame index (StereoFrame::seq of the rendered pair)
  double depth_mm = 0;          // rut bottom below the ground line, perpendicular; excludes tread grooves
  double width_mm = 0;          // distance between the ground-level crossings along the ground line
  double left_pile_mm = 0;      // pile height above the ground line on the side of smaller X
  double right_pile_mm = 0;     // the same on the side of larger X
  double area_mm2 = 0;          // area between the ground line and the cross-section (no tread grooves)
  double ground_slope_deg = 0;  // atan(m) of the ground line Z = m X + c, degrees
  double center_x_mm = 0;       // X of the midpoint between the two crossings
  double tread_depth_mm = 0;    // how much deeper the groove floor is than depth_mm; 0 without tread
  double y_mm = 0;              // world y of the rig midpoint (distance travelled)
  // Standing water (SceneConditions::water), in the same frame and with the same perpendicular heights:
  // its depth over the rut's bottom (0: dry), how far its surface lies below the ground line, and the X
  // of the two waterlines (where the surface meets the walls on the cross-section), smaller X first.
  // The last three are NaN when dry. The surface is level in the world, so parallel to the ground line
  // across the rut.
  double water_depth_mm = 0;
  double waterline_depth_mm = std::numeric_limits<double>::quiet_NaN();
  double waterline_left_x_mm = std::numeric_limits<double>::quiet_NaN();
  double waterline_right_x_mm = std::numeric_limits<double>::quiet_NaN();
  // The cameras: how long after the left exposure the right one was taken (free-running cameras; 0 when
  // triggered together), and the exposure and gain of the pair (SyntheticRendererConfig; auto exposure's
  // choice is known only once the pair is rendered: SyntheticRenderer::render returns it).
  std::int64_t right_delay_ns = 0;
  double exposure = 1;
  double gain = 1;
};

// cos(pi w) and sin(pi w) from the cubic Hermite table behind RutTerrain's *_fast functions: within
// 1e-12 of libm, several times faster. Thread-safe.
double fast_cos_pi(double w) noexcept;
double fast_sin_pi(double w) noexcept;

// The terrain of one frame: z = h(x, y) in world millimetres. Cheap to build (no allocation), immutable,
// thread-safe. The shape is assumed valid (validate()).
class RutTerrain {
 public:
  RutTerrain(const RutShape& shape, double depth_mm) noexcept;

  double height(double x, double y) const noexcept;
  cv::Vec2d gradient(double x, double y) const noexcept;  // (dh/dx, dh/dy)
  double profile(double s) const noexcept;                // h(s) without tread grooves
  double centreline_x(double y) const noexcept;

  // The same functions with every sine and cosine taken from a cubic Hermite table instead of libm:
  // several times faster, and within 1e-12 of the exact value per unit amplitude (so < 1e-9 mm for any
  // valid shape). For ray marching and shading; exact answers come from the functions above.
  double height_fast(double x, double y) const noexcept;
  cv::Vec2d gradient_fast(double x, double y) const noexcept;

  // Bounds for ray casting: max_height() >= h >= min_height() everywhere, |dh/dx| <= max_slope_x(),
  // |dh/dy| <= max_slope_y(), the Hessian's spectral norm <= max_curvature() (per mm), and h == 0
  // exactly for x outside [disturbed_x_min(), disturbed_x_max()].
  double max_height() const noexcept { return max_height_; }
  double min_height() const noexcept { return min_height_; }
  double max_slope_x() const noexcept { return max_slope_x_; }
  double max_slope_y() const noexcept { return max_slope_y_; }
  double max_curvature() const noexcept { return max_curvature_; }
  double disturbed_x_min() const noexcept { return disturbed_min_; }
  double disturbed_x_max() const noexcept { return disturbed_max_; }
  const RutShape& shape() const noexcept { return shape_; }  // with depth_mm of this frame

  // The cross-section P(s) (no tread, no wander) in kProfilePieces pieces, in order of increasing s:
  // piece k spans (end of piece k - 1, s_end], the first from -infinity, the last to +infinity. On each
  // piece P(s) = a + b cos(pi (g s + m)) is monotone and either convex or concave, so a ray that enters it
  // above the terrain meets it at most once where P is convex, and where P is concave only if its
  // height above P dips to 0 at its one minimum there. For exact ray casting without marching.
  struct ProfilePiece {
    double s_end, h_end;  // where the piece ends and P there (s_end = +inf for the last)
    bool convex;
    double a, b, g, m;
  };
  static constexpr int kProfilePieces = 15;
  const ProfilePiece& piece(int k) const noexcept { return pieces_[k]; }

 private:
  // Trig supplies cos_pi(w) = cos(pi w) and sin_pi(w) = sin(pi w): libm or the table.
  template <class Trig>
  double centreline_t(double y) const noexcept;
  template <class Trig>
  double profile_t(double s) const noexcept;
  template <class Trig>
  double profile_slope(double s) const noexcept;  // dh/ds without tread
  template <class Trig>
  double tread_lowering(double s, double y) const noexcept;
  template <class Trig>
  cv::Vec2d tread_gradient(double s, double y) const noexcept;  // (d/ds, d/dy)
  template <class Trig>
  double height_t(double x, double y) const noexcept;
  template <class Trig>
  cv::Vec2d gradient_t(double x, double y) const noexcept;
  void init_pieces() noexcept;

  RutShape shape_;
  double half_bottom_, half_width_, wall_width_;
  double wander_k_;  // 2 pi / wavelength
  double max_height_, min_height_, max_slope_x_, max_slope_y_, max_curvature_;
  double disturbed_min_, disturbed_max_;
  ProfilePiece pieces_[kProfilePieces];
};

// A world-fixed solid texture: albedo (0..1) at a 3D world point, so a point keeps its brightness from
// frame to frame and between the cameras. Built once (allocates its noise tiles and their mip-maps);
// albedo() is const, allocation-free and thread-safe.
class SolidTexture {
 public:
  SolidTexture(Texture kind, std::uint64_t seed);
  // Point sample: every detail of the texture, however fine.
  float albedo(const cv::Vec3d& p) const noexcept;
  // Band-limited sample for a sample spacing of `footprint_mm` on the surface: details finer than about
  // the footprint are replaced by their mean (trilinear mip-mapping of Gaussian pyramids of the noise
  // tiles), so a box filter over samples this far apart does not alias. Equals albedo(p) for a
  // footprint below about a texel. Depends only on p and the footprint: still world-fixed.
  float albedo(const cv::Vec3d& p, double footprint_mm) const noexcept;

 private:
  struct Layer {
    cv::Vec3f u, v;  // tile coordinates (texels) = (u . p, v . p); p in mm
    float weight;
    float texels_per_mm;  // the largest stretch of the (u, v) map, to turn a footprint into texels
  };
  float sample(const Layer& layer, const cv::Vec3d& p, int level, float blend) const noexcept;
  float bilinear(int level, double x, double y) const noexcept;
  float layered(const Layer& layer, const cv::Vec3d& p, double footprint_mm) const noexcept;
  float shade(float n) const noexcept;

  Texture kind_;
  std::vector<cv::Mat> levels_;  // levels_[0]: kTile x kTile CV_32F, periodic, zero mean, unit std;
                                 // levels_[l]: its Gaussian pyramid level l (kTile >> l texels a side)
  Layer fine_, coarse_;
  float base_, contrast_;
};

}  // namespace rutd
