#pragma once
// Numerical building blocks of rut extraction: sliding parabola fits, robust statistics, robust line
// fit and fit-based peak refinement. Internal to rut/; NaN marks a missing sample everywhere. None of
// these allocate once the vectors passed in have grown.
#include <vector>

namespace rutd::detail {

// Least-squares parabola through the valid samples of z within +-half bins of every bin i (the
// paper's sliding fit; Savitzky-Golay that tolerates gaps). value[i] and slope[i] (dZ/dX, with dx the
// bin width) are the parabola's value and slope at bin i, NaN where fewer than min_count samples
// were available.
void sliding_quadratic(const std::vector<double>& z, double dx, int half, int min_count, std::vector<double>& value,
                       std::vector<double>& slope);

// Variance of a full-window sliding_quadratic value relative to the per-sample variance (the centre
// leverage of a parabola fitted to 2*half+1 equally spaced points).
double centre_leverage(int half);

// Median of [first, last) (reorders the range). NaN for an empty range.
double median_inplace(double* first, double* last);

// Robust per-sample noise sigma: 1.4826 MAD of raw - fit over bins where both are valid, corrected
// for the fit's leverage. `scratch` is overwritten.
double noise_sigma(const std::vector<double>& raw, const std::vector<double>& fit, double leverage,
                   std::vector<double>& scratch);

struct Line {
  double m = 0.0;      // dZ/dX
  double c = 0.0;      // Z at X = 0, mm
  double scale = 0.0;  // robust residual sigma of the points that carried weight, mm
};

// Fits Z = m X + c to the n points (x[i], z[i]) with Tukey's bisquare (IRLS from a least-squares
// start), so points that are not ground (stones, pile tails) do not pull the line. `scratch` is
// overwritten. Returns false for fewer than 2 distinct X.
bool fit_line_robust(const double* x, const double* z, int n, std::vector<double>& scratch, Line& line);

// Fit-based estimate of the largest value of a profile around bin k, unbiased by noise unlike the
// largest sample. The region is the run of bins around k whose smoothed value lies within `delta` of
// h_fit[k] (a bin without a smoothed value: its raw sample within 2 delta; gaps do not end the run;
// at least +-min_half bins, within [lo, hi]); a parabola is fitted to the raw samples there.
// A concave parabola whose curvature exceeds min_t times its standard error gives its vertex, clamped
// to the samples' extent within the region and never above the highest sample; otherwise the top is
// flat within the noise and the mean of the region is the estimate. min_t = 0 trusts any concave fit
// (tops known to be rounded). overshoot, where given, gets how far the vertex lay above the highest
// sample (0 where it did not, or where no vertex was taken).
double refine_max(const std::vector<double>& h_raw, const std::vector<double>& h_fit, int k, double delta, int min_half,
                  int lo, int hi, double min_t, double* overshoot = nullptr);

}  // namespace rutd::detail
