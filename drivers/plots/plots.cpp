#include "plots/plots.hpp"

#include <plplot/plstream.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace rutd {
namespace {

// PLplot keeps global state (the current stream, the driver table): one figure at a time.
std::mutex plplot_mutex;

// Colour map 0 indices used by every figure.
enum Colour : int {
  kWhite = 0,
  kBlack = 1,
  kGrey = 2,
  kBlue = 3,
  kRed = 4,
  kGreen = 5,
  kOrange = 6,
  kPurple = 7,
  kBrown = 8,
  kLightGrey = 9,
};

void set_palette(plstream& pls) {
  pls.scol0(kWhite, 255, 255, 255);
  pls.scol0(kBlack, 0, 0, 0);
  pls.scol0(kGrey, 90, 90, 90);
  // The marks tests look for: kPlot*Bgr of plots.hpp, in RGB.
  pls.scol0(kBlue, 0, 90, 200);
  pls.scol0(kRed, 220, 0, 0);
  pls.scol0(kGreen, 0, 140, 0);
  pls.scol0(kOrange, 230, 140, 0);
  pls.scol0(kPurple, 140, 60, 170);
  pls.scol0(kBrown, 150, 90, 40);
  pls.scol0(kLightGrey, 215, 215, 215);
}

// One PNG page drawn by PLplot's memory cairo driver. Draw with stream() inside the object's lifetime;
// write() ends the stream (which renders into the buffer) and saves the PNG.
class Figure {
 public:
  explicit Figure(cv::Size page) : page_(page), rgb_(static_cast<std::size_t>(page.area()) * 3, 255) {
    pls_.emplace();
    pls_->sdev("memcairo");
    pls_->smem(page.width, page.height, rgb_.data());
    set_palette(*pls_);
    pls_->init();
    pls_->adv(0);
    pls_->schr(0, 0.9);
  }
  plstream& stream() { return *pls_; }
  // Page pixels of the normalised viewport (PLplot's vpor arguments).
  cv::Rect2d viewport_px(double x0, double x1, double y0, double y1) const {
    return {x0 * page_.width, (1.0 - y1) * page_.height, (x1 - x0) * page_.width, (y1 - y0) * page_.height};
  }
  PlotResult write(const std::string& path) {
    pls_.reset();  // plend1: the driver renders into rgb_
    const cv::Mat rgb(page_, CV_8UC3, rgb_.data());
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    return save_png(path, bgr);
  }
  static PlotResult save_png(const std::string& path, const cv::Mat& image) {
    PlotResult r;
    try {
      r.ok = cv::imwrite(path, image, {cv::IMWRITE_PNG_COMPRESSION, 6});
    } catch (const cv::Exception& e) {
      r.error = path + ": " + e.what();
      return r;
    }
    if (!r.ok) r.error = path + ": cannot write the PNG file";
    return r;
  }

 private:
  cv::Size page_;
  std::vector<unsigned char> rgb_;
  std::optional<plstream> pls_;
};

PlotResult fail(const std::string& path, const std::string& why) { return PlotResult{false, path + ": " + why}; }

// Lines between consecutive finite points; NaN breaks the line.
void polyline(plstream& pls, const std::vector<double>& x, const std::vector<double>& y) {
  std::size_t i = 0;
  while (i < x.size()) {
    while (i < x.size() && !(std::isfinite(x[i]) && std::isfinite(y[i]))) ++i;
    std::size_t j = i;
    while (j < x.size() && std::isfinite(x[j]) && std::isfinite(y[j])) ++j;
    if (j - i >= 2) pls.line(static_cast<PLINT>(j - i), &x[i], &y[i]);
    if (j - i == 1) pls.poin(1, &x[i], &y[i], 1);
    i = j;
  }
}

// A filled disc or triangle of radius r_px page pixels at world (x, y), on axes `a`.
void marker(plstream& pls, const PlotAxes& a, double x, double y, double r_px, bool triangle) {
  const double sx = (a.x_right - a.x_left) / a.area_px.width;   // world per pixel
  const double sy = (a.y_top - a.y_bottom) / a.area_px.height;  // world per pixel, upwards
  const int n = triangle ? 3 : 24;
  std::array<PLFLT, 24> px{}, py{};
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * M_PI * i / n + (triangle ? M_PI / 2 : 0.0);
    px[i] = x + r_px * std::cos(t) * sx;
    py[i] = y + r_px * std::sin(t) * sy;
  }
  pls.fill(n, px.data(), py.data());
}

std::string status_label(RutStatus s) { return std::string(to_string(s)); }

// Viridis at 8 knots: perceptually uniform and readable in grey print.
void set_viridis(plstream& pls) {
  static const PLFLT pos[] = {0.0, 0.143, 0.286, 0.429, 0.571, 0.714, 0.857, 1.0};
  static const PLFLT r[] = {0.267, 0.275, 0.212, 0.153, 0.122, 0.290, 0.627, 0.993};
  static const PLFLT g[] = {0.005, 0.194, 0.359, 0.498, 0.633, 0.762, 0.866, 0.906};
  static const PLFLT b[] = {0.329, 0.497, 0.552, 0.558, 0.528, 0.429, 0.237, 0.144};
  pls.scmap1n(256);
  pls.scmap1l(true, 8, pos, r, g, b, nullptr);
}

}  // namespace

PlotResult plot_cross_section(const std::string& path, const CrossSection& section, const RutMeasurement& m,
                              const RutGeometry& geo, const std::string& title, cv::Size page, PlotAxes* axes_out) {
  const std::size_t n = section.z_mm.size();
  std::vector<double> x(n), z(n);
  double zmin = std::numeric_limits<double>::infinity(), zmax = -zmin;
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = section.x0_mm + section.dx_mm * static_cast<double>(i);
    z[i] = section.z_mm[i];
    if (std::isfinite(z[i])) {
      zmin = std::min(zmin, z[i]);
      zmax = std::max(zmax, z[i]);
    }
  }
  if (!std::isfinite(zmin) || n < 2) return fail(path, "cross-section has no valid point to plot");
  const double xl = x.front(), xr = x.back();
  const double norm = std::sqrt(1.0 + geo.line_m * geo.line_m);
  const double deepest_z = deepest_z_mm(geo, m.depth_mm);
  if (geo.has_line) {
    for (double xe : {xl, xr}) {
      zmin = std::min(zmin, geo.line_m * xe + geo.line_c);
      zmax = std::max(zmax, geo.line_m * xe + geo.line_c);
    }
  }
  if (geo.has_rut) zmax = std::max(zmax, deepest_z);
  const double pad = std::max(1.0, 0.08 * (zmax - zmin));
  // Room below the data for the legend.
  zmin -= pad;
  zmax += pad + 0.30 * (zmax - zmin + pad);

  const std::lock_guard lock(plplot_mutex);
  Figure f(page);
  plstream& pls = f.stream();
  const double vx0 = 0.10, vx1 = 0.96, vy0 = 0.11, vy1 = 0.86;
  PlotAxes a;
  a.area_px = f.viewport_px(vx0, vx1, vy0, vy1);
  a.x_left = xl;
  a.x_right = xr;
  a.y_top = zmin;
  a.y_bottom = zmax;
  pls.vpor(vx0, vx1, vy0, vy1);
  pls.wind(xl, xr, zmax, zmin);  // Z grows downwards: the rut is a dip, as it looks on the ground
  pls.col0(kLightGrey);
  pls.box("g", 0, 0, "g", 0, 0);
  pls.col0(kBlack);
  pls.box("bcnst", 0, 0, "bcnstv", 0, 0);
  pls.lab("X, across the rut (mm)", "Z, distance from the left camera (mm)", "");
  pls.mtex("t", 2.6, 0.5, 0.5, title.c_str());
  // Figures only where a rut was found (a NO_RUT after the opening was found still has them: too shallow,
  // too narrow or too wide); otherwise the ground slope when the line was fitted.
  const std::string figures =
      geo.has_rut ? fmt::format(
                        "{}: depth {:.2f} mm, width {:.1f} mm, piles {:.1f} / {:.1f} mm, slope {:.2f}°, "
                        "quality {:.2f}",
                        status_label(m.status), m.depth_mm, m.width_mm, m.left_pile_mm, m.right_pile_mm,
                        m.ground_slope_deg, m.quality)
      : geo.has_line ? fmt::format("{}: no depth (ground slope {:.2f}°)", status_label(m.status), m.ground_slope_deg)
                     : fmt::format("{}: no depth", status_label(m.status));
  pls.mtex("t", 1.0, 0.5, 0.5, figures.c_str());

  pls.col0(kBlack);
  pls.width(1.5);
  polyline(pls, x, z);
  if (geo.has_line) {
    const PLFLT lx[2] = {xl, xr};
    const PLFLT lz[2] = {geo.line_m * xl + geo.line_c, geo.line_m * xr + geo.line_c};
    pls.col0(kBlue);
    pls.width(2.5);
    pls.line(2, lx, lz);
  }
  if (geo.has_rut) {
    // The depth: from the ground line, perpendicular to it, down to the deepest point.
    const double ux = -geo.line_m / norm, uz = 1.0 / norm;  // unit normal pointing away from the camera
    const PLFLT dx[2] = {geo.deepest_x_mm - m.depth_mm * ux, geo.deepest_x_mm};
    const PLFLT dz[2] = {deepest_z - m.depth_mm * uz, deepest_z};
    pls.col0(kRed);
    pls.width(1.5);
    pls.lsty(2);
    pls.line(2, dx, dz);
    pls.lsty(1);
    marker(pls, a, geo.deepest_x_mm, deepest_z, 6, false);
    const std::string label = fmt::format("depth {:.1f} mm", m.depth_mm);
    pls.ptex(geo.deepest_x_mm, deepest_z + 0.05 * (zmax - zmin), 1, 0, 0.5, label.c_str());
    pls.col0(kGreen);
    const double heights[2] = {m.left_pile_mm, m.right_pile_mm};
    const double pile_x[2] = {geo.left_pile_x_mm, geo.right_pile_x_mm};
    for (int s = 0; s < 2; ++s) {
      if (!std::isfinite(pile_x[s])) continue;
      const double pz = geo.line_m * pile_x[s] + geo.line_c - heights[s] * norm;
      marker(pls, a, pile_x[s], pz, 7, true);
    }
  }
  // Legend, inside at the lower left (below the ground, beside the rut).
  const char* text[] = {"cross-section", "ground line", "deepest point", "pile tops"};
  const PLINT opt[] = {PL_LEGEND_LINE, PL_LEGEND_LINE, PL_LEGEND_SYMBOL, PL_LEGEND_SYMBOL};
  const PLINT colours[] = {kBlack, kBlue, kRed, kGreen};
  const PLINT styles[] = {1, 1, 1, 1};
  const PLFLT widths[] = {1.5, 2.5, 1, 1};
  const PLFLT scales[] = {1, 1, 1.6, 1.6};
  const PLINT numbers[] = {1, 1, 1, 1};
  const char* symbols[] = {"", "", "●", "▲"};
  PLFLT lw = 0, lh = 0;
  pls.legend(&lw, &lh, PL_LEGEND_BACKGROUND | PL_LEGEND_BOUNDING_BOX,
             PL_POSITION_LEFT | PL_POSITION_BOTTOM | PL_POSITION_INSIDE | PL_POSITION_VIEWPORT, 0.02, 0.03, 0.08,
             kWhite, kGrey, 1, 0, 0, 4, opt, 1.0, 0.9, 2.0, 0.0, colours, text, nullptr, nullptr, nullptr, nullptr,
             colours, styles, widths, colours, scales, numbers, symbols);
  if (axes_out) *axes_out = a;
  return f.write(path);
}

PlotResult plot_disparity(const std::string& path, const cv::Mat& disparity, int row0, const std::string& title,
                          cv::Size page) {
  if (disparity.empty() || disparity.type() != CV_32FC1) return fail(path, "no disparity map (CV_32FC1) to plot");
  std::vector<float> valid;
  for (int r = 0; r < disparity.rows; ++r) {
    const float* d = disparity.ptr<float>(r);
    for (int c = 0; c < disparity.cols; ++c)
      if (std::isfinite(d[c])) valid.push_back(d[c]);
  }
  if (valid.empty()) return fail(path, "the disparity map has no valid pixel");
  // Colour range: 1st..99th percentile, so a few outliers do not wash out the map.
  const auto lo_it = valid.begin() + static_cast<std::ptrdiff_t>(valid.size() / 100);
  std::nth_element(valid.begin(), lo_it, valid.end());
  const double lo = *lo_it;
  const auto hi_it = valid.begin() + static_cast<std::ptrdiff_t>(valid.size() - 1 - valid.size() / 100);
  std::nth_element(valid.begin(), hi_it, valid.end());
  const double hi = std::max(*hi_it, static_cast<float>(lo + 0.01));
  const int nx = disparity.cols, ny = disparity.rows;
  // An invalid pixel between two valid ones of its column (the rows DIC skips with its row step) is shown
  // as their mean, so the map does not look striped; anything else invalid stays white.
  const auto shown = [&](int r, int c) -> float {
    const float d = disparity.at<float>(r, c);
    if (std::isfinite(d) || r == 0 || r + 1 == ny) return d;
    const float a = disparity.at<float>(r - 1, c), b = disparity.at<float>(r + 1, c);
    return std::isfinite(a) && std::isfinite(b) ? 0.5f * (a + b) : d;
  };
  // PLplot images are indexed [x][y]; below-range values are not drawn (white): the invalid pixels.
  std::vector<PLFLT> storage(static_cast<std::size_t>(nx) * ny);
  std::vector<const PLFLT*> columns(static_cast<std::size_t>(nx));
  for (int c = 0; c < nx; ++c) {
    PLFLT* col = &storage[static_cast<std::size_t>(c) * ny];
    columns[static_cast<std::size_t>(c)] = col;
    for (int r = 0; r < ny; ++r) {
      const float d = shown(r, c);
      col[r] = std::isfinite(d) ? std::clamp<double>(d, lo, hi) : lo - 1e6;
    }
  }

  const std::lock_guard lock(plplot_mutex);
  Figure f(page);
  plstream& pls = f.stream();
  // Keep the image's aspect where it fits; a thin strip is stretched to a readable height.
  const double ax0 = 0.09, ax1 = 0.86, ay0 = 0.12, ay1 = 0.88;
  const double aw = (ax1 - ax0) * page.width, ah = (ay1 - ay0) * page.height;
  const double scale = std::min(aw / nx, ah / ny);
  const double w = nx * scale, h = std::min(ah, std::max(ny * scale, 0.45 * ah));
  const double vx0 = ax0 + (aw - w) / 2 / page.width, vy0 = ay0 + (ah - h) / 2 / page.height;
  pls.vpor(vx0, vx0 + w / page.width, vy0, vy0 + h / page.height);
  pls.wind(0, nx, row0 + ny, row0);  // image rows grow downwards
  set_viridis(pls);
  pls.imagefr(columns.data(), nx, ny, 0, nx, row0 + ny, row0, lo, hi, lo, hi, nullptr, nullptr);
  pls.col0(kBlack);
  pls.box("bcnst", 0, 0, "bcnstv", 0, 0);
  pls.lab("column (px)", "row of the rectified image (px)", "");
  pls.mtex("t", 1.5, 0.5, 0.5, title.c_str());
  PLINT label_opts[] = {PL_COLORBAR_LABEL_RIGHT};
  const char* labels[] = {"disparity (px)"};
  const char* axis_opts[] = {"bcvtm"};
  PLFLT ticks[] = {0};
  PLINT sub_ticks[] = {0};
  PLINT n_values[] = {2};
  const PLFLT range[] = {lo, hi};
  const PLFLT* values[] = {range};
  PLFLT cw = 0, ch = 0;
  pls.colorbar(&cw, &ch, PL_COLORBAR_GRADIENT, PL_POSITION_RIGHT | PL_POSITION_OUTSIDE | PL_POSITION_VIEWPORT, 0.02, 0,
               0.03, 1.0, kWhite, kBlack, 1, 0, 0, 0, 0, 1, label_opts, labels, 1, axis_opts, ticks, sub_ticks,
               n_values, values);
  return f.write(path);
}

PlotResult write_strip_overlay(const std::string& path, const cv::Mat& rectified_left, const ImageMarks& marks) {
  if (rectified_left.empty() || rectified_left.type() != CV_8UC1)
    return fail(path, "no rectified image (CV_8UC1) to draw on");
  const double s = rectified_left.cols < 640 ? 640.0 / rectified_left.cols : 1.0;
  cv::Mat grey, image;
  cv::resize(rectified_left, grey, cv::Size(), s, s, cv::INTER_LINEAR);
  cv::cvtColor(grey, image, cv::COLOR_GRAY2BGR);
  const int top = static_cast<int>(std::lround(marks.strip_row0 * s));
  const int bottom = static_cast<int>(std::lround((marks.strip_row0 + marks.strip_rows) * s)) - 1;
  const cv::Scalar yellow(0, 220, 255), cyan(255, 220, 0), red(0, 0, 255);
  cv::rectangle(image, cv::Point(0, top), cv::Point(image.cols - 1, bottom), yellow, 2);
  const auto vline = [&](double col, const cv::Scalar& colour) {
    if (col < 0) return;
    const int x = static_cast<int>(std::lround(col * s));
    cv::line(image, cv::Point(x, std::max(0, top - 12)), cv::Point(x, std::min(image.rows - 1, bottom + 12)), colour,
             2);
  };
  vline(marks.left_col, cyan);
  vline(marks.right_col, cyan);
  vline(marks.deepest_col, red);
  const double font = 0.55 * std::max(1.0, image.cols / 900.0);
  const int band = static_cast<int>(28 * std::max(1.0, image.cols / 900.0));
  cv::rectangle(image, cv::Point(0, 0), cv::Point(image.cols - 1, band), cv::Scalar(40, 40, 40), cv::FILLED);
  cv::putText(image, marks.caption, cv::Point(8, band - 9), cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(255, 255, 255),
              1, cv::LINE_AA);
  const std::string legend = "yellow: measured strip   cyan: rut edges   red: deepest point";
  cv::rectangle(image, cv::Point(0, image.rows - band - 1), cv::Point(image.cols - 1, image.rows - 1),
                cv::Scalar(40, 40, 40), cv::FILLED);
  cv::putText(image, legend, cv::Point(8, image.rows - 10), cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(255, 255, 255),
              1, cv::LINE_AA);
  return Figure::save_png(path, image);
}

PlotResult plot_series(const std::string& path, const std::vector<SeriesSample>& samples, const std::string& title,
                       cv::Size page) {
  if (samples.empty()) return fail(path, "no measurement to plot");
  double t0 = samples.front().t_s, t1 = samples.back().t_s;
  for (const SeriesSample& s : samples) {
    t0 = std::min(t0, s.t_s);
    t1 = std::max(t1, s.t_s);
  }
  if (t1 - t0 < 1e-6) t1 = t0 + 1.0;
  const double tpad = 0.02 * (t1 - t0);
  static constexpr RutStatus kFailed[] = {RutStatus::NoRut, RutStatus::TooFewPoints, RutStatus::NoGround,
                                          RutStatus::RutAtEdge, RutStatus::NoMeasurement};
  static constexpr PLINT kFailedColour[] = {kOrange, kPurple, kBrown, kGreen, kGrey};

  const std::lock_guard lock(plplot_mutex);
  Figure f(page);
  plstream& pls = f.stream();
  struct Panel {
    const char* label;
    double SeriesSample::*field;
  };
  const Panel panels[] = {{"depth (mm)", &SeriesSample::depth_mm},
                          {"width (mm)", &SeriesSample::width_mm},
                          {"quality (0-1)", &SeriesSample::quality}};
  const double top = 0.90, bottom = 0.09, gap = 0.035;
  const double ph = (top - bottom - 2 * gap) / 3;
  for (int p = 0; p < 3; ++p) {
    const Panel& panel = panels[p];
    std::vector<double> t, v;
    double vmin = std::numeric_limits<double>::infinity(), vmax = -vmin;
    for (const SeriesSample& s : samples) {
      if (s.status != RutStatus::Ok) continue;
      t.push_back(s.t_s);
      v.push_back(s.*panel.field);
      vmin = std::min(vmin, s.*panel.field);
      vmax = std::max(vmax, s.*panel.field);
    }
    if (!std::isfinite(vmin)) vmin = 0, vmax = 1;
    if (p == 2) vmin = 0, vmax = 1;
    const double span = std::max(vmax - vmin, p == 2 ? 1.0 : 2.0);
    const double mid = 0.5 * (vmin + vmax);
    // Failed frames are marked in a band below the data.
    const double y0 = mid - 0.5 * span - 0.45 * span, y1 = mid + 0.5 * span + 0.12 * span;
    const double vy1 = top - p * (ph + gap), vy0 = vy1 - ph;
    pls.vpor(0.09, 0.72, vy0, vy1);
    pls.wind(t0 - tpad, t1 + tpad, y0, y1);
    pls.col0(kLightGrey);
    pls.box("g", 0, 0, "g", 0, 0);
    pls.col0(kBlack);
    pls.box(p == 2 ? "bcnst" : "bcst", 0, 0, "bcnstv", 0, 0);
    pls.mtex("l", 5.0, 0.5, 0.5, panel.label);
    if (p == 0) pls.mtex("t", 1.2, 0.5, 0.5, title.c_str());
    if (p == 2) pls.mtex("b", 3.0, 0.5, 0.5, "time (s)");
    pls.col0(kBlue);
    pls.width(1.5);
    // Lines only between consecutive OK frames: a gap shows where the measurement failed.
    std::vector<double> lt, lv;
    for (const SeriesSample& s : samples) {
      lt.push_back(s.t_s);
      lv.push_back(s.status == RutStatus::Ok ? s.*panel.field : std::numeric_limits<double>::quiet_NaN());
    }
    polyline(pls, lt, lv);
    if (!t.empty()) pls.string(static_cast<PLINT>(t.size()), t.data(), v.data(), "•");
    const double mark_y = mid - 0.5 * span - 0.25 * span;
    for (std::size_t k = 0; k < std::size(kFailed); ++k) {
      std::vector<double> ft, fy;
      for (const SeriesSample& s : samples)
        if (s.status == kFailed[k]) ft.push_back(s.t_s), fy.push_back(mark_y);
      if (ft.empty()) continue;
      pls.col0(kFailedColour[k]);
      pls.string(static_cast<PLINT>(ft.size()), ft.data(), fy.data(), "▼");
    }
  }
  // One legend for all panels, right of the top panel.
  std::vector<const char*> text = {"OK (measured)"};
  std::vector<PLINT> colours = {kBlue};
  std::vector<std::string> names;
  names.reserve(std::size(kFailed));
  for (std::size_t k = 0; k < std::size(kFailed); ++k) {
    names.push_back(status_label(kFailed[k]));
    text.push_back(names.back().c_str());
    colours.push_back(kFailedColour[k]);
  }
  const std::size_t nl = text.size();
  std::vector<PLINT> opt(nl, PL_LEGEND_SYMBOL), numbers(nl, 1);
  std::vector<PLFLT> scales(nl, 1.0);
  std::vector<const char*> symbols(nl, "▼");
  symbols[0] = "•";
  // Right of the panels, centred on the page's height.
  pls.vpor(0.09, 0.72, bottom, top);
  pls.wind(0, 1, 0, 1);
  PLFLT lw = 0, lh = 0;
  pls.legend(&lw, &lh, PL_LEGEND_BACKGROUND | PL_LEGEND_BOUNDING_BOX,
             PL_POSITION_RIGHT | PL_POSITION_OUTSIDE | PL_POSITION_VIEWPORT, 0.02, 0.0, 0.03, kWhite, kGrey, 1, 0, 0,
             static_cast<PLINT>(nl), opt.data(), 1.0, 0.75, 2.0, 0.0, colours.data(), text.data(), nullptr, nullptr,
             nullptr, nullptr, nullptr, nullptr, nullptr, colours.data(), scales.data(), numbers.data(),
             symbols.data());
  return f.write(path);
}

PlotResult plot_depth_along_track(const std::string& path, const std::vector<DepthAlongTrack>& drives,
                                  const std::string& title, cv::Size page) {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const DepthAlongTrack& d : drives) {
    for (std::size_t i = 0; i < d.distance_m.size() && i < d.depth_mm.size(); ++i) {
      if (!std::isfinite(d.distance_m[i]) || !std::isfinite(d.depth_mm[i])) continue;
      x0 = std::min(x0, d.distance_m[i]);
      x1 = std::max(x1, d.distance_m[i]);
      y0 = std::min(y0, d.depth_mm[i]);
      y1 = std::max(y1, d.depth_mm[i]);
    }
  }
  if (!std::isfinite(x0)) return fail(path, "no measured depth with a position to plot");
  if (x1 - x0 < 1e-6) x1 = x0 + 1.0;
  if (y1 - y0 < 2.0) y0 -= 1.0, y1 += 1.0;
  const double xpad = 0.02 * (x1 - x0), ypad = 0.1 * (y1 - y0);
  static constexpr PLINT kDriveColour[] = {kBlue, kRed, kGreen, kOrange, kPurple, kBrown};
  const std::lock_guard lock(plplot_mutex);
  Figure f(page);
  plstream& pls = f.stream();
  pls.vpor(0.09, 0.75, 0.12, 0.90);
  pls.wind(x0 - xpad, x1 + xpad, y0 - ypad, y1 + ypad);
  pls.col0(kLightGrey);
  pls.box("g", 0, 0, "g", 0, 0);
  pls.col0(kBlack);
  pls.box("bcnst", 0, 0, "bcnstv", 0, 0);
  pls.mtex("l", 5.0, 0.5, 0.5, "rut depth (mm)");
  pls.mtex("b", 3.0, 0.5, 0.5, "distance along the track (m)");
  pls.mtex("t", 1.2, 0.5, 0.5, title.c_str());
  pls.width(1.5);
  for (std::size_t k = 0; k < drives.size(); ++k) {
    const PLINT colour = kDriveColour[k % std::size(kDriveColour)];
    pls.col0(colour);
    polyline(pls, drives[k].distance_m, drives[k].depth_mm);
    pls.mtex("rv", 1.5, 0.95 - 0.06 * static_cast<double>(k), 0.0, drives[k].label.c_str());
  }
  return f.write(path);
}

}  // namespace rutd
