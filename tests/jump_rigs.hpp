#pragma once
// A jump of the terrain for band-tracking tests: two renderings of one rig calibration, the rig standing
// 350 mm (45 mm rut) and 270 mm (30 mm rut) above the ground, about 30 % apart in disparity, far outside
// any band kept for the other.
#include "synthetic/synthetic_renderer.hpp"

namespace rutd::test {

struct JumpRigs {
  static SyntheticRendererConfig high_config() {
    SyntheticRendererConfig c;
    c.rut.depth_mm = 45;
    return c;
  }
  static SyntheticRendererConfig low_config() {
    SyntheticRendererConfig c = high_config();
    c.rig.height_mm = 270;
    c.rut.depth_mm = 30;
    return c;
  }
  const SyntheticRenderer high{high_config()}, low{low_config()};
};

}  // namespace rutd::test
