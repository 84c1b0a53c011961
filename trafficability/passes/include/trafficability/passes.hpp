#pragma once
// Passes over the same ground. The paper: "rut measurements of multiple passes over the same terrain can
// assist in determining eventual sinkage levels". A later drive's segments (core/track.hpp, each with the
// position at its middle) are matched to an earlier drive's: the nearest earlier segment whose position
// lies within the two fixes' reported errors (their 95 % horizontal errors combined) and whose heading
// differs by at most a tolerance (same direction of travel: the camera behind the tyre sees the rut the
// same way round); matches count only on stretches of at least min_common_m in common, so that a track
// that merely crosses or touches the earlier one is not a pass. Each match reports the sinkage increase
// (later mean depth minus earlier) with its standard uncertainty.
//
// Pure: no threads, no I/O. Positions are turned into local metres around the earlier drive's first fix
// (equirectangular: under 1 mm of error per kilometre of track at mid latitudes, far below GNSS error).
// Brute-force nearest search: O(later x earlier) segments, a few milliseconds for kilometres of 1 m
// segments.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/track.hpp"

namespace rutd {

struct PassConfig {
  double heading_tolerance_deg = 30.0;  // |later heading - earlier heading| at most this
  double min_common_m = 3.0;            // a stretch in common shorter than this is no pass
  // A segment whose fix reports no error (NaN) is matched as if it reported this much (95 %, metres);
  // never 0, which would make a match depend on exact equality of noisy positions.
  double default_error_m = 5.0;
};

struct SegmentMatch {
  std::size_t later = 0;    // index into the later drive's segments
  std::size_t earlier = 0;  // index into the earlier drive's segments
  double distance_m = 0.0;  // between their positions
  double allowed_m = 0.0;   // the combined reported error it had to be within
  double heading_difference_deg = 0.0;
  // Later mean depth minus earlier (NaN unless both were measured), and its standard uncertainty from the
  // two segments' depth uncertainties (NaN when either lacks one).
  double sinkage_increase_mm = 0.0;
  double sinkage_increase_uncertainty_mm = 0.0;
};

// Matches `later` to `earlier` (both in travel order). Segments without a valid position or heading are
// never matched. Returns the matches in the later drive's order.
std::vector<SegmentMatch> match_pass(const std::vector<Segment>& earlier, const std::vector<Segment>& later,
                                     const PassConfig& config = {});

// Several drives in the order they were driven: sets every segment's `pass` (0: no earlier drive covered
// it; otherwise one more than the pass of the segment it matched in the latest earlier drive that covered
// it) and returns, per drive, its matches to that latest covering drive (matches[d][i].earlier indexes
// drive `covering[d][i]`).
struct PassNumbering {
  std::vector<std::vector<SegmentMatch>> matches;
  std::vector<std::vector<std::size_t>> covering;
};
PassNumbering number_passes(std::vector<std::vector<Segment>>& drives, const PassConfig& config = {});

// Metres between two fixes (local equirectangular approximation; NaN when either is not valid).
double ground_distance_m(const GeoFix& a, const GeoFix& b);

}  // namespace rutd
