// Terrain, texture and depth profile of the synthetic test bench (synthetic/synthetic_scene.hpp).
#include "synthetic/synthetic_scene.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace rutd {
namespace {

constexpr double kPi = std::numbers::pi;

void require(bool ok, const std::string& field, const std::string& what) {
  if (!ok) throw std::invalid_argument("rut shape: " + field + ": " + what);
}

bool finite_all(const RutShape& s) {
  for (double v : {s.depth_mm, s.width_mm, s.bottom_width_mm, s.pile_left_mm, s.pile_right_mm, s.pile_width_mm,
                   s.lateral_offset_mm, s.wander_amplitude_mm, s.wander_wavelength_mm, s.tread_depth_mm,
                   s.tread_pitch_mm, s.tread_taper_mm}) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

}  // namespace

std::optional<Texture> parse_texture(std::string_view name) {
  std::string lower(name);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (lower == "sand") return Texture::Sand;
  if (lower == "mud") return Texture::Mud;
  if (lower == "snow") return Texture::Snow;
  if (lower == "grass") return Texture::Grass;
  return std::nullopt;
}

std::string_view to_string(Texture texture) noexcept {
  switch (texture) {
    case Texture::Sand: return "sand";
    case Texture::Mud: return "mud";
    case Texture::Snow: return "snow";
    case Texture::Grass: return "grass";
  }
  return "unknown";
}

void validate(const RutShape& s, bool check_depth) {
  require(finite_all(s), "values", "every value must be finite");
  if (check_depth) require(s.depth_mm > 0, "depth_mm", "must be > 0");
  require(s.width_mm > 0, "width_mm", "must be > 0");
  require(s.bottom_width_mm >= 0 && s.bottom_width_mm < s.width_mm, "bottom_width_mm",
          "must be >= 0 and < width_mm (a vertical wall cannot be ray cast)");
  require(s.pile_left_mm >= 0, "pile_left_mm", "must be >= 0");
  require(s.pile_right_mm >= 0, "pile_right_mm", "must be >= 0");
  require(s.pile_width_mm > 0, "pile_width_mm", "must be > 0");
  require(s.wander_amplitude_mm >= 0, "wander_amplitude_mm", "must be >= 0");
  require(s.wander_wavelength_mm > 0, "wander_wavelength_mm", "must be > 0");
  if (!s.tread) return;
  require(s.tread_depth_mm > 0, "tread_depth_mm", "must be > 0");
  require(s.tread_pitch_mm > 0, "tread_pitch_mm", "must be > 0");
  require(s.tread_taper_mm > 0 && s.tread_taper_mm <= s.bottom_width_mm / 2, "tread_taper_mm",
          "must be > 0 and <= bottom_width_mm / 2");
}

void validate(const DepthProfile& profile) {
  for (std::size_t i = 0; i < profile.size(); ++i) {
    const double depth = profile[i].second;
    if (!std::isfinite(depth) || depth <= 0) {
      throw std::invalid_argument("depth profile: knot " + std::to_string(i) + ": depth must be > 0");
    }
    if (i > 0 && profile[i].first <= profile[i - 1].first) {
      throw std::invalid_argument("depth profile: knot " + std::to_string(i) + ": frames must strictly increase");
    }
  }
}

double depth_at(const DepthProfile& profile, double constant_depth_mm, std::uint64_t index) noexcept {
  if (profile.empty()) return constant_depth_mm;
  if (index <= profile.front().first) return profile.front().second;
  if (index >= profile.back().first) return profile.back().second;
  const auto after = std::upper_bound(profile.begin(), profile.end(), index,
                                      [](std::uint64_t i, const auto& knot) { return i < knot.first; });
  const auto before = after - 1;
  const double u = static_cast<double>(index - before->first) / static_cast<double>(after->first - before->first);
  return before->second + u * (after->second - before->second);
}

// ---------------------------------------------------------------------------------------------------
// RutTerrain

RutTerrain::RutTerrain(const RutShape& shape, double depth_mm) noexcept : shape_(shape) {
  shape_.depth_mm = depth_mm;
  half_bottom_ = shape_.bottom_width_mm / 2;
  half_width_ = shape_.width_mm / 2;
  wall_width_ = half_width_ - half_bottom_;
  wander_k_ = 2 * kPi / shape_.wander_wavelength_mm;
  const double tread = shape_.tread ? shape_.tread_depth_mm : 0.0;
  const double pile = std::max(shape_.pile_left_mm, shape_.pile_right_mm);
  max_height_ = pile;
  min_height_ = -(depth_mm + tread);
  const double wall_slope = depth_mm * kPi / (2 * wall_width_);
  const double pile_slope = pile * kPi / shape_.pile_width_mm;
  const double tread_s = shape_.tread ? tread * kPi / (2 * shape_.tread_taper_mm) : 0.0;
  const double tread_y = shape_.tread ? tread * kPi / shape_.tread_pitch_mm : 0.0;
  const double wander = shape_.wander_amplitude_mm * wander_k_;  // max |xc'(y)|
  // h = P(s) - tread(s, y) with s = x - xc(y); the s terms of P and of the tread never overlap in s,
  // their sum is a bound. dh/dx = dh/ds; dh/dy = -xc' dh/ds - d tread/dy.
  const double slope_s = std::max(wall_slope, pile_slope) + tread_s;
  max_slope_x_ = slope_s;
  max_slope_y_ = slope_s * wander + tread_y;
  const double wall_curve = depth_mm * kPi * kPi / (2 * wall_width_ * wall_width_);
  const double pile_curve = 2 * pile * kPi * kPi / (shape_.pile_width_mm * shape_.pile_width_mm);
  const double tread_curve = shape_.tread ? tread * (kPi * kPi / (2 * shape_.tread_taper_mm * shape_.tread_taper_mm) +
                                                     kPi * kPi / (shape_.tread_taper_mm * shape_.tread_pitch_mm) +
                                                     2 * kPi * kPi / (shape_.tread_pitch_mm * shape_.tread_pitch_mm))
                                          : 0.0;
  // Every second derivative (s-s, s-y, y-y, through xc' and xc'') is bounded by these terms; the
  // Frobenius norm of the bounded Hessian bounds its spectral norm.
  const double chain = (1 + wander) * (1 + wander);
  max_curvature_ = 2 * ((std::max(wall_curve, pile_curve) + tread_curve) * chain +
                        slope_s * shape_.wander_amplitude_mm * wander_k_ * wander_k_);
  const double reach = half_width_ + (pile > 0 ? shape_.pile_width_mm : 0.0) + shape_.wander_amplitude_mm;
  disturbed_min_ = shape_.lateral_offset_mm - reach;
  disturbed_max_ = shape_.lateral_offset_mm + reach;
  init_pieces();
}

void RutTerrain::init_pieces() noexcept {
  // s is measured from the centreline here; the caller adds the lateral offset.
  const double D = shape_.depth_mm, B = half_bottom_, L = half_width_, Pw = shape_.pile_width_mm;
  const double ww = wall_width_, Hl = shape_.pile_left_mm, Hr = shape_.pile_right_mm;
  const double inf = std::numeric_limits<double>::infinity();
  // Convexity: sin^2 is convex on its outer quarters and concave around its crest; the raised-cosine
  // wall is convex on its lower half and concave on its upper half.
  const ProfilePiece flat{0, 0, true, 0, 0, 0, 0};
  const ProfilePiece left_pile{0, 0, true, Hl / 2, -Hl / 2, -2 / Pw, -2 * L / Pw};
  const ProfilePiece left_wall{0, 0, true, -D / 2, -D / 2, -1 / ww, -B / ww};
  const ProfilePiece bottom{0, 0, true, -D, 0, 0, 0};
  const ProfilePiece right_wall{0, 0, true, -D / 2, -D / 2, 1 / ww, -B / ww};
  const ProfilePiece right_pile{0, 0, true, Hr / 2, -Hr / 2, 2 / Pw, -2 * L / Pw};
  const auto at = [](ProfilePiece p, double s_end, double h_end, bool convex) {
    p.s_end = s_end, p.h_end = h_end, p.convex = convex;
    return p;
  };
  const double mid = B + ww / 2;
  const ProfilePiece pieces[kProfilePieces] = {at(flat, -L - Pw, 0, true),
                                               at(left_pile, -L - 0.75 * Pw, Hl / 2, true),
                                               at(left_pile, -L - 0.5 * Pw, Hl, false),
                                               at(left_pile, -L - 0.25 * Pw, Hl / 2, false),
                                               at(left_pile, -L, 0, true),
                                               at(left_wall, -mid, -D / 2, false),
                                               at(left_wall, -B, -D, true),
                                               at(bottom, B, -D, true),
                                               at(right_wall, mid, -D / 2, true),
                                               at(right_wall, L, 0, false),
                                               at(right_pile, L + 0.25 * Pw, Hr / 2, true),
                                               at(right_pile, L + 0.5 * Pw, Hr, false),
                                               at(right_pile, L + 0.75 * Pw, Hr / 2, false),
                                               at(right_pile, L + Pw, 0, true),
                                               at(flat, inf, 0, true)};
  std::copy(std::begin(pieces), std::end(pieces), pieces_);
}

namespace {

struct LibmTrig {
  static double cos_pi(double w) noexcept { return std::cos(kPi * w); }
  static double sin_pi(double w) noexcept { return std::sin(kPi * w); }
};

// cos(pi w) by cubic Hermite interpolation of values and slopes at kCosSteps + 1 nodes over one period
// w in [0, 2]. Node spacing h = 2 / kCosSteps; the error is at most h^4 pi^4 / 384 < 1e-12.
class TableTrig {
 public:
  static double cos_pi(double w) noexcept {
    const double half = 0.5 * w;
    auto periods = static_cast<std::int64_t>(half);  // floor without a libm call
    periods -= half < static_cast<double>(periods);
    const double r = (w - 2.0 * static_cast<double>(periods)) * (kCosSteps / 2.0);  // node units, [0, kCosSteps]
    int i = static_cast<int>(r);
    i = std::min(std::max(i, 0), kCosSteps - 1);
    const double t = r - i;
    const Node& a = kTable.nodes[i];
    const Node& b = kTable.nodes[i + 1];
    // Hermite basis on [0, 1] with slopes already scaled by the node spacing.
    const double t2 = t * t, t3 = t2 * t;
    return a.value * (2 * t3 - 3 * t2 + 1) + a.slope * (t3 - 2 * t2 + t) + b.value * (3 * t2 - 2 * t3) +
           b.slope * (t3 - t2);
  }
  static double sin_pi(double w) noexcept { return cos_pi(w - 0.5); }

 private:
  static constexpr int kCosSteps = 2048;
  struct Node {
    double value, slope;  // cos(pi w) and h * d/dw cos(pi w)
  };
  struct Table {
    Node nodes[kCosSteps + 1];
    Table() {
      const double h = 2.0 / kCosSteps;
      for (int i = 0; i <= kCosSteps; ++i) {
        nodes[i] = {std::cos(kPi * i * h), -h * kPi * std::sin(kPi * i * h)};
      }
    }
  };
  static const Table kTable;
};

// Built during static initialisation: nothing in this library renders before main().
const TableTrig::Table TableTrig::kTable;

// Raised cosine falling from 1 at u = 0 to 0 at u = 1, and its derivative.
template <class Trig>
double fall(double u) noexcept {
  return 0.5 * (1.0 + Trig::cos_pi(u));
}
template <class Trig>
double fall_slope(double u) noexcept {
  return -0.5 * kPi * Trig::sin_pi(u);
}

}  // namespace

template <class Trig>
double RutTerrain::centreline_t(double y) const noexcept {
  if (shape_.wander_amplitude_mm == 0) return shape_.lateral_offset_mm;
  return shape_.lateral_offset_mm + shape_.wander_amplitude_mm * Trig::sin_pi(2 * y / shape_.wander_wavelength_mm);
}

template <class Trig>
double RutTerrain::profile_t(double s) const noexcept {
  const double a = std::abs(s);
  if (a <= half_bottom_) return -shape_.depth_mm;
  if (a <= half_width_) return -shape_.depth_mm * fall<Trig>((a - half_bottom_) / wall_width_);
  if (a <= half_width_ + shape_.pile_width_mm) {
    const double pile_height = s < 0 ? shape_.pile_left_mm : shape_.pile_right_mm;
    // H sin^2(pi u) = H (1 - cos(2 pi u)) / 2
    return pile_height * (1.0 - fall<Trig>(2 * (a - half_width_) / shape_.pile_width_mm));
  }
  return 0.0;
}

template <class Trig>
double RutTerrain::profile_slope(double s) const noexcept {
  const double a = std::abs(s);
  const double sign = s < 0 ? -1.0 : 1.0;
  if (a <= half_bottom_) return 0.0;
  if (a <= half_width_) {
    return -sign * shape_.depth_mm * fall_slope<Trig>((a - half_bottom_) / wall_width_) / wall_width_;
  }
  if (a <= half_width_ + shape_.pile_width_mm) {
    const double pile_height = s < 0 ? shape_.pile_left_mm : shape_.pile_right_mm;
    const double w = kPi / shape_.pile_width_mm;
    return sign * pile_height * w * Trig::sin_pi(2 * (a - half_width_) / shape_.pile_width_mm);
  }
  return 0.0;
}

template <class Trig>
double RutTerrain::tread_lowering(double s, double y) const noexcept {
  const double a = std::abs(s);
  if (!shape_.tread || a >= half_bottom_) return 0.0;
  const double inner = half_bottom_ - shape_.tread_taper_mm;
  const double across = a <= inner ? 1.0 : fall<Trig>((a - inner) / shape_.tread_taper_mm);
  const double along = 1.0 - fall<Trig>(2 * y / shape_.tread_pitch_mm);
  return shape_.tread_depth_mm * across * along;
}

template <class Trig>
cv::Vec2d RutTerrain::tread_gradient(double s, double y) const noexcept {
  const double a = std::abs(s);
  if (!shape_.tread || a >= half_bottom_) return {0.0, 0.0};
  const double inner = half_bottom_ - shape_.tread_taper_mm;
  const double u = (a - inner) / shape_.tread_taper_mm;
  const double across = a <= inner ? 1.0 : fall<Trig>(u);
  const double across_slope = a <= inner ? 0.0 : fall_slope<Trig>(u) / shape_.tread_taper_mm * (s < 0 ? -1 : 1);
  const double w = 2 * kPi / shape_.tread_pitch_mm;
  const double phase = 2 * y / shape_.tread_pitch_mm;  // w y / pi
  const double along = 1.0 - fall<Trig>(phase);
  const double along_slope = 0.5 * w * Trig::sin_pi(phase);
  return {shape_.tread_depth_mm * across_slope * along, shape_.tread_depth_mm * across * along_slope};
}

template <class Trig>
double RutTerrain::height_t(double x, double y) const noexcept {
  const double s = x - centreline_t<Trig>(y);
  return profile_t<Trig>(s) - tread_lowering<Trig>(s, y);
}

template <class Trig>
cv::Vec2d RutTerrain::gradient_t(double x, double y) const noexcept {
  const double s = x - centreline_t<Trig>(y);
  const cv::Vec2d tread = tread_gradient<Trig>(s, y);
  const double dh_ds = profile_slope<Trig>(s) - tread[0];
  const double xc_slope = shape_.wander_amplitude_mm == 0 ? 0.0
                                                          : shape_.wander_amplitude_mm * wander_k_ *
                                                                Trig::cos_pi(2 * y / shape_.wander_wavelength_mm);
  return {dh_ds, -dh_ds * xc_slope - tread[1]};
}

double fast_cos_pi(double w) noexcept { return TableTrig::cos_pi(w); }
double fast_sin_pi(double w) noexcept { return TableTrig::sin_pi(w); }

double RutTerrain::centreline_x(double y) const noexcept { return centreline_t<LibmTrig>(y); }
double RutTerrain::profile(double s) const noexcept { return profile_t<LibmTrig>(s); }
double RutTerrain::height(double x, double y) const noexcept { return height_t<LibmTrig>(x, y); }
cv::Vec2d RutTerrain::gradient(double x, double y) const noexcept { return gradient_t<LibmTrig>(x, y); }
double RutTerrain::height_fast(double x, double y) const noexcept { return height_t<TableTrig>(x, y); }
cv::Vec2d RutTerrain::gradient_fast(double x, double y) const noexcept { return gradient_t<TableTrig>(x, y); }

// ---------------------------------------------------------------------------------------------------
// SolidTexture

namespace {

constexpr int kTileBits = 10;
constexpr int kTile = 1 << kTileBits;  // texels per tile side; a power of two so wrapping is a mask

// White noise, uniform in [-1, 1].
cv::Mat white_noise(std::mt19937_64& rng) {
  cv::Mat noise(kTile, kTile, CV_32F);
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  for (int r = 0; r < kTile; ++r) {
    float* row = noise.ptr<float>(r);
    for (int c = 0; c < kTile; ++c) row[c] = uniform(rng);
  }
  return noise;
}

// `tile` blurred by a Gaussian of `sigma` texels with periodic (wrapped) borders.
cv::Mat blur_periodic(const cv::Mat& tile, double sigma) {
  const int pad = static_cast<int>(std::ceil(4 * sigma)) + 1;
  cv::Mat padded, blurred;
  cv::copyMakeBorder(tile, padded, pad, pad, pad, pad, cv::BORDER_WRAP);
  cv::GaussianBlur(padded, blurred, cv::Size(0, 0), sigma, sigma, cv::BORDER_REFLECT);
  return blurred(cv::Rect(pad, pad, kTile, kTile)).clone();
}

cv::Mat normalised(const cv::Mat& tile) {
  cv::Scalar mean, stddev;
  cv::meanStdDev(tile, mean, stddev);
  cv::Mat out;
  tile.convertTo(out, CV_32F, 1.0 / std::max(stddev[0], 1e-12), -mean[0] / std::max(stddev[0], 1e-12));
  return out;
}

// Multi-scale isotropic noise: sum of blurred white noise at the given sigmas (texels) and weights.
cv::Mat grain_tile(std::mt19937_64& rng, std::initializer_list<std::pair<double, double>> octaves) {
  cv::Mat sum = cv::Mat::zeros(kTile, kTile, CV_32F);
  for (const auto& [sigma, weight] : octaves) {
    cv::Mat layer = normalised(blur_periodic(white_noise(rng), sigma));
    cv::scaleAdd(layer, weight, sum, sum);
  }
  return normalised(sum);
}

// Grass seen from above: overlapping anti-aliased strands of random direction, length and shade,
// painted with periodic wrap so the tile stays seamless.
cv::Mat strand_tile(std::mt19937_64& rng) {
  cv::Mat tile(kTile, kTile, CV_32F, cv::Scalar(-0.6));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  constexpr int kStrands = 3500;
  for (int i = 0; i < kStrands; ++i) {
    const double x = unit(rng) * kTile, y = unit(rng) * kTile;
    const double angle = unit(rng) * kPi;
    const double length = 40 + 90 * unit(rng);
    const int thickness = 2 + static_cast<int>(4 * unit(rng));
    const double shade = -0.4 + 1.6 * unit(rng);
    const cv::Point2d d(std::cos(angle) * length / 2, std::sin(angle) * length / 2);
    for (int ox = -1; ox <= 1; ++ox) {
      for (int oy = -1; oy <= 1; ++oy) {
        const cv::Point2d c(x + ox * kTile, y + oy * kTile);
        constexpr int kShift = 4;  // sub-pixel endpoints
        const auto fixed = [](cv::Point2d p) {
          return cv::Point(cvRound(p.x * (1 << kShift)), cvRound(p.y * (1 << kShift)));
        };
        cv::line(tile, fixed(c - d), fixed(c + d), cv::Scalar(shade), thickness, cv::LINE_AA, kShift);
      }
    }
  }
  return normalised(blur_periodic(tile, 0.7));
}

// Tile axes for a layer: texels per mm `1/texel_mm`, rotated about z by `angle` and tilted into z so the
// texture is a genuine function of 3D position (walls are not smeared).
void layer_axes(double texel_mm, double angle, cv::Vec3f& u, cv::Vec3f& v) {
  const double k = 1.0 / texel_mm;
  const double c = std::cos(angle), s = std::sin(angle);
  u = cv::Vec3f(static_cast<float>(k * c), static_cast<float>(k * s), static_cast<float>(k * 0.6 * s));
  v = cv::Vec3f(static_cast<float>(-k * s), static_cast<float>(k * c), static_cast<float>(k * 0.6 * c));
}

// Mip level choice: texels as wide as this fraction of the footprint. Below 1, a little detail finer
// than the footprint survives, which keeps the texture's contrast near that of a 3 x 3 point-sampled
// box filter while still removing what would alias.
constexpr float kFootprintScale = 0.7f;

// Gaussian pyramid of a periodic tile (cv::pyrDown on a wrapped copy), down to kMinLevelTexels a side.
// Level l texel i sits over level 0 texel i * 2^l, so level l coordinates are level 0 ones / 2^l.
constexpr int kMinLevelTexels = 4;
std::vector<cv::Mat> periodic_pyramid(const cv::Mat& tile) {
  std::vector<cv::Mat> levels{tile};
  constexpr int kPad = 4;  // even, so the halved padding stays whole
  while (levels.back().cols / 2 >= kMinLevelTexels) {
    const cv::Mat& top = levels.back();
    cv::Mat padded, down;
    cv::copyMakeBorder(top, padded, kPad, kPad, kPad, kPad, cv::BORDER_WRAP);
    cv::pyrDown(padded, down);
    levels.push_back(down(cv::Rect(kPad / 2, kPad / 2, top.cols / 2, top.rows / 2)).clone());
  }
  return levels;
}

}  // namespace

SolidTexture::SolidTexture(Texture kind, std::uint64_t seed) : kind_(kind) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(kind) + 1);
  std::uniform_real_distribution<double> angle(0.0, 2 * kPi);
  // Texel sizes keep the finest features (~3 texels) above the sub-pixel sample spacing of a 640 px
  // wide image at 350 mm (0.28 mm), so the box filter integrates them instead of aliasing them.
  double fine_texel = 0.3, coarse_texel = 6.9, coarse_weight = 0.5;
  switch (kind) {
    case Texture::Sand:  // fine grain, good contrast
      levels_ = {grain_tile(rng, {{1.0, 1.0}, {3.5, 0.6}})};
      base_ = 0.5f, contrast_ = 0.185f;
      break;
    case Texture::Mud:  // darker, smoother, blotchy
      levels_ = {grain_tile(rng, {{1.5, 0.35}, {6.0, 1.0}})};
      fine_texel = 0.4, coarse_texel = 5.1, coarse_weight = 1.0;
      base_ = 0.25f, contrast_ = 0.09f;
      break;
    case Texture::Snow:  // bright, very low contrast
      levels_ = {grain_tile(rng, {{1.0, 1.0}, {4.0, 0.5}})};
      coarse_texel = 8.7, coarse_weight = 0.3;
      base_ = 0.85f, contrast_ = 0.036f;
      break;
    case Texture::Grass:  // blades and strands
      levels_ = {strand_tile(rng)};
      fine_texel = 0.35, coarse_texel = 3.7, coarse_weight = 0.4;
      base_ = 0.38f, contrast_ = 0.16f;
      break;
  }
  layer_axes(fine_texel, angle(rng), fine_.u, fine_.v);
  layer_axes(coarse_texel, angle(rng), coarse_.u, coarse_.v);
  fine_.weight = 1.0f;
  coarse_.weight = static_cast<float>(coarse_weight);
  // The z tilt stretches the map by up to sqrt(1 + 0.6^2) along the steepest surface direction.
  fine_.texels_per_mm = static_cast<float>(std::sqrt(1 + 0.36) / fine_texel);
  coarse_.texels_per_mm = static_cast<float>(std::sqrt(1 + 0.36) / coarse_texel);
  levels_ = periodic_pyramid(levels_[0]);
}

namespace {

std::int64_t floor_to_int(double x) noexcept {
  const auto i = static_cast<std::int64_t>(x);
  return i - (x < static_cast<double>(i));
}

// log2(x) for x >= 1 from the float's exponent and a quadratic in its mantissa: continuous and
// increasing, within 0.01 of log2; picks mip levels.
float level_of(float x) noexcept {
  std::uint32_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  const int exponent = static_cast<int>(bits >> 23) - 127;
  bits = (bits & 0x007FFFFFu) | 0x3F800000u;  // mantissa in [1, 2)
  float m;
  std::memcpy(&m, &bits, sizeof m);
  return static_cast<float>(exponent) + (m - 1.0f) * (1.6932f - 0.3466f * m);
}

}  // namespace

float SolidTexture::bilinear(int level, double x, double y) const noexcept {
  const cv::Mat& tile = levels_[level];
  const std::int64_t mask = tile.cols - 1;  // power of two
  const std::int64_t ix = floor_to_int(x), iy = floor_to_int(y);
  const float ax = static_cast<float>(x - static_cast<double>(ix));
  const float ay = static_cast<float>(y - static_cast<double>(iy));
  const int x0 = static_cast<int>(ix & mask);
  const int y0 = static_cast<int>(iy & mask);
  const int x1 = static_cast<int>((x0 + 1) & mask), y1 = static_cast<int>((y0 + 1) & mask);
  const float* r0 = tile.ptr<float>(y0);
  const float* r1 = tile.ptr<float>(y1);
  const float top = r0[x0] + ax * (r0[x1] - r0[x0]);
  const float bottom = r1[x0] + ax * (r1[x1] - r1[x0]);
  return top + ay * (bottom - top);
}

float SolidTexture::sample(const Layer& layer, const cv::Vec3d& p, int level, float blend) const noexcept {
  // Coordinates in double: after minutes of travel y reaches 1e5 mm, 1e6 texels, beyond float's reach.
  const double x = layer.u[0] * p[0] + layer.u[1] * p[1] + layer.u[2] * p[2];
  const double y = layer.v[0] * p[0] + layer.v[1] * p[1] + layer.v[2] * p[2];
  const double scale = 1.0 / static_cast<double>(1 << level);
  float value = bilinear(level, x * scale, y * scale);
  if (blend > 0) value += blend * (bilinear(level + 1, 0.5 * x * scale, 0.5 * y * scale) - value);
  return layer.weight * value;
}

float SolidTexture::layered(const Layer& layer, const cv::Vec3d& p, double footprint_mm) const noexcept {
  // Level l has texels 2^l wide: pick the level (and blend with the next) whose texels are as wide as
  // the footprint, so the samples see no detail finer than their spacing.
  const int top = static_cast<int>(levels_.size()) - 1;
  const float lambda =
      level_of(std::max(1.0f, static_cast<float>(footprint_mm) * layer.texels_per_mm * kFootprintScale));
  if (!(lambda < static_cast<float>(top))) return 0.0f;  // coarser than the coarsest level: its mean
  const int level = static_cast<int>(lambda);
  return sample(layer, p, level, lambda - static_cast<float>(level));
}

float SolidTexture::shade(float n) const noexcept {
  if (kind_ == Texture::Mud) n = 1.6f * std::tanh(1.2f * n);  // blotches: flattened extremes
  return std::clamp(base_ + contrast_ * n, 0.01f, 0.99f);
}

float SolidTexture::albedo(const cv::Vec3d& p) const noexcept {
  return shade(sample(fine_, p, 0, 0.0f) + sample(coarse_, p, 0, 0.0f));
}

float SolidTexture::albedo(const cv::Vec3d& p, double footprint_mm) const noexcept {
  return shade(layered(fine_, p, footprint_mm) + layered(coarse_, p, footprint_mm));
}

}  // namespace rutd
