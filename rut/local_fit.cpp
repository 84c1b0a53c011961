#include "local_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace rutd::detail {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Normal equations of a parabola y = a + b t + c t^2 in a local coordinate t (bins).
struct QuadSums {
  double s[5] = {0, 0, 0, 0, 0};  // sum t^k
  double y[3] = {0, 0, 0};        // sum y t^k
  double yy = 0.0;                // sum y^2
  int n = 0;

  void add(double t, double v) {
    const double t2 = t * t;
    s[0] += 1.0;
    s[1] += t;
    s[2] += t2;
    s[3] += t2 * t;
    s[4] += t2 * t2;
    y[0] += v;
    y[1] += v * t;
    y[2] += v * t2;
    yy += v * v;
    ++n;
  }
  Eigen::Matrix3d normal() const {
    Eigen::Matrix3d a;
    a << s[0], s[1], s[2], s[1], s[2], s[3], s[2], s[3], s[4];
    return a;
  }
  // Returns false when the points do not determine a parabola (fewer than 3 distinct t). Closed-form
  // inverse of the symmetric 3x3 system: this runs once per bin per frame.
  bool solve(Eigen::Vector3d& coef, Eigen::Matrix3d* inverse = nullptr) const {
    if (n < 3) return false;
    const double c00 = s[2] * s[4] - s[3] * s[3];
    const double c01 = s[2] * s[3] - s[1] * s[4];
    const double c02 = s[1] * s[3] - s[2] * s[2];
    const double c11 = s[0] * s[4] - s[2] * s[2];
    const double c12 = s[1] * s[2] - s[0] * s[3];
    const double c22 = s[0] * s[2] - s[1] * s[1];
    const double det = s[0] * c00 + s[1] * c01 + s[2] * c02;
    if (!(det > 1e-9 * s[0] * s[2] * s[4])) return false;  // collinear in t: fewer than 3 distinct
    Eigen::Matrix3d inv;
    inv << c00, c01, c02, c01, c11, c12, c02, c12, c22;
    inv /= det;
    coef = inv * Eigen::Vector3d(y[0], y[1], y[2]);
    if (inverse) *inverse = inv;
    return true;
  }
  double rss(const Eigen::Vector3d& coef) const {
    // sum (y - A coef)^2 = yy - 2 coef.b + coef' A coef, clamped against round-off.
    const Eigen::Vector3d b(y[0], y[1], y[2]);
    return std::max(0.0, yy - 2.0 * coef.dot(b) + coef.dot(normal() * coef));
  }
};

}  // namespace

void sliding_quadratic(const std::vector<double>& z, double dx, int half, int min_count, std::vector<double>& value,
                       std::vector<double>& slope) {
  const int n = static_cast<int>(z.size());
  value.assign(n, kNaN);
  slope.assign(n, kNaN);
  for (int i = 0; i < n; ++i) {
    QuadSums q;
    const int lo = std::max(0, i - half);
    const int hi = std::min(n - 1, i + half);
    for (int j = lo; j <= hi; ++j) {
      if (!std::isnan(z[j])) q.add(double(j - i), z[j]);
    }
    Eigen::Vector3d coef;
    if (q.n < min_count || !q.solve(coef)) continue;
    value[i] = coef[0];
    slope[i] = coef[1] / dx;
  }
}

double centre_leverage(int half) {
  const double n = 2.0 * half + 1.0;
  return 3.0 * (3.0 * n * n - 7.0) / (4.0 * n * (n * n - 4.0));
}

double median_inplace(double* first, double* last) {
  const long n = last - first;
  if (n <= 0) return kNaN;
  double* mid = first + n / 2;
  std::nth_element(first, mid, last);
  if (n % 2 == 1) return *mid;
  return 0.5 * (*mid + *std::max_element(first, mid));
}

double noise_sigma(const std::vector<double>& raw, const std::vector<double>& fit, double leverage,
                   std::vector<double>& scratch) {
  scratch.clear();
  for (std::size_t i = 0; i < raw.size(); ++i) {
    if (!std::isnan(raw[i]) && !std::isnan(fit[i])) scratch.push_back(std::abs(raw[i] - fit[i]));
  }
  if (scratch.empty()) return 0.0;
  const double mad = median_inplace(scratch.data(), scratch.data() + scratch.size());
  // A residual of a fit that includes the sample has variance sigma^2 (1 - leverage).
  return 1.4826 * mad / std::sqrt(std::max(1e-6, 1.0 - leverage));
}

namespace {

// Weighted least-squares line; false when degenerate.
bool weighted_line(const double* x, const double* z, const double* w, int n, Line& line) {
  double sw = 0, sx = 0, sz = 0;
  for (int i = 0; i < n; ++i) {
    sw += w[i];
    sx += w[i] * x[i];
    sz += w[i] * z[i];
  }
  if (sw <= 0.0) return false;
  const double mx = sx / sw;
  const double mz = sz / sw;
  double sxx = 0, sxz = 0;
  for (int i = 0; i < n; ++i) {
    sxx += w[i] * (x[i] - mx) * (x[i] - mx);
    sxz += w[i] * (x[i] - mx) * (z[i] - mz);
  }
  if (sxx <= 1e-12 * sw) return false;
  line.m = sxz / sxx;
  line.c = mz - line.m * mx;
  return true;
}

}  // namespace

bool fit_line_robust(const double* x, const double* z, int n, std::vector<double>& scratch, Line& line) {
  if (n < 2) return false;
  scratch.assign(2 * static_cast<std::size_t>(n), 1.0);
  double* w = scratch.data();
  double* r = scratch.data() + n;
  if (!weighted_line(x, z, w, n, line)) return false;
  // Floor on the scale: noise-free data would otherwise reject everything but exact points.
  constexpr double kMinScale = 0.02;  // mm
  constexpr double kTukey = 4.685;
  double scale = 0.0;
  for (int iter = 0; iter < 8; ++iter) {
    for (int i = 0; i < n; ++i) r[i] = std::abs(z[i] - line.m * x[i] - line.c);
    // The median needs a reorderable copy; the weights are recomputed below anyway.
    std::copy(r, r + n, w);
    scale = std::max(kMinScale, 1.4826 * median_inplace(w, w + n));
    const double cut = kTukey * scale;
    for (int i = 0; i < n; ++i) {
      const double u = r[i] / cut;
      w[i] = u < 1.0 ? (1.0 - u * u) * (1.0 - u * u) : 0.0;
    }
    Line next = line;
    if (!weighted_line(x, z, w, n, next)) break;
    const bool converged = std::abs(next.m - line.m) < 1e-9 && std::abs(next.c - line.c) < 1e-6;
    line = next;
    if (converged) break;
  }
  line.scale = scale;
  return true;
}

double refine_max(const std::vector<double>& h_raw, const std::vector<double>& h_fit, int k, double delta, int min_half,
                  int lo, int hi, double min_t, double* overshoot) {
  if (overshoot) *overshoot = 0.0;
  const double top = h_fit[k];
  // Bins without a fit (near gaps) are judged by their raw sample, with the raw noise allowed for.
  auto inside = [&](int j) {
    if (!std::isnan(h_fit[j])) return h_fit[j] >= top - delta;
    return std::isnan(h_raw[j]) || h_raw[j] >= top - 2.0 * delta;
  };
  int a = k;
  while (a - 1 >= lo && (inside(a - 1) || k - (a - 1) <= min_half)) --a;
  int b = k;
  while (b + 1 <= hi && (inside(b + 1) || (b + 1) - k <= min_half)) ++b;

  QuadSums q;
  int first = b + 1, last = a - 1;  // the samples' extent: the region may run on across a gap
  double highest = -std::numeric_limits<double>::infinity();
  for (int j = a; j <= b; ++j) {
    if (std::isnan(h_raw[j])) continue;
    q.add(double(j - k), h_raw[j]);
    first = std::min(first, j);
    last = std::max(last, j);
    highest = std::max(highest, h_raw[j]);
  }
  Eigen::Vector3d coef;
  Eigen::Matrix3d inv;
  if (!q.solve(coef, &inv)) return q.n > 0 ? q.y[0] / q.s[0] : top;
  const double dof = q.n - 3;
  const double var = dof > 0 ? q.rss(coef) / dof : 0.0;
  const double curvature_sigma = std::sqrt(std::max(0.0, var * inv(2, 2)));
  if (coef[2] < 0.0 && -coef[2] > min_t * curvature_sigma) {
    // The vertex within the samples: carried into a gap beyond them, the parabola is no measurement (a
    // wall's last bins curving off at a gap's edge once put the bottom 54 mm below anything seen).
    // Nor above every sample: across a gap, a parabola through a wall's foot on one side and a bottom
    // on the other overshoots both (measured: 91 mm from samples no deeper than 70, published OK).
    const double t = std::clamp(-coef[1] / (2.0 * coef[2]), double(first - k), double(last - k));
    const double vertex = coef[0] + coef[1] * t + coef[2] * t * t;
    if (overshoot) *overshoot = std::max(0.0, vertex - highest);
    return std::min(vertex, highest);
  }
  return q.y[0] / q.s[0];
}

}  // namespace rutd::detail
