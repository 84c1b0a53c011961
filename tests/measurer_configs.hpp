#pragma once
// Measurer configurations the water and guard tests compare against the defaults.
#include "measurement/measurer.hpp"

namespace rutd::test {

// The measured strip's own judgement: no guard strips (StripConfig::guards), so neither their water checks
// nor their reading of a noisy depth together with the strip (tests/integration/test_guard_strips.cpp).
inline MeasurerConfig strip_alone() {
  MeasurerConfig c;
  c.strip.guards = 0;
  return c;
}

}  // namespace rutd::test
