// The scene matrix (daemon/scene_matrix.hpp): its scenes drawn from fixed ranges by a fixed seed.
#include "daemon/scene_matrix.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>

#include <fmt/format.h>

namespace rutd {
namespace {

// splitmix64: the same draws on every platform (the standard distributions are not portable).
class Draw {
 public:
  explicit Draw(std::uint64_t seed) : state_(seed) {}
  double uniform(double lo, double hi) {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return lo + (hi - lo) * static_cast<double>(z >> 11) * 0x1.0p-53;
  }
  int pick(int n) { return std::min(n - 1, static_cast<int>(uniform(0, n))); }
  bool chance(double p) { return uniform(0, 1) < p; }

 private:
  std::uint64_t state_;
};

constexpr std::array<const char*, 4> kTextures = {"sand", "mud", "snow", "grass"};
// Their brightest grains' albedo (mean + 3 deviations, synthetic_scene.cpp's SolidTexture), and the light
// on flat ground in the default sun.
constexpr std::array<double, 4> kTextureBrightest = {1.05, 0.39, 0.96, 0.86};
constexpr double kGroundLight = 0.94;

// The widest rut (top width, mm) whose piles (50 mm wide, the renderer's default) and 40 mm of ground
// beyond each both cameras see on the principal row of a rig `height` above the ground, its rut `offset`
// from the rig's middle: a measurable scene. Wider, and no ground is left to fit the ground line to.
double widest_rut(double height, double baseline, double hfov_deg, double offset) {
  const double common = 2 * height * std::tan(hfov_deg / 2 * std::numbers::pi / 180) - baseline;
  return 0.95 * common - 2 * (50 + 40) - 2 * std::abs(offset);
}

// The rig and the rut of the spoiled and skewed groups (75 degree lens, the rut under the rig's middle);
// `depth` deep enough for the water level given. (Draws are taken one statement at a time: the order of
// a call's arguments is unspecified.)
std::string rig_and_rut(Draw& d, const char* texture, double depth, int seed) {
  double baseline = 0, height = 0;
  do {  // a rig that sees the narrowest rut drawn with ground beside it
    baseline = d.uniform(40, 100);
    height = d.uniform(280, 450);
  } while (widest_rut(height, baseline, 75, 0) < 150);
  const double width = d.uniform(150, std::min(260.0, widest_rut(height, baseline, 75, 0)));
  const double bottom = width * d.uniform(0.3, 0.55);
  const double pile_left = d.uniform(0, 15);
  const double pile_right = d.uniform(0, 15);
  const double sign = d.chance(0.5) ? 1 : -1;
  const double roll = sign * d.uniform(0, 5);
  return fmt::format(
      "--texture {} --depth {:.1f} --width {:.0f} --bottom-width {:.0f} --pile-left {:.1f} --pile-right {:.1f} "
      "--baseline {:.0f} --height {:.0f} --roll {:.1f} --seed {}",
      texture, depth, width, bottom, pile_left, pile_right, baseline, height, roll, seed);
}

// "NAME VALUE" with VALUE drawn in [lo, hi], printed with `digits` decimals.
std::string draw_option(Draw& d, const char* name, double lo, double hi, int digits) {
  return fmt::format(" {} {:.{}f}", name, d.uniform(lo, hi), digits);
}

void add_water(std::vector<MatrixScene>& out) {
  constexpr std::array<const char*, 8> kKinds = {"turbid", "clear", "foam", "leaves",
                                                 "litter", "glint", "wind", "rain"};
  Draw d(0x57A7E4);
  for (int i = 0; i < 40; ++i) {
    const int k = i % 8;
    const char* texture = kTextures[static_cast<std::size_t>((i / 8 + i) % 4)];
    const double level = d.uniform(5, 30);
    const double depth = level + d.uniform(15, 40);
    std::string water = fmt::format(" --water-level {:.1f}", level);
    const std::string kind = kKinds[static_cast<std::size_t>(k)];
    // Under debris and ripples, half the water is clear and half turbid.
    const auto mixed_attenuation = [&] {
      return d.chance(0.5) ? draw_option(d, "--water-attenuation", 0.005, 0.03, 3)
                           : draw_option(d, "--water-attenuation", 0.2, 0.6, 3);
    };
    if (kind == "turbid") {
      water += draw_option(d, "--water-attenuation", 0.15, 1.0, 2);
      water += draw_option(d, "--water-colour", 0.08, 0.25, 2);
      water += draw_option(d, "--silt", 0.02, 0.08, 2);
    } else if (kind == "clear") {
      water += draw_option(d, "--water-attenuation", 0.002, 0.01, 4);
      water += draw_option(d, "--water-colour", 0.04, 0.12, 2);
    } else if (kind == "foam" || kind == "leaves" || kind == "litter") {
      water += draw_option(d, "--debris", 0.4, 1.0, 2) + " --debris-kind " + kind;
      water += mixed_attenuation();
    } else if (kind == "glint") {
      // The sun near the zenith: each camera sees its own mirror image of it in the water under it.
      water += draw_option(d, "--water-attenuation", 0.005, 0.05, 3);
      water += draw_option(d, "--sun-elevation", 84, 89, 1);
      water += draw_option(d, "--sun-azimuth", 0, 360, 0);
      water += draw_option(d, "--water-roughness", 1, 3, 1) + " --underside-height 0";
    } else {
      water += draw_option(d, "--ripple", 0.03, 0.1, 3) + " --ripple-kind " + kind;
      water += mixed_attenuation();
      water += draw_option(d, "--sun-elevation", 70, 88, 1);
      water += draw_option(d, "--sun-azimuth", 120, 240, 0) + " --underside-height 0";
    }
    const std::string rig = rig_and_rut(d, texture, depth, 1000 + i);
    out.push_back(
        {fmt::format("water-{}-{}-{:02d}", kind, texture, i), "spoiled", "water-" + kind, {"Water"}, rig + water});
  }
}

// Covered water drawn again: floating debris is where trust is hardest won (a textured, level lid looks
// like a rut's bottom to stereo), so beyond add_water's five lid scenes of each kind, 24 more, each kind
// twice on each texture, half over clear water (the bottom seen through gaps in the lid).
void add_lids(std::vector<MatrixScene>& out) {
  constexpr std::array<const char*, 3> kKinds = {"foam", "leaves", "litter"};
  Draw d(0x11D5);
  for (int i = 0; i < 24; ++i) {
    const std::string kind = kKinds[static_cast<std::size_t>(i % 3)];
    const char* texture = kTextures[static_cast<std::size_t>((i / 3) % 4)];
    const double level = d.uniform(5, 30);
    const double depth = level + d.uniform(15, 40);
    std::string water = fmt::format(" --water-level {:.1f}", level);
    water += draw_option(d, "--debris", 0.4, 1.0, 2) + " --debris-kind " + kind;
    water += d.chance(0.5) ? draw_option(d, "--water-attenuation", 0.005, 0.03, 3)
                           : draw_option(d, "--water-attenuation", 0.03, 0.6, 3);
    const std::string rig = rig_and_rut(d, texture, depth, 1300 + i);
    out.push_back(
        {fmt::format("lid-{}-{}-{:02d}", kind, texture, i), "spoiled", "water-" + kind, {"Water"}, rig + water});
  }
}

void add_lens_faults(std::vector<MatrixScene>& out) {
  constexpr std::array<const char*, 5> kFaults = {"mud", "snow", "drops", "spray", "dust"};
  constexpr std::array<const char*, 3> kSides = {"left", "right", "both"};
  Draw d(0x1E45);
  int i = 0;
  for (const char* fault : kFaults) {
    for (const char* side : kSides) {
      const std::string f = fault;
      double amount = 0;
      std::string centre;
      if (f == "mud" || f == "snow") {
        amount = f == "mud" ? d.uniform(0.1, 0.5) : d.uniform(0.15, 0.5);
        centre = fmt::format(":{:.2f}", d.uniform(0.3, 0.7));
      }
      if (f == "drops") amount = d.uniform(0.2, 0.5);
      if (f == "spray") amount = d.uniform(0.05, 0.2);
      if (f == "dust") amount = d.uniform(0.3, 0.7);
      const std::string s = side;
      std::vector<std::string> expect;
      if (s != "right") expect.push_back("LeftLensObstructed");
      if (s != "left") expect.push_back("RightLensObstructed");
      const char* texture = kTextures[static_cast<std::size_t>(i % 4)];
      const double depth = d.uniform(25, 70);
      const std::string rig = rig_and_rut(d, texture, depth, 1100 + i);
      out.push_back({fmt::format("lens-{}-{}-{}", f, s, texture), "spoiled", fmt::format("lens-{}-{}", f, s), expect,
                     rig + fmt::format(" --lens {}:{}:{:.2f}{}", f, s, amount, centre)});
      ++i;
    }
  }
}

// A rig drawn until it sees a rut `width` wide whole, with its piles and ground beside them: baseline,
// height above the ground, lens, where the rut lies.
struct Rig {
  double baseline = 0, height = 0, offset = 0;
  int hfov = 75;
};
Rig draw_rig(Draw& d, double width) {
  Rig r;
  do {
    r.baseline = d.uniform(40, 120);
    r.height = d.uniform(260, 560);
    r.hfov = std::array<int, 3>{60, 75, 90}[static_cast<std::size_t>(d.pick(3))];
    r.offset = d.uniform(-40, 40);
  } while (widest_rut(r.height, r.baseline, r.hfov, r.offset) < width);
  return r;
}

// The options after the rut's shape: its piles, the rig, its pose, the sensor's noise, the speed, the
// right camera's response and the seed.
std::string rig_options(Draw& d, const Rig& r, int seed) {
  std::string s = draw_option(d, "--pile-left", 0, 20, 1);
  s += draw_option(d, "--pile-right", 0, 20, 1);
  s += fmt::format(" --offset {:.0f} --baseline {:.0f} --height {:.0f} --hfov {}", r.offset, r.baseline, r.height,
                   r.hfov);
  s += draw_option(d, "--roll", -5, 5, 1);
  s += draw_option(d, "--pitch", -6, 10, 1);
  s += draw_option(d, "--noise", 1, 2.5, 2);
  s += draw_option(d, "--speed", 300, 3000, 0);
  s += draw_option(d, "--right-response", 0.96, 1.06, 3);
  return s + fmt::format(" --seed {}", seed);
}

// A clean rut on any rig: the rig drawn first, then a rut it sees whole with ground beside it.
std::string any_rig_and_rut(Draw& d, const char* texture, int seed) {
  const Rig r = draw_rig(d, 140);
  const double width = d.uniform(140, std::min(300.0, widest_rut(r.height, r.baseline, r.hfov, r.offset)));
  std::string s = fmt::format("--texture {}", texture) + draw_option(d, "--depth", 15, 80, 1);
  s += fmt::format(" --width {:.0f} --bottom-width {:.0f}", width, width * d.uniform(0.3, 0.6));
  return s + rig_options(d, r, seed);
}

// Night: auto exposure at its longest exposure and highest gain, the texture under the noise.
void add_dark(std::vector<MatrixScene>& out) {
  Draw d(0xDA4C);
  for (int i = 0; i < 4; ++i) {
    const char* texture = kTextures[static_cast<std::size_t>(i)];
    const double depth = d.uniform(25, 70);
    const std::string rig = rig_and_rut(d, texture, depth, 1200 + i);
    out.push_back({fmt::format("dark-{}", texture),
                   "spoiled",
                   "dark",
                   {"LowLight"},
                   rig + " --auto-exposure" + draw_option(d, "--light", 0.008, 0.04, 3)});
  }
}

// Exposure modes: set by hand (exposure, or gain with a shorter exposure), auto in daylight, auto in
// dim light (gain up).
constexpr std::array<const char*, 4> kModes = {"manual", "gain", "auto", "auto-dim"};

// The options of exposure `mode` (kModes) for kTextures[texture]. Set by hand as an operator sets it for
// the terrain: its brightest grains at 60-95 % of full scale (snow, bright and even, then sits high; sand,
// whose grains spread twice its mean, lower), with a gain of 1.2-3 in the gain mode. Auto exposure holds
// a median of 35-60 % of full scale, in daylight or dim light.
std::string exposure_options(Draw& d, const std::string& mode, std::size_t texture) {
  std::string s;
  const double level = d.uniform(0.6, 0.95) / (kTextureBrightest[texture] * kGroundLight);
  if (mode == "manual") s += fmt::format(" --exposure {:.2f}", level);
  if (mode == "gain") {
    const double gain = d.uniform(1.2, 3);
    s += fmt::format(" --exposure {:.3f} --gain {:.2f}", level / gain, gain);
  }
  if (mode == "auto" || mode == "auto-dim") s += " --auto-exposure" + draw_option(d, "--ae-target", 0.35, 0.6, 2);
  if (mode == "auto") s += draw_option(d, "--light", 0.5, 1.5, 2);
  if (mode == "auto-dim") s += draw_option(d, "--light", 0.12, 0.4, 3);
  return s;
}

void add_clean(std::vector<MatrixScene>& out) {
  Draw d(0xC1EA4);
  for (int i = 0; i < 64; ++i) {
    const char* texture = kTextures[static_cast<std::size_t>(i % 4)];
    const std::string mode = kModes[static_cast<std::size_t>((i / 4) % 4)];
    std::string s = any_rig_and_rut(d, texture, 2000 + i);
    if (i % 16 == 7) s += " --size 1280x1024";
    if (i % 7 == 3) {
      s += draw_option(d, "--wander", 20, 60, 0);
      s += draw_option(d, "--wander-wavelength", 800, 3000, 0);
    }
    s += exposure_options(d, mode, static_cast<std::size_t>(i % 4));
    out.push_back({fmt::format("clean-{}-{}-{:02d}", mode, texture, i), "clean", "clean-" + mode, {}, s});
  }
}

// Steep clean ruts, as cohesive ground holds them (snow, mud, grass sod; dry sand slumps to its angle of
// repose): 55-80 mm deep, walls 51-61 degrees (each 0.55-0.8 of the depth across), bottoms 40-100 mm
// wide, on any rig and exposure mode. Their low-texture walls, foreshortened differently in the two
// views, are where DIC loses most of a rut: a depth must be within 1 mm or refused (a refusal is a false
// alarm, as in the clean group, counted apart).
void add_steep(std::vector<MatrixScene>& out) {
  constexpr std::array<std::size_t, 4> kCohesive = {2, 1, 2, 3};  // snow, mud, snow, grass (kTextures)
  Draw d(0x57EE9);
  for (int i = 0; i < 16; ++i) {
    const std::size_t t = kCohesive[static_cast<std::size_t>(i % 4)];
    const std::string mode = kModes[static_cast<std::size_t>((i / 4) % 4)];
    const double depth = d.uniform(55, 80), wall = depth * d.uniform(0.55, 0.8), bottom = d.uniform(40, 100);
    const double width = bottom + 2 * wall;
    const Rig r = draw_rig(d, width);
    std::string s = fmt::format("--texture {} --depth {:.1f} --width {:.0f} --bottom-width {:.0f}", kTextures[t], depth,
                                width, bottom);
    s += rig_options(d, r, 2600 + i);  // before the exposure's: the draws' order is the scenes'
    s += exposure_options(d, mode, t);
    out.push_back({fmt::format("steep-{}-{}-{:02d}", mode, kTextures[t], i), "steep", "steep-" + mode, {}, s});
  }
}

// Tread marks across the rut's bottom, 3 mm deep: truth.csv's depth_mm excludes them (tread_depth_mm says
// how much deeper the grooves' floor is), while the strip rutd averages along travel holds part of each
// groove. Reported apart from the clean ruts until the product says which depth it owes.
void add_tread(std::vector<MatrixScene>& out) {
  Draw d(0x78EAD);
  for (int i = 0; i < 6; ++i) {
    const char* texture = kTextures[static_cast<std::size_t>(i % 4)];
    out.push_back({fmt::format("tread-{}-{:02d}", texture, i),
                   "tread",
                   "tread",
                   {},
                   any_rig_and_rut(d, texture, 2500 + i) + " --tread"});
  }
}

void add_skew(std::vector<MatrixScene>& out) {
  Draw d(0x5CE3);
  for (int i = 0; i < 6; ++i) {
    const char* texture = kTextures[static_cast<std::size_t>(i % 4)];
    const double depth = d.uniform(25, 70);
    std::string s = rig_and_rut(d, texture, depth, 3000 + i) + draw_option(d, "--speed", 1000, 8000, 0);
    const double sign = d.chance(0.5) ? 1 : -1;
    s += fmt::format(" --right-delay-ms {:.2f}", sign * d.uniform(0.3, 8));
    out.push_back({fmt::format("skew-{}-{:02d}", texture, i), "skew", "skew", {"UNSYNCHRONISED"}, s});
  }
}

// A rut deepening by `rate` mm a pair into a pool whose level surface lies below the ground where the rut
// reaches it between two pairs: 2-4 dry pairs, then water from a fraction of `rate` deep on the first wet
// pair (--water-surface, --depth-profile over the matrix's 8 pairs). Rates (log-uniform) from a rut
// levelling off, where a dry pair's depth is most like the next one's, to one plunging 1 mm in 15 of
// travel at 1 m/s.
void add_entries(std::vector<MatrixScene>& out) {
  constexpr std::array<const char*, 5> kKinds = {"turbid", "foam", "leaves", "litter", "clear"};
  Draw d(0xE4721);
  for (int i = 0; i < 10; ++i) {
    const std::string kind = kKinds[static_cast<std::size_t>(i % 5)];
    const char* texture = kTextures[static_cast<std::size_t>((i / 5 + i) % 4)];
    const double depth = d.uniform(25, 50);
    const double rate = std::exp(d.uniform(std::log(0.05), std::log(2.2)));  // as often under 0.3 as over 0.3
    const int first_wet = 2 + d.pick(3);
    // The surface a fraction of a pair's deepening above the first wet pair's bottom.
    const double surface = depth + rate * (first_wet - d.uniform(0.05, 0.95));
    std::string water =
        fmt::format(" --depth-profile 0:{:.2f},7:{:.2f} --water-surface {:.2f}", depth, depth + 7 * rate, surface);
    if (kind == "turbid") {
      water += draw_option(d, "--water-attenuation", 0.15, 1.0, 2) + draw_option(d, "--water-colour", 0.08, 0.25, 2);
    } else if (kind == "clear") {
      water += draw_option(d, "--water-attenuation", 0.002, 0.01, 4);
    } else {
      water += draw_option(d, "--debris", 0.5, 1.0, 2) + " --debris-kind " + kind;
      water += draw_option(d, "--water-attenuation", 0.03, 0.6, 3);
    }
    // Half the shores sharp (no capillary fringe: the dry pairs' bottom unwetted up to the water), half
    // wetted a few millimetres above the surface.
    water += i % 2 == 1 ? std::string(" --wet-fringe 0") : draw_option(d, "--wet-fringe", 1, 4, 1);
    const std::string rig = rig_and_rut(d, texture, depth, 3100 + i);
    out.push_back(
        {fmt::format("entry-{}-{}-{:02d}", kind, texture, i), "entry", "entry-" + kind, {"Water"}, rig + water});
  }
}

}  // namespace

std::vector<MatrixScene> scene_matrix() {
  std::vector<MatrixScene> scenes;
  add_water(scenes);
  add_lids(scenes);
  add_lens_faults(scenes);
  add_dark(scenes);
  add_clean(scenes);
  add_steep(scenes);
  add_tread(scenes);
  add_skew(scenes);
  add_entries(scenes);
  return scenes;
}

}  // namespace rutd
