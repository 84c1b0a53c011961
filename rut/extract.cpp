// extract_rut: the seed method of DESIGN.md §5 in mm units, made robust to noise, gaps, roll and a
// missing pile. Steps:
//  1. Sliding parabola fit over fit_window_mm: smoothed Z and dZ/dX per bin; per-bin noise from the
//     fit residuals.
//  2. Reference profile: a line with the median local slope through the 40th percentile of the
//     detrended profile, so neither the rut nor the piles pull it (the mean profile of the paper would
//     be dragged into a large rut and tilted by an off-centre one).
//  3. Rut and piles relative to the current line: the deepest smoothed point of the bins measured is
//     the rut bottom; walking outwards from it to the ground-line crossings (the rut opening) and on
//     over the pile (the Z minimum, i.e. the turning point closest to the camera) down to its outer
//     foot (where it meets the line or stops descending) gives the disturbed zone. A side without a
//     pile simply ends at the crossing.
//  4. Ground line: robust (Tukey) line fit to low-gradient bins outside the disturbed zone. Steps 3-4
//     run twice, the second time from the fitted line.
//  5. Figures per core/rut_measurement.hpp, from fits rather than extreme samples where noise would bias
//     them: depth and pile heights from parabola / flat fits around the extreme (detail::refine_max),
//     crossings from the smoothed profile, area by trapezoids over the raw bins.
#include "rut/extract.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "local_fit.hpp"

namespace rutd {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;
// Smallest tolerance (mm) used to delimit an extreme or a pile when the data are noise-free.
constexpr double kMinDelta = 0.2;
// Look-ahead threshold floor (mm) of the pile walk.
constexpr double kMinStep = 0.5;

struct Grid {
  double x0;
  double dx;
  int n;
  double x(int i) const { return x0 + dx * i; }
};

// Everything derived from the section once, before any line is fitted.
struct Profile {
  Grid grid;
  int half = 0;            // half window of the sliding fit, bins
  double sigma = 0.0;      // per-bin noise, mm
  double sigma_fit = 0.0;  // noise of a smoothed value, mm
  double slope_noise = 0.0;
};

struct Opening {
  double left_x = 0.0, right_x = 0.0;  // crossings of the ground line
  int left_bin = 0, right_bin = 0;     // first bin at or beyond each crossing (or the data edge)
  bool left_edge = false, right_edge = false;
};

// h = signed distance above the line (towards the camera), mm.
void heights(const std::vector<double>& z, const Grid& g, const detail::Line& line, std::vector<double>& h) {
  const double inv_norm = 1.0 / std::sqrt(1.0 + line.m * line.m);
  h.resize(z.size());
  for (int i = 0; i < g.n; ++i) h[i] = (line.m * g.x(i) + line.c - z[i]) * inv_norm;
}

int argmin_valid(const std::vector<double>& h, int lo, int hi) {
  int best = -1;
  for (int i = lo; i <= hi; ++i) {
    if (!std::isnan(h[i]) && (best < 0 || h[i] < h[best])) best = i;
  }
  return best;
}

int argmax_valid(const std::vector<double>& h, int lo, int hi) {
  int best = -1;
  for (int i = lo; i <= hi; ++i) {
    if (!std::isnan(h[i]) && (best < 0 || h[i] > h[best])) best = i;
  }
  return best;
}

// Walks from the bottom bin k in direction dir (-1/+1) to where h rises to the line (h >= 0),
// interpolating the crossing linearly between the bins around it; NaN bins are stepped over.
// Where the data end first, the wall may still have come up to the ground: ground a little below a
// line that leans on the other side's ground (a crowned track, a line fitted to one side first) never
// reaches h >= 0. The crossing is then where the profile rises to within tau of the line and stays
// there, at least min_run valid bins to the data's end: a flat run at the line's level is ground, the
// wall ended before it. Only a profile still below the line by more than tau at the edge (a wall cut
// off by the view, or too little ground beyond it) is at the edge.
void find_crossing(const std::vector<double>& h, const Grid& g, int k, int dir, double tau, int min_run, double& x,
                   int& bin, bool& at_edge) {
  int last = k;
  for (int j = k + dir; j >= 0 && j < g.n; j += dir) {
    if (std::isnan(h[j])) continue;
    if (h[j] >= 0.0) {
      const double t = h[last] / (h[last] - h[j]);  // h[last] < 0 <= h[j]
      x = g.x(last) + t * (g.x(j) - g.x(last));
      bin = j;
      at_edge = false;
      return;
    }
    last = j;
  }
  x = g.x(last);
  bin = last;
  at_edge = true;
  // Walking back in from the data edge: the run of valid bins within tau of the line, and the deeper
  // bin that ends it.
  int run = 0, start = -1, below = -1;
  for (int j = last; j != k; j -= dir) {
    if (std::isnan(h[j])) continue;
    if (h[j] < -tau) {
      below = j;
      break;
    }
    start = j;
    ++run;
  }
  if (run < min_run || below < 0) return;
  const double t = (h[below] + tau) / (h[below] - h[start]);  // h[below] < -tau <= h[start]
  x = g.x(below) + t * (g.x(start) - g.x(below));
  bin = start;
  at_edge = false;
}

// The opening's crossings (find_crossing) with its tolerance for ground below the line: 3 % of the depth
// at k, at least the pile walk's step (kMinStep, 5 smoothed noise sigmas), over a run of a fit window.
Opening find_opening(const std::vector<double>& h, const Grid& g, int k, const Profile& p) {
  const double tau = std::max({kMinStep, 5.0 * p.sigma_fit, -0.03 * h[k]});
  const int min_run = 2 * p.half;
  Opening o;
  find_crossing(h, g, k, -1, tau, min_run, o.left_x, o.left_bin, o.left_edge);
  find_crossing(h, g, k, +1, tau, min_run, o.right_x, o.right_bin, o.right_edge);
  return o;
}

// True if a valid bin within `look` bins beyond j (direction dir) is above (sign +1) or below
// (sign -1) h[j] by more than tau.
bool ahead_exceeds(const std::vector<double>& h, int j, int dir, int look, double tau, int sign) {
  for (int l = j + dir, steps = 0; steps < look && l >= 0 && l < int(h.size()); l += dir, ++steps) {
    if (!std::isnan(h[l]) && sign * (h[l] - h[j]) > tau) return true;
  }
  return false;
}

int next_valid(const std::vector<double>& h, int j, int dir) {
  for (int l = j + dir; l >= 0 && l < int(h.size()); l += dir) {
    if (!std::isnan(h[l])) return l;
  }
  return -1;
}

// From the opening's bin, climbs the pile while the profile ahead still rises by more than tau, then
// descends to the pile's outer foot: while the profile ahead still falls by more than tau, the profile
// is still above the line by more than tau, and - once below half the pile's top - still falls faster
// than ground can slope (descent rate dir * (slope - m) of the local fit above grad_max). The look-ahead
// alone would walk on over ground whose line is still tilted (first pass) or whose last bins drift at
// the data edge, claiming all the ground of a narrow view; the ground is where the pile has come down
// to the line or has stopped descending. Without a pile both walks stop at once. Returns the foot bin,
// or -1 if the walk ran off the data.
int pile_foot(const std::vector<double>& h, const std::vector<double>& slope, double m, double grad_max, int start,
              int dir, int look, double tau) {
  int j = std::isnan(h[start]) ? next_valid(h, start, dir) : start;
  while (j >= 0 && ahead_exceeds(h, j, dir, look, tau, +1)) j = next_valid(h, j, dir);
  const double top = j >= 0 ? h[j] : 0.0;
  while (j >= 0 && h[j] > tau && ahead_exceeds(h, j, dir, look, tau, -1)) {
    const bool flat = !std::isnan(slope[j]) && dir * (slope[j] - m) < grad_max;
    if (flat && h[j] < 0.5 * top) break;
    j = next_valid(h, j, dir);
  }
  return j;
}

struct Zone {
  int lo = 0, hi = 0;  // disturbed bins (inclusive); ground lies outside
  bool ground_left = false, ground_right = false;
};

// Bins a gradient must stay below to count as ground (dimensionless); see RutConfig.
double ground_gradient(const RutConfig& params, const Profile& p) {
  return std::max(params.ground_gradient_max, 4.0 * p.slope_noise);
}

Zone disturbed_zone(const RutWorkspace& ws, const detail::Line& line, const Opening& o, const Profile& p,
                    double grad_max) {
  const double tau = std::max(kMinStep, 5.0 * p.sigma_fit);
  const int look = 2 * p.half;
  Zone z;
  const int left_foot = o.left_edge ? -1 : pile_foot(ws.h_fit, ws.slope, line.m, grad_max, o.left_bin, -1, look, tau);
  const int right_foot =
      o.right_edge ? -1 : pile_foot(ws.h_fit, ws.slope, line.m, grad_max, o.right_bin, +1, look, tau);
  // No margin beyond the feet: the walk stops only where the local fit (which reaches half a window
  // inwards) has flattened or come down to the line, and fit_ground drops every bin whose local fit
  // still sees the flank (gradient test), so a margin of half a window would only discard the ground
  // a narrow view has.
  z.lo = left_foot < 0 ? 0 : left_foot;
  z.hi = right_foot < 0 ? p.grid.n - 1 : right_foot;
  z.ground_left = left_foot >= 0 && z.lo > 0;
  z.ground_right = right_foot >= 0 && z.hi < p.grid.n - 1;
  return z;
}

// Robust ground line through low-gradient bins outside the zone. Updates line; false if there is
// too little ground (the caller reports NoGround).
bool fit_ground(const CrossSection& s, const Profile& p, const Zone& zone, const RutConfig& params, RutWorkspace& ws,
                detail::Line& line, Zone& used) {
  const double grad_max = ground_gradient(params, p);
  ws.a.clear();
  ws.b.clear();
  int left = 0, right = 0;
  for (int i = 0; i < p.grid.n; ++i) {
    if (i >= zone.lo && i <= zone.hi) continue;
    if (std::isnan(s.z_mm[i]) || std::isnan(ws.slope[i])) continue;
    if (std::abs(ws.slope[i] - line.m) > grad_max) continue;
    ws.a.push_back(p.grid.x(i));
    ws.b.push_back(s.z_mm[i]);
    (i < zone.lo ? left : right) += 1;
  }
  used = zone;
  used.ground_left = left > 0;
  used.ground_right = right > 0;
  const bool enough_in_all = double(left + right) * p.grid.dx >= params.min_ground_mm;
  const bool enough_each_side = double(std::min(left, right)) * p.grid.dx >= params.min_ground_each_side_mm;
  if (!enough_in_all && !enough_each_side) return false;
  return detail::fit_line_robust(ws.a.data(), ws.b.data(), int(ws.a.size()), ws.c, line);
}

// Step 2: median slope, 40th percentile level (see the file comment).
detail::Line reference_line(const Profile& p, RutWorkspace& ws) {
  detail::Line line;
  ws.a.clear();
  for (double d : ws.slope) {
    if (!std::isnan(d)) ws.a.push_back(d);
  }
  line.m = detail::median_inplace(ws.a.data(), ws.a.data() + ws.a.size());
  ws.a.clear();
  for (int i = 0; i < p.grid.n; ++i) {
    if (!std::isnan(ws.smooth[i])) ws.a.push_back(ws.smooth[i] - line.m * p.grid.x(i));
  }
  auto nth = ws.a.begin() + static_cast<long>(0.4 * double(ws.a.size()));
  std::nth_element(ws.a.begin(), nth, ws.a.end());
  line.c = *nth;
  return line;
}

// Nearest valid slope from bin i walking in direction dir, at most `reach` bins; NaN if none.
double nearest_slope(const std::vector<double>& slope, int i, int dir, int reach) {
  for (int j = i, steps = 0; steps <= reach && j >= 0 && j < int(slope.size()); j += dir, ++steps) {
    if (!std::isnan(slope[j])) return slope[j];
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// Area below the line between the crossings: integral of (Z - m X - c) dX = norm * integral of -h
// over the raw bins by trapezoids, h = 0 at both crossings. A gap is bridged by the cubic Hermite
// through the values and fitted slopes at its ends (trapezoid plus an end-slope correction), so a
// hole on a curved wall follows the curve rather than its chord; linearly if no slope is known.
double area_below(const std::vector<double>& h_raw, const std::vector<double>& slope, double m, const Grid& g,
                  const Opening& o, double norm, int reach) {
  double area = 0.0;
  double px = o.left_x, pv = o.left_edge ? kNaN : 0.0;
  int pi = -1;
  for (int i = 0; i < g.n; ++i) {
    const double x = g.x(i);
    if (x <= o.left_x || x >= o.right_x || std::isnan(h_raw[i])) continue;
    const double v = -h_raw[i];
    if (!std::isnan(pv)) {
      const double len = x - px;
      area += 0.5 * len * (pv + v);
      if (pi >= 0 && i - pi > 1) {
        // d(-h)/dX = (dZ/dX - m) / norm at both ends of the gap.
        const double d0 = (nearest_slope(slope, pi, -1, reach) - m) / norm;
        const double d1 = (nearest_slope(slope, i, +1, reach) - m) / norm;
        if (!std::isnan(d0) && !std::isnan(d1)) area += len * len * (d0 - d1) / 12.0;
      }
    }
    px = x;
    pv = v;
    pi = i;
  }
  if (!o.right_edge && !std::isnan(pv)) area += 0.5 * (o.right_x - px) * pv;
  return area * norm;
}

// Largest height on one side of the opening (bins [lo, hi]), 0 when below the detection floor.
double pile_height(const RutWorkspace& ws, const Profile& p, const RutConfig& params, int lo, int hi) {
  if (lo > hi) return 0.0;
  const int k = argmax_valid(ws.h_fit, lo, hi);
  if (k < 0) return 0.0;
  const double floor = std::max(params.min_pile_mm, 5.0 * p.sigma_fit);
  if (ws.h_fit[k] < floor) return 0.0;
  const double delta = std::max({kMinDelta, 5.0 * p.sigma_fit, 0.1 * ws.h_fit[k]});
  const double height = detail::refine_max(ws.h_raw, ws.h_fit, k, delta, 2, lo, hi, 0.0);
  return height >= floor ? height : 0.0;
}

// Standard error (mm) of the robust ground line at x: residual scatter of the ground bins (xs, zs: the
// last fit's inputs) about the line, propagated as for least squares, the slope's share (carried from
// the bins' mean to x) times `inflation` for noise correlated from bin to bin. 0 with fewer than 3 bins.
double line_error_at(const std::vector<double>& xs, const std::vector<double>& zs, const detail::Line& line, double x,
                     std::vector<double>& scratch, double inflation) {
  const std::size_t n = std::min(xs.size(), zs.size());
  if (n < 3) return 0.0;
  double mean = 0.0;
  for (std::size_t i = 0; i < n; ++i) mean += xs[i];
  mean /= double(n);
  double sxx = 0.0;
  scratch.clear();
  for (std::size_t i = 0; i < n; ++i) {
    sxx += (xs[i] - mean) * (xs[i] - mean);
    scratch.push_back(std::abs(zs[i] - (line.m * xs[i] + line.c)));
  }
  const double sigma = 1.4826 * detail::median_inplace(scratch.data(), scratch.data() + scratch.size());
  const double lever = sxx > 0.0 ? (x - mean) * (x - mean) / sxx : 0.0;
  return sigma * std::sqrt(1.0 / double(n) + inflation * inflation * lever) / std::sqrt(1.0 + line.m * line.m);
}

// The selection term of the uncertainty (see extract.hpp): the deepest smoothed bin, chosen within
// `reach` bins of a gap (NaN raw bins), rests on a one-sided fit beside pixels the matcher lost, where
// the matching windows that did match straddle them and read the surface off (measured: bins at a gap's
// edge in a mud rut's flat bottom 0.5-1 mm deep, the depth taken there 0.83 mm off with an uncertainty
// of 0.04 mm). The other hypothesis is read at the bin this returns: the deepest smoothed bin of the
// opening with no gap within `reach`; -1 where `k` is clear of gaps itself, or no bin of the opening is.
int deepest_bin_clear_of_gaps(const RutWorkspace& ws, const Opening& o, int k, int reach) {
  const int n = static_cast<int>(ws.h_raw.size());
  const auto near_gap = [&](int i) {
    for (int j = std::max(0, i - reach); j <= std::min(n - 1, i + reach); ++j)
      if (std::isnan(ws.h_raw[j])) return true;
    return false;
  };
  if (!near_gap(k)) return -1;
  int clear = -1;
  for (int i = std::max(0, o.left_bin); i <= std::min(n - 1, o.right_bin); ++i)
    if (!std::isnan(ws.h_fit[i]) && !near_gap(i) && (clear < 0 || ws.h_fit[i] < ws.h_fit[clear])) clear = i;
  return clear;
}

// The coverage term of the uncertainty (see extract.hpp): for every gap of NaN bins inside the opening,
// how much deeper than `depth` the profile could reach unseen. Walking into the gap from each edge, the
// profile may go on down at that edge's smoothed slope. Where the two edges' tangents meet inside the
// gap, the deepest profile they allow is their V, at depth (r_l d_r + r_r d_l + r_l r_r w) / (r_l + r_r)
// (edge depths d, descent rates r >= 0, gap width w): a rut's profile below its shoulders is a bowl,
// which lies above its tangents, and a level edge is one leg (a level bottom beside a wall lost from its
// middle down hides nothing below the bottom). A gentler edge shallower than the bottom by more than
// `bottom_band` (the deepest region's width, mm) may be a shoulder, a level lip or a wall's upper half,
// whose slope steepens below it: unless it lies deeper than the steeper edge's face reaches in half the
// gap, it takes that edge's rate, blended in over one more band so that the bound moves continuously
// with the edges (a rut whose near wall and bottom are lost below a level lip reaches as deep as the far
// wall's slope takes it, not the far edge's depth). Where the tangents meet beyond the gap, the
// shallower edge's tangent passes above the deeper edge: the deeper edge bounds the gap where it is no
// steeper than the other (a bottom beside a wall lost near its top) or lies on a bottom (below); else
// each edge is taken down at its rate for half the width (a symmetric V). An edge's descent rate is the
// steepest within `reach` bins of it: the last bins before a gap bend (a shore's edge matches at the
// water's level, the fits there extrapolate), the wall above them does not. The largest excess, mm.
double unseen_excess(const std::vector<double>& h_fit, const std::vector<double>& slope, double m, const Grid& g,
                     const Opening& o, double depth, double bottom_band, double norm, int reach_bins) {
  // Steepest descent below the line (mm per mm) walking in direction dir over bins [from, from + dir
  // reach_bins]; 0 if none descends.
  const auto descent = [&](int from, int dir) {
    double rate = 0.0;
    for (int j = from, k = 0; k <= reach_bins && j >= 0 && j < int(slope.size()); j -= dir, ++k) {
      if (!std::isnan(slope[j])) rate = std::max(rate, dir * (slope[j] - m) / norm);
    }
    return rate;
  };
  double worst = 0.0;
  int last = -1;
  for (int i = o.left_bin; i <= o.right_bin; ++i) {
    if (std::isnan(h_fit[i])) continue;
    if (last >= 0 && i - last > 1) {
      const double width = (i - last) * g.dx;
      // Descent rates below the line walking into the gap from each side.
      double rl = descent(last, +1);
      double rr = descent(i, -1);
      const double dl = -h_fit[last], dr = -h_fit[i];
      // Beyond the gap (below), the edges' own rates say which is the steeper, and the profile away
      // from the gap whether the deeper edge lies on the bottom: two reaches away it is still at least
      // half as deep and has risen less than half what the edge's descent rate gives (a one-sided fit
      // at a bottom's edge curls down into the gap; a wall's face goes on rising at its slope).
      const bool deeper_gentler = dl >= dr ? rl <= rr : rr <= rl;
      const int deep_edge = dl >= dr ? last : i;
      const int away = deep_edge + (dl >= dr ? -1 : +1) * 2 * reach_bins;
      const double d_deep = std::max(dl, dr), r_deep = dl >= dr ? rl : rr;
      const double d_away =
          away >= 0 && away < int(h_fit.size()) ? -h_fit[away] : std::numeric_limits<double>::quiet_NaN();
      const bool deeper_on_bottom = d_away >= 0.5 * d_deep && d_deep - d_away < 0.5 * r_deep * 2 * reach_bins * g.dx;
      // A gentler edge above the bottom takes the steeper edge's rate (above), in full from two bands up.
      double& gentle = rl < rr ? rl : rr;
      const double steep = std::max(rl, rr);
      const double d_gentle = rl < rr ? dl : dr, d_steep = rl < rr ? dr : dl;
      if (steep > 0.0) {
        const double shoulder = std::clamp((depth - d_gentle) / bottom_band - 1.0, 0.0, 1.0);
        const double above = std::clamp(1.0 - (d_gentle - d_steep) / (0.5 * width * steep), 0.0, 1.0);
        gentle += shoulder * above * (steep - gentle);
      }
      // Where the tangents meet, from the left edge (NaN when both are level).
      const double x = rl + rr > 0.0 ? (dr - dl + rr * width) / (rl + rr) : std::numeric_limits<double>::quiet_NaN();
      // Beyond the gap: bounded by the deeper edge, or each edge half the width down (above).
      const double reach = x >= 0.0 && x <= width ? dl + rl * x
                           : deeper_gentler || deeper_on_bottom
                               ? std::max(dl, dr)
                               : std::max(dl + 0.5 * width * rl, dr + 0.5 * width * rr);
      worst = std::max(worst, reach - depth);
    }
    last = i;
  }
  return std::max(0.0, worst);
}

// The gap bound of unseen_excess where a second reading of the strip (wider matching windows) covers
// the gaps: h_fill are its smoothed heights above the line on the section's grid, offset to the
// section's (fill_heights; NaN where it has none), tol the scatter of their difference to the section's.
// A gap it covers but for runs of at most reach_bins (which its smoothing bridges) is bounded by the
// deepest of its bins there, plus tol; one it does not cover keeps the walls' bound. Returns the excess
// over `depth`, mm (>= 0).
double unseen_excess_filled(const std::vector<double>& h_fit, const std::vector<double>& slope, double m, const Grid& g,
                            const Opening& o, double depth, double bottom_band, double norm, int reach_bins,
                            const std::vector<double>& h_fill, double tol) {
  double worst = 0.0;
  int last = -1;
  for (int i = o.left_bin; i <= o.right_bin; ++i) {
    if (std::isnan(h_fit[i])) continue;
    if (last >= 0 && i - last > 1) {
      double deepest = -std::numeric_limits<double>::infinity();
      int run = 0, longest = 0;
      for (int j = last + 1; j < i; ++j) {
        if (std::isnan(h_fill[j])) {
          longest = std::max(longest, ++run);
        } else {
          run = 0;
          deepest = std::max(deepest, -h_fill[j]);
        }
      }
      if (longest <= reach_bins && std::isfinite(deepest)) {
        worst = std::max(worst, deepest + tol - depth);
      } else {
        // Not covered: the walls' bound of this gap alone (a section of the two bins around it).
        Opening gap = o;
        gap.left_bin = last;
        gap.right_bin = i;
        worst = std::max(worst, unseen_excess(h_fit, slope, m, g, gap, depth, bottom_band, norm, reach_bins));
      }
    }
    last = i;
  }
  return std::max(0.0, worst);
}

// gap_fill smoothed as the section is (sliding_quadratic over the fit window), as heights above `line` on
// the section's grid into h (NaN where it has none), less their median difference to the section's
// smoothed ones (h_fit) over the bins both measured; returns the scatter (1.4826 MAD) of that
// difference, or NaN with fewer than kMinOverlapBins such bins. z, slope and scratch are overwritten.
double fill_heights(const CrossSection& section, const CrossSection& fill, const Profile& p, const detail::Line& line,
                    const std::vector<double>& h_fit, std::vector<double>& z, std::vector<double>& slope,
                    std::vector<double>& h, std::vector<double>& scratch) {
  constexpr std::size_t kMinOverlapBins = 16;
  const Grid& g = p.grid;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  z.assign(static_cast<std::size_t>(g.n), nan);
  h.assign(static_cast<std::size_t>(g.n), nan);
  scratch.clear();
  if (!(std::abs(fill.dx_mm - g.dx) < 1e-9)) return nan;
  const long offset = std::lround((fill.x0_mm - g.x0) / g.dx);  // section bin of fill's bin 0
  for (int i = 0; i < g.n; ++i) {
    const long k = i - offset;
    if (k >= 0 && k < static_cast<long>(fill.z_mm.size())) z[i] = fill.z_mm[static_cast<std::size_t>(k)];
  }
  detail::sliding_quadratic(z, g.dx, p.half, p.half + 1, h, slope);
  const double inv_norm = 1.0 / std::sqrt(1.0 + line.m * line.m);
  for (int i = 0; i < g.n; ++i) {
    if (std::isnan(z[i])) h[i] = nan;  // a value the fit carried into a bin fill did not measure
    if (std::isnan(h[i])) continue;
    h[i] = (line.m * g.x(i) + line.c - h[i]) * inv_norm;
    if (!std::isnan(h_fit[i]) && !std::isnan(section.z_mm[i])) scratch.push_back(h[i] - h_fit[i]);
  }
  if (scratch.size() < kMinOverlapBins) return nan;
  // The two readings' offset (a wider window's bias on the slopes it spans) taken out: the section is
  // the reference, its depth the one published.
  const double median = detail::median_inplace(scratch.data(), scratch.data() + scratch.size());
  for (double& d : scratch) d = std::abs(d - median);
  for (double& v : h) v -= median;
  return 1.4826 * detail::median_inplace(scratch.data(), scratch.data() + scratch.size());
}

// Robust (1.4826 MAD) scatter of the smoothed heights of the ground bins (outside the disturbed zone)
// about the ground line, mm; 0 with fewer than 8 such bins. `scratch` is overwritten.
double smoothed_ground_sigma(const std::vector<double>& h_fit, const Zone& zone, std::vector<double>& scratch) {
  scratch.clear();
  for (int i = 0; i < int(h_fit.size()); ++i) {
    if ((i < zone.lo || i > zone.hi) && !std::isnan(h_fit[i])) scratch.push_back(std::abs(h_fit[i]));
  }
  if (scratch.size() < 8) return 0.0;
  return 1.4826 * detail::median_inplace(scratch.data(), scratch.data() + scratch.size());
}

}  // namespace

RutMeasurement extract_rut(const CrossSection& section, const RutConfig& params, RutWorkspace& ws,
                           const CrossSection* gap_fill) {
  RutMeasurement out;
  ws.geometry = RutGeometry{};
  const int n = static_cast<int>(section.z_mm.size());
  Profile p;
  p.grid = {section.x0_mm, section.dx_mm, n};
  p.half = std::max(2, int(std::lround(0.5 * params.fit_window_mm / section.dx_mm)));

  int valid = 0;
  for (double z : section.z_mm) valid += std::isnan(z) ? 0 : 1;
  out.valid_fraction = n > 0 ? double(valid) / n : 0.0;
  if (n == 0 || valid < 4 * p.half || out.valid_fraction < params.min_valid_fraction) {
    out.status = RutStatus::TooFewPoints;
    return out;
  }

  // Step 1.
  detail::sliding_quadratic(section.z_mm, section.dx_mm, p.half, p.half + 1, ws.smooth, ws.slope);
  const double leverage = detail::centre_leverage(p.half);
  p.sigma = detail::noise_sigma(section.z_mm, ws.smooth, leverage, ws.a);
  ws.geometry.roughness_mm = p.sigma;
  if (p.sigma > params.vegetation_roughness_mm) out.conditions |= kConditionVegetation;
  p.sigma_fit = p.sigma * std::sqrt(leverage);
  double t2 = 0.0;  // sum of squared offsets of a full window, mm^2
  for (int j = -p.half; j <= p.half; ++j) t2 += double(j) * j * section.dx_mm * section.dx_mm;
  p.slope_noise = p.sigma / std::sqrt(t2);

  // Shallower than this is noise or undisturbed ground, not a rut.
  const double min_depth = std::max(params.min_rut_depth_mm, 6.0 * p.sigma_fit);

  // Steps 2-4.
  detail::Line line = reference_line(p, ws);
  Zone ground;
  for (int pass = 0; pass < 2; ++pass) {
    heights(ws.smooth, p.grid, line, ws.h_fit);
    const int k = argmin_valid(ws.h_fit, 0, n - 1);
    if (k < 0 || -ws.h_fit[k] < min_depth) {
      // No rut: all of the low-gradient profile is ground (still reported: slope, NoGround).
      if (!fit_ground(section, p, Zone{1, 0, false, false}, params, ws, line, ground)) {
        out.status = RutStatus::NoGround;
        return out;
      }
      break;
    }
    const Opening o = find_opening(ws.h_fit, p.grid, k, p);
    if (!fit_ground(section, p, disturbed_zone(ws, line, o, p, ground_gradient(params, p)), params, ws, line, ground)) {
      out.status = RutStatus::NoGround;
      return out;
    }
  }
  out.ground_slope_deg = std::atan(line.m) * 180.0 / kPi;
  ws.geometry.has_line = true;
  ws.geometry.line_m = line.m;
  ws.geometry.line_c = line.c;
  // The ground bins of the last fit are still in ws.a, ws.b: their scatter about the line, at the
  // deepest point, is the line's share of the depth uncertainty. Copied out before step 5 reuses the
  // scratch (bounded by the section size: no allocation once grown).
  ws.ground_x.assign(ws.a.begin(), ws.a.end());
  ws.ground_z.assign(ws.b.begin(), ws.b.end());

  // Step 5.
  heights(ws.smooth, p.grid, line, ws.h_fit);
  heights(section.z_mm, p.grid, line, ws.h_raw);
  // The deepest smoothed point among the bins the section measured: the smoother's local fits carry a
  // wall's last bins on into a gap, and a bin they reach there is no measurement.
  int k = -1;
  for (int i = 0; i < n; ++i) {
    if (!std::isnan(ws.h_fit[i]) && !std::isnan(ws.h_raw[i]) && (k < 0 || ws.h_fit[i] < ws.h_fit[k])) k = i;
  }
  if (k < 0 || -ws.h_fit[k] < min_depth) {
    // The smoother leaves a bin without a value where its window holds too few measured bins: a rut whose
    // walls and bottom the matcher lost but for fragments (plain snow) is smoothed away with them. Raw
    // bins as many as a quarter of a window deeper than noise can reach are such a rut, not flat ground:
    // its depth is unknown, not zero.
    const double deep = std::max(min_depth, 6.0 * p.sigma);
    int deep_bins = 0;
    for (int i = 0; i < n; ++i) deep_bins += -ws.h_raw[i] > deep;  // false for NaN
    if (2 * deep_bins >= p.half) {
      out.status = RutStatus::Uncertain;
      out.conditions |= kConditionUncertain;
    } else {
      out.status = RutStatus::NoRut;
    }
    return out;
  }
  const Opening o = find_opening(ws.h_fit, p.grid, k, p);
  // Depth: the largest value of -h, refined by a fit over the deepest region.
  ws.a.resize(n);
  ws.b.resize(n);
  for (int i = 0; i < n; ++i) {
    ws.a[i] = -ws.h_raw[i];
    ws.b[i] = -ws.h_fit[i];
  }
  // Stereo noise is correlated over a matching window (several bins), which p.sigma_fit (from raw-minus-
  // fit residuals) does not see: the smoothed profile then wanders more than predicted, a too narrow
  // deepest region is chosen and the noise looks like curvature, both biasing the depth high (+1 mm
  // measured on low-texture images). The smoothed ground, which should lie on the line, shows the real
  // wander; the region and the curvature test are widened by its excess over the white-noise figure.
  const double wander = std::max(p.sigma_fit, smoothed_ground_sigma(ws.h_fit, ground, ws.c));
  const double inflation = p.sigma_fit > 0.0 ? wander / p.sigma_fit : 1.0;
  const double delta = std::max(kMinDelta, 5.0 * wander);
  // A flat bottom is the common case: only a curved one (curvature > 2 standard errors) is taken at
  // its vertex. Stricter would bias round bottoms low (flat mean of a curved top), laxer would bias
  // flat bottoms high (the vertex of noise); 2 balances both under 0.1 mm at 0.5 mm noise.
  const auto depth_at = [&](int bin, double* overshoot = nullptr) {
    return detail::refine_max(ws.a, ws.b, bin, delta, 2, o.left_bin, o.right_bin, 2.0 * inflation, overshoot);
  };
  // A parabola that peaks above every sample of the deepest region fits no top there (a wall's foot on
  // one side of a gap, a bottom seen in fragments on the other): the depth is its highest sample, and
  // half of the overshoot counts as a standard uncertainty (two hypotheses, as the selection's below).
  double overshoot = 0.0;
  out.depth_mm = depth_at(k, &overshoot);
  const double u_fit = 0.5 * overshoot;
  // A gap within the sliding fit's half window of k leans the smoothed value there on the gap's edge: the
  // depth read at the deepest bin clear of gaps is the other hypothesis. Of two equally likely readings
  // the depth is their midpoint and half their difference a standard uncertainty (a two-point
  // distribution's), whichever holds; publishing the deeper one with that uncertainty put the truth at
  // twice it whenever the edge read deep (scene matrix: 4 frames of snow and mud ruts published OK 1.00-
  // 1.13 mm deep, all within 1 mm at the midpoint; on a snow rut whose every frame's deepest bin lay at
  // a gap's edge, the clear readings were within 0.3 mm of the truth, the edge's 0.6-3.3 mm deep).
  // Shallower counts nothing: picking the deepest bin biases deep, so only an excess is the selection's.
  const int clear = deepest_bin_clear_of_gaps(ws, o, k, p.half);
  const double u_select = clear < 0 ? 0.0 : 0.5 * std::max(0.0, out.depth_mm - depth_at(clear));
  out.depth_mm -= u_select;
  const double norm = std::sqrt(1.0 + line.m * line.m);
  out.width_mm = (o.right_x - o.left_x) * norm;
  out.center_x_mm = 0.5 * (o.left_x + o.right_x);
  out.area_mm2 = area_below(ws.h_raw, ws.slope, line.m, p.grid, o, norm, p.half / 2);
  out.left_pile_mm = o.left_edge ? 0.0 : pile_height(ws, p, params, 0, o.left_bin);
  out.right_pile_mm = o.right_edge ? 0.0 : pile_height(ws, p, params, o.right_bin, n - 1);
  RutGeometry& geo = ws.geometry;
  geo.has_rut = true;
  geo.deepest_x_mm = p.grid.x(k);
  geo.left_x_mm = o.left_x;
  geo.right_x_mm = o.right_x;
  // Pile tops: the highest smoothed point outside each crossing (where pile_height refines).
  const double none = std::numeric_limits<double>::quiet_NaN();
  const int left_top = out.left_pile_mm > 0.0 ? argmax_valid(ws.h_fit, 0, o.left_bin) : -1;
  const int right_top = out.right_pile_mm > 0.0 ? argmax_valid(ws.h_fit, o.right_bin, n - 1) : -1;
  geo.left_pile_x_mm = left_top >= 0 ? p.grid.x(left_top) : none;
  geo.right_pile_x_mm = right_top >= 0 ? p.grid.x(right_top) : none;

  // The line's slope error, carried to the deepest point, grows with the noise's correlation as the
  // wander does (its level error is the wander's, already counted): by `inflation`, at most what noise
  // correlated over a whole fit window gives (1 / sqrt(leverage); a noise-free section has no scale).
  const double u_line =
      line_error_at(ws.ground_x, ws.ground_z, line, p.grid.x(k), ws.c, std::min(inflation, 1.0 / std::sqrt(leverage)));
  const double unseen = unseen_excess(ws.h_fit, ws.slope, line.m, p.grid, o, out.depth_mm, delta, norm, p.half);
  geo.unseen_depth_mm = unseen;
  double bound = unseen;
  if (gap_fill != nullptr && unseen > 0.0) {
    const double tol = fill_heights(section, *gap_fill, p, line, ws.h_fit, ws.a, ws.b, ws.h_fill, ws.c);
    if (std::isfinite(tol)) {
      bound = unseen_excess_filled(ws.h_fit, ws.slope, line.m, p.grid, o, out.depth_mm, delta, norm, p.half, ws.h_fill,
                                   tol);
    }
  }
  geo.unseen_bound_mm = bound;
  const double u_gap = bound / std::sqrt(3.0);
  out.depth_uncertainty_mm =
      std::sqrt(wander * wander + u_line * u_line + u_gap * u_gap + u_select * u_select + u_fit * u_fit);
  // What the shape gives, not the noise: the same in the guard strips and the next frames over this rut.
  out.depth_systematic_mm = std::sqrt(u_gap * u_gap + u_select * u_select + u_fit * u_fit);
  // Heights read off the principal row of a rig pitched against the ground (CrossSection::along_slope).
  const double level = 1.0 - section.along_slope * section.ray_elevation;
  out.depth_mm *= level;
  out.depth_uncertainty_mm *= level;
  out.depth_systematic_mm *= level;
  out.area_mm2 *= level;
  out.left_pile_mm *= level;
  out.right_pile_mm *= level;
  const double limit = params.max_depth_uncertainty_mm;
  const double quality = depth_quality(out.depth_uncertainty_mm, limit);

  if (o.left_edge || o.right_edge) {
    out.status = RutStatus::RutAtEdge;
  } else if (out.depth_mm < min_depth || out.width_mm < params.min_rut_width_mm ||
             out.width_mm > params.max_rut_width_mm) {
    out.status = RutStatus::NoRut;
  } else {
    // A depth was found: quality says how far to trust it, whether or not it is published.
    out.quality = quality;
    if (p.sigma > params.vegetation_roughness_mm) {
      out.status = RutStatus::Vegetation;
    } else if (out.depth_uncertainty_mm > limit) {
      out.status = RutStatus::Uncertain;
      out.conditions |= kConditionUncertain;
    } else {
      out.status = RutStatus::Ok;
    }
  }
  return out;
}

double depth_quality(double u_mm, double limit_mm) {
  return limit_mm > 0.0 ? std::clamp(1.0 - u_mm / (2.0 * limit_mm), 0.0, 1.0) : 0.0;
}

}  // namespace rutd
