// Waterline detection and the refraction correction (rut/waterline.hpp).
#include "rut/waterline.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/core.hpp>

#include "local_fit.hpp"

namespace rutd {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Mean of the valid values in [lo, hi] (clamped), NaN unless at least `need` are valid.
double window_mean(const std::vector<double>& v, int lo, int hi, int need) {
  lo = std::max(lo, 0);
  hi = std::min(hi, static_cast<int>(v.size()) - 1);
  double sum = 0.0;
  int n = 0;
  for (int i = lo; i <= hi; ++i) {
    if (std::isnan(v[static_cast<std::size_t>(i)])) continue;
    sum += v[static_cast<std::size_t>(i)];
    ++n;
  }
  return n >= need ? sum / n : kNaN;
}

// Median of v over the flat ground bins in [from, to] (clamped): those within 1 mm of the ground line
// (z: heights below it; piles and stones slope), NaN with fewer than 10.
double flat_ground_median(const std::vector<double>& v, const std::vector<double>& z, int from, int to,
                          std::vector<double>& scratch) {
  scratch.clear();
  for (int i = std::max(from, 0); i <= std::min(to, static_cast<int>(v.size()) - 1); ++i) {
    const double value = v[static_cast<std::size_t>(i)], height = z[static_cast<std::size_t>(i)];
    if (!std::isnan(value) && std::abs(height) <= 1.0) scratch.push_back(value);
  }
  return scratch.size() >= 10 ? detail::median_inplace(scratch.data(), scratch.data() + scratch.size()) : kNaN;
}

// Of two differences, the smaller in size; 0 unless both have one sign (NaN: unknown, 0 too).
double smaller_same_sign(double left, double right) {
  if (!(left * right > 0.0)) return 0.0;
  return std::abs(left) < std::abs(right) ? left : right;
}

struct Step {
  int bin = -1;       // the boundary lies between bin and bin + 1
  double step = 0.0;  // log brightness below the boundary minus above it
  double depth = kNaN, slope = kNaN;
};

}  // namespace

Waterline find_waterline(const CrossSection& section, const std::vector<double>& brightness,
                         const RutGeometry& geometry, const WaterlineConfig& config, WaterlineWorkspace& ws) {
  Waterline out;
  const int n = static_cast<int>(section.z_mm.size());
  if (!config.enabled || !geometry.has_line || !geometry.has_rut || n < 8 || static_cast<int>(brightness.size()) != n ||
      !(section.dx_mm > 0))
    return out;
  const double dx = section.dx_mm;
  const double m = geometry.line_m, c = geometry.line_c, norm = std::sqrt(1.0 + m * m);
  const int w = std::max(2, static_cast<int>(std::lround(config.step_window_mm / dx)));
  const int need = (w + 1) / 2;
  const auto x_of = [&](int i) { return section.x0_mm + dx * i; };

  // Depth below the ground line (perpendicular, + = away from the camera) and log brightness per bin.
  ws.z.assign(static_cast<std::size_t>(n), kNaN);
  ws.log_brightness.assign(static_cast<std::size_t>(n), kNaN);
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (!std::isnan(section.z_mm[k])) ws.z[k] = (section.z_mm[k] - (m * x_of(i) + c)) / norm;
    if (std::isfinite(brightness[k])) ws.log_brightness[k] = std::log(std::max(brightness[k], 1.0));
  }
  // Step at every boundary: the mean log brightness of the w bins after it minus the w bins before it.
  ws.step.assign(static_cast<std::size_t>(n), kNaN);
  for (int i = 0; i + 1 < n; ++i) {
    const double before = window_mean(ws.log_brightness, i - w + 1, i, need);
    const double after = window_mean(ws.log_brightness, i + 1, i + w, need);
    ws.step[static_cast<std::size_t>(i)] = after - before;
  }
  // The soil's own variation of the statistic: over the ground outside the opening.
  ws.values.clear();
  for (int i = 0; i + 1 < n; ++i) {
    const double x = x_of(i);
    const double s = ws.step[static_cast<std::size_t>(i)];
    if (!std::isnan(s) && (x + w * dx < geometry.left_x_mm || x - w * dx > geometry.right_x_mm))
      ws.values.push_back(std::abs(s));
  }
  out.ground_spread = ws.values.size() >= 10
                          ? 1.4826 * detail::median_inplace(ws.values.data(), ws.values.data() + ws.values.size())
                          : 0.0;
  const double threshold = waterline_step_threshold(config, out.ground_spread);

  // Candidate steps on each wall: local extremes of the step above the threshold, between the rim and
  // the deepest point, at least min_level_mm below the ground line.
  const auto candidates = [&](double x_from, double x_to, double sign, Step* list, int capacity) {
    int count = 0;
    for (int i = 1; i + 2 < n && count < capacity; ++i) {
      const double x = x_of(i) + 0.5 * dx;
      if (x <= x_from || x >= x_to) continue;
      const double s = sign * ws.step[static_cast<std::size_t>(i)];
      if (std::isnan(s) || std::abs(s) < threshold) continue;
      const double sl = sign * ws.step[static_cast<std::size_t>(i - 1)];
      const double sr = sign * ws.step[static_cast<std::size_t>(i + 1)];
      if ((!std::isnan(sl) && std::abs(sl) > std::abs(s)) || (!std::isnan(sr) && std::abs(sr) >= std::abs(s))) continue;
      const double depth = window_mean(ws.z, i - 1, i + 2, 1);
      const double above = window_mean(ws.z, i - w + 1, i, need), below = window_mean(ws.z, i + 1, i + w, need);
      if (std::isnan(depth) || depth < config.min_level_mm) continue;
      list[count++] = Step{i, s, depth, std::isnan(above) || std::isnan(below) ? 0.0 : (below - above) / (w * dx)};
    }
    return count;
  };
  constexpr int kCapacity = 16;
  Step left[kCapacity], right[kCapacity];
  // Walking down each wall: on the left wall down is +X, on the right wall -X (the step's sign flips).
  // The flat ground's median log brightness beyond the opening on each side (3 bins clear of its ends),
  // for submerged_ground_step: taken once, when the first pair is accepted (most frames have none).
  double ground_left = kNaN, ground_right = kNaN;
  bool ground_taken = false;
  // The walls meet at the middle of the opening (a lid's deepest point may lie anywhere on it).
  const double middle = 0.5 * (geometry.left_x_mm + geometry.right_x_mm);
  const int nl = candidates(geometry.left_x_mm, middle, +1.0, left, kCapacity);
  const int nr = candidates(middle, geometry.right_x_mm, -1.0, right, kCapacity);
  double best = 0.0;
  for (int a = 0; a < nl; ++a) {
    for (int b = 0; b < nr; ++b) {
      const Step& l = left[a];
      const Step& r = right[b];
      if ((l.step > 0) != (r.step > 0)) continue;  // wet (darker) on both walls, or a lid on both
      const double tolerance = config.level_tolerance_mm + 2.0 * dx * (std::abs(l.slope) + std::abs(r.slope));
      if (std::abs(l.depth - r.depth) > tolerance) continue;
      // Below a waterline the whole submerged span stays wet (or lidded), not just a band at the step:
      // its mean brightness must differ from the walls' just above in the same sense by at least half the
      // threshold (a grain or a shadow band gives a local step only).
      const double above = 0.5 * (window_mean(ws.log_brightness, l.bin - w + 1, l.bin, need) +
                                  window_mean(ws.log_brightness, r.bin + 1, r.bin + w, need));
      const double submerged = window_mean(ws.log_brightness, l.bin + 1, r.bin, need);
      const double sense = l.step > 0 ? 1.0 : -1.0;
      if (!((submerged - above) * sense >= std::max(0.5 * threshold, config.min_submerged_step))) continue;
      const double strength = std::min(std::abs(l.step), std::abs(r.step));
      if (strength <= best) continue;
      best = strength;
      out.found = true;
      out.level_mm = 0.5 * (l.depth + r.depth);
      // The two walls' disagreement, and each step located to about a bin on its wall.
      const double half = 0.5 * (l.depth - r.depth);
      const double located = dx * std::hypot(l.slope, r.slope);
      out.level_u_mm = std::sqrt(half * half + located * located);
      out.left_x_mm = x_of(l.bin) + 0.5 * dx;
      out.right_x_mm = x_of(r.bin) + 0.5 * dx;
      out.left_step = l.step;
      out.right_step = r.step;
      out.submerged_step = submerged - above;
      if (!ground_taken) {
        const int lo = static_cast<int>(std::ceil((geometry.left_x_mm - section.x0_mm) / dx));
        const int hi = static_cast<int>(std::floor((geometry.right_x_mm - section.x0_mm) / dx));
        ground_left = flat_ground_median(ws.log_brightness, ws.z, 0, lo - 3, ws.values);
        ground_right = flat_ground_median(ws.log_brightness, ws.z, hi + 3, n - 1, ws.values);
        ground_taken = true;
      }
      out.submerged_ground_step = smaller_same_sign(submerged - ground_left, submerged - ground_right);
    }
  }
  return out;
}

namespace {

// Robust bin-to-bin scatter of z over the bins `use` accepts: each valid bin against the mean of its two
// valid neighbours (a parabola's curvature over two bins is far below the noise), 1.4826 MAD scaled to
// one bin's sigma (the residual's variance is 1.5 times a bin's). NaN under 5 residuals.
template <class Use>
double bin_scatter(const std::vector<double>& z, Use use, std::vector<double>& scratch) {
  scratch.clear();
  for (std::size_t i = 1; i + 1 < z.size(); ++i) {
    if (!use(static_cast<int>(i)) || std::isnan(z[i]) || std::isnan(z[i - 1]) || std::isnan(z[i + 1])) continue;
    scratch.push_back(std::abs(z[i] - 0.5 * (z[i - 1] + z[i + 1])));
  }
  if (scratch.size() < 5) return kNaN;
  return 1.4826 * detail::median_inplace(scratch.data(), scratch.data() + scratch.size()) / std::sqrt(1.5);
}

}  // namespace

LevelSpan find_level_span(const CrossSection& section, const std::vector<double>& brightness,
                          const std::vector<double>& texture, const RutGeometry& geometry,
                          const WaterlineConfig& config, WaterlineWorkspace& ws) {
  LevelSpan out;
  const int n = static_cast<int>(section.z_mm.size());
  if (!config.enabled || !config.lid_check || !geometry.has_line || !geometry.has_rut || n < 8 || !(section.dx_mm > 0))
    return out;
  const double dx = section.dx_mm;
  const double m = geometry.line_m, c = geometry.line_c, norm = std::sqrt(1.0 + m * m);
  const auto x_of = [&](int i) { return section.x0_mm + dx * i; };
  ws.z.assign(static_cast<std::size_t>(n), kNaN);
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (!std::isnan(section.z_mm[k])) ws.z[k] = (section.z_mm[k] - (m * x_of(i) + c)) / norm;
  }
  const int lo = std::max(0, static_cast<int>(std::ceil((geometry.left_x_mm - section.x0_mm) / dx)));
  const int hi = std::min(n - 1, static_cast<int>(std::floor((geometry.right_x_mm - section.x0_mm) / dx)));
  const int deepest = static_cast<int>(std::lround((geometry.deepest_x_mm - section.x0_mm) / dx));
  if (hi - lo < 8 || deepest < lo || deepest > hi) return out;
  out.ground_roughness_mm = bin_scatter(
      ws.z, [&](int i) { return i < lo - 2 || i > hi + 2; }, ws.values);
  if (std::isnan(out.ground_roughness_mm)) return out;
  const double tol = std::max(config.lid_tolerance_mm, 3.0 * out.ground_roughness_mm);
  // Smoothed over three bins, so one noisy bin neither ends the span nor makes a crossing.
  ws.step.assign(static_cast<std::size_t>(n), kNaN);
  for (int i = 0; i < n; ++i) ws.step[static_cast<std::size_t>(i)] = window_mean(ws.z, i - 1, i + 1, 2);
  const std::vector<double>& zs = ws.step;
  const double bottom = window_mean(ws.z, deepest - 1, deepest + 1, 1);
  if (std::isnan(bottom)) return out;
  // The span: bins about the deepest within tol of its depth (gaps of up to two bins bridged).
  const auto extend = [&](int dir) {
    int last = deepest, gap = 0;
    for (int i = deepest + dir; i >= lo && i <= hi; i += dir) {
      const double v = zs[static_cast<std::size_t>(i)];
      if (std::isnan(v)) {
        if (++gap > 2) break;
        continue;
      }
      if (v < bottom - tol) break;
      gap = 0;
      last = i;
    }
    return last;
  };
  const int a = extend(-1), b = extend(+1);
  // Level and tilt: least squares over the span's valid bins.
  double sx = 0, sz = 0, sxx = 0, sxz = 0;
  int count = 0;
  for (int i = a; i <= b; ++i) {
    const double v = ws.z[static_cast<std::size_t>(i)];
    if (std::isnan(v)) continue;
    const double x = x_of(i);
    sx += x;
    sz += v;
    sxx += x * x;
    sxz += x * v;
    ++count;
  }
  if (count < 5) return out;
  const double den = count * sxx - sx * sx;
  out.tilt = den > 0 ? (count * sxz - sx * sz) / den : 0.0;
  out.level_mm = sz / count;
  out.left_x_mm = x_of(a);
  out.right_x_mm = x_of(b);
  out.roughness_mm = bin_scatter(
      ws.z, [&](int i) { return i >= a && i <= b; }, ws.values);
  // Brightness across each end of the span: w bins on the span against w bins on the wall beyond it,
  // against the same statistic's spread over the ground (find_waterline's threshold). Without the
  // brightness the threshold is NaN, and no test on it passes.
  out.step_threshold = kNaN;
  const int w = std::max(2, static_cast<int>(std::lround(config.step_window_mm / dx)));  // bins, both tests
  if (static_cast<int>(brightness.size()) == n) {
    const int need = (w + 1) / 2;
    ws.log_brightness.assign(static_cast<std::size_t>(n), kNaN);
    for (int i = 0; i < n; ++i)
      if (std::isfinite(brightness[static_cast<std::size_t>(i)]))
        ws.log_brightness[static_cast<std::size_t>(i)] =
            std::log(std::max(brightness[static_cast<std::size_t>(i)], 1.0));
    const auto& lb = ws.log_brightness;
    out.left_step = window_mean(lb, a, a + w - 1, need) - window_mean(lb, a - w, a - 1, need);
    out.right_step = window_mean(lb, b - w + 1, b, need) - window_mean(lb, b + 1, b + w, need);
    ws.values.clear();
    for (int i = 0; i + 1 < n; ++i) {
      if (!(i + w < lo || i - w > hi)) continue;
      const double st = window_mean(lb, i + 1, i + w, need) - window_mean(lb, i - w + 1, i, need);
      if (!std::isnan(st)) ws.values.push_back(std::abs(st));
    }
    const double spread = ws.values.size() >= 10
                              ? 1.4826 * detail::median_inplace(ws.values.data(), ws.values.data() + ws.values.size())
                              : kNaN;
    out.step_threshold = std::isnan(spread) ? kNaN : waterline_step_threshold(config, spread);
    // Against the flat ground outside the rut, which faces the light as a level span does: the median log
    // brightness of the ground bins within 1 mm of the ground line (piles and stones slope) on each side,
    // and of the two differences the smaller, zero unless both have one sign (a soil blotched on a larger
    // scale than the rut, mud's, is darker on one side than on the other).
    const double span = window_mean(lb, a, b, std::max(1, (b - a + 1) / 2));
    out.ground_step = smaller_same_sign(span - flat_ground_median(lb, ws.z, 0, lo - 3, ws.values),
                                        span - flat_ground_median(lb, ws.z, hi + 3, n - 1, ws.values));
  }
  // Texture (WaterlineConfig::lid_texture_step): the whole span's mean log texture against the wall
  // beyond each end (step_window_mm of it) and against the flat ground's median on each side.
  if (static_cast<int>(texture.size()) == n) {
    ws.log_texture.assign(static_cast<std::size_t>(n), kNaN);
    for (int i = 0; i < n; ++i) {
      const double t = texture[static_cast<std::size_t>(i)];
      if (t > 0.0 && std::isfinite(t)) ws.log_texture[static_cast<std::size_t>(i)] = std::log(t);
    }
    const auto& lt = ws.log_texture;
    const double span = window_mean(lt, a, b, std::max(1, (b - a + 1) / 2));
    // Two textured bins of a wall will do: a steep wall beside a lid is often matched only a few bins
    // down from it (foreshortened unlike in the two views, DIC loses the rest).
    out.texture_left_step = span - window_mean(lt, a - w, a - 1, 2);
    out.texture_right_step = span - window_mean(lt, b + 1, b + w, 2);
    out.texture_ground_step = smaller_same_sign(span - flat_ground_median(lt, ws.z, 0, lo - 3, ws.values),
                                                span - flat_ground_median(lt, ws.z, hi + 3, n - 1, ws.values));
  }
  const double edge = std::max(std::abs(out.left_step), std::abs(out.right_step));
  const bool level = (out.right_x_mm - out.left_x_mm) >= config.lid_min_width_mm &&
                     out.roughness_mm <= config.lid_roughness_ratio * out.ground_roughness_mm;
  out.found = level && edge >= config.lid_step_factor * out.step_threshold;
  out.unlike_ground = level && std::abs(out.ground_step) >= config.lid_ground_factor * out.step_threshold;
  // Unlike the soil on all three in one sense (NaN steps fail every comparison).
  const double walls = smaller_same_sign(out.texture_left_step, out.texture_right_step);
  const double all = smaller_same_sign(walls, out.texture_ground_step);
  out.other_material = level && config.lid_texture_step > 0.0 && std::abs(all) >= config.lid_texture_step;
  const double bright = smaller_same_sign(smaller_same_sign(out.left_step, out.right_step), out.ground_step);
  out.brighter_all_round =
      level && config.lid_bright_factor > 0.0 && bright >= config.lid_bright_factor * out.step_threshold;
  return out;
}

double share_seen_below(const CrossSection& section, const RutGeometry& geometry, const Waterline& line,
                        double margin_mm) {
  if (!geometry.has_line || !(section.dx_mm > 0)) return 0.0;
  const double m = geometry.line_m, c = geometry.line_c, norm = std::sqrt(1.0 + m * m);
  const int n = static_cast<int>(section.z_mm.size());
  const int from = std::max(0, static_cast<int>(std::ceil((line.left_x_mm - section.x0_mm) / section.dx_mm)));
  const int to = std::min(n - 1, static_cast<int>(std::floor((line.right_x_mm - section.x0_mm) / section.dx_mm)));
  int valid = 0, below = 0;
  for (int i = from; i <= to; ++i) {
    const double z = section.z_mm[static_cast<std::size_t>(i)];
    if (std::isnan(z)) continue;
    const double x = section.x0_mm + section.dx_mm * i;
    ++valid;
    below += (z - (m * x + c)) / norm > line.level_mm + margin_mm;
  }
  return valid > 0 ? double(below) / valid : 0.0;
}

void refract_section(const CrossSection& apparent, const RutGeometry& geometry, double level_mm, double n,
                     double baseline_mm, double y_mm, CrossSection& out, WaterlineWorkspace& ws) {
  out.x0_mm = apparent.x0_mm;
  out.dx_mm = apparent.dx_mm;
  out.z_mm = apparent.z_mm;
  out.count = apparent.count;
  const int bins = static_cast<int>(apparent.z_mm.size());
  const double m = geometry.line_m, norm = std::sqrt(1.0 + m * m);
  const cv::Vec3d normal(-m / norm, 0.0, 1.0 / norm);      // of the surface, pointing away from the cameras
  const double plane = geometry.line_c / norm + level_mm;  // normal . P on the surface
  const cv::Vec3d left_centre(0.0, 0.0, 0.0), right_centre(baseline_mm, 0.0, 0.0);
  const double eta = 1.0 / n;
  // Refracts the ray from `centre` towards the apparent point `a` at the surface: the point where it
  // enters and its direction in the water. False where it meets no surface before `a`.
  const auto bend = [&](const cv::Vec3d& centre, const cv::Vec3d& a, cv::Vec3d& entry, cv::Vec3d& dir) {
    cv::Vec3d v = a - centre;
    v /= cv::norm(v);
    const double along = normal.dot(v);
    if (!(along > 0.0)) return false;
    const double t = (plane - normal.dot(centre)) / along;
    if (!(t > 0.0)) return false;
    entry = centre + t * v;
    // Snell's law in vector form, the normal facing the incoming ray (-normal).
    const double cos_i = along;
    const double k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    if (k < 0.0) return false;
    dir = eta * v + (std::sqrt(k) - eta * cos_i) * normal;
    dir /= cv::norm(dir);
    return true;
  };
  ws.x.clear();
  ws.z.clear();
  bool any = false;
  for (int i = 0; i < bins; ++i) {
    const double z = apparent.z_mm[static_cast<std::size_t>(i)];
    if (std::isnan(z)) continue;
    const double x = apparent.x0_mm + apparent.dx_mm * i;
    const cv::Vec3d a(x, y_mm, z);
    cv::Vec3d el, dl, er, dr;
    if (normal.dot(a) <= plane || !bend(left_centre, a, el, dl) || !bend(right_centre, a, er, dr)) {
      ws.x.push_back(x);
      ws.z.push_back(z);
      continue;
    }
    // Closest approach of el + s dl and er + t dr: the midpoint of the shortest segment between them.
    const cv::Vec3d w0 = el - er;
    const double b = dl.dot(dr), d = dl.dot(w0), e = dr.dot(w0);
    const double den = 1.0 - b * b;
    if (!(den > 1e-12)) {
      ws.x.push_back(x);
      ws.z.push_back(z);
      continue;
    }
    const double s = (b * e - d) / den, t = (e - b * d) / den;
    const cv::Vec3d p = 0.5 * ((el + s * dl) + (er + t * dr));
    ws.x.push_back(p[0]);
    ws.z.push_back(p[2]);
    any = true;
  }
  if (!any) return;
  // Resample onto the grid: each valid bin takes the corrected profile at its X, linear between the
  // corrected points that bracket it (in their order along the section); NaN where none does.
  const std::size_t count = ws.x.size();
  std::size_t j = 0;
  for (int i = 0; i < bins; ++i) {
    auto& z = out.z_mm[static_cast<std::size_t>(i)];
    if (std::isnan(apparent.z_mm[static_cast<std::size_t>(i)])) continue;
    const double x = apparent.x0_mm + apparent.dx_mm * i;
    while (j + 1 < count && ws.x[j + 1] < x) ++j;
    z = kNaN;
    for (std::size_t k = j; k + 1 < count && k <= j + 1; ++k) {
      const double x0 = ws.x[k], x1 = ws.x[k + 1];
      if (x0 <= x && x <= x1 && x1 > x0) {
        z = ws.z[k] + (ws.z[k + 1] - ws.z[k]) * (x - x0) / (x1 - x0);
        break;
      }
    }
    if (std::isnan(z) && count == 1) z = ws.z[0];
  }
}

}  // namespace rutd
