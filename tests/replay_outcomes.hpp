#pragma once
// `rutd replay` of a synthetic recording, its CSV judged against the renderer's truth.csv: how many
// frames were published OK, and how many of those lie beyond 1 mm of the truth (each such frame is also
// a test failure naming it). Shared by the tests that compare a measurement option on and off.
#include <cmath>
#include <span>
#include <string>

#include <gtest/gtest.h>

#include "recording/measurement_csv.hpp"
#include "synthetic/truth_csv.hpp"
#include "test_support.hpp"

namespace rutd::test {

struct ReplayOutcomes {
  int frames = 0, ok = 0, ok_beyond_1mm = 0;
  std::string logs;  // the replays' standard error, one after the other
};

// Replays rec with `options` (files written into tmp, named by `tag`), adding its outcomes to `count`.
inline void replay_and_count(const std::string& rec, const std::string& options, const TempDir& tmp, int tag,
                             ReplayOutcomes& count) {
  const std::string csv = (tmp.path() / ("m" + std::to_string(tag) + ".csv")).string();
  const std::string err = (tmp.path() / ("err" + std::to_string(tag) + ".txt")).string();
  ASSERT_EQ(run_rutd("replay " + rec + " --out " + csv + " " + options, err), 0) << read_text(err);
  count.logs += read_text(err);
  const auto rows = read_measurement_csv(csv).rows;
  const auto truth = read_truth_csv(rec + "/truth.csv");
  ASSERT_EQ(rows.size(), truth.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    ++count.frames;
    if (rows[i].measurement.status != RutStatus::Ok) continue;
    ++count.ok;
    const double error = rows[i].measurement.depth_mm - truth[i].depth_mm;
    if (std::abs(error) > 1.0) ++count.ok_beyond_1mm;
    EXPECT_LE(std::abs(error), 1.0) << options << " frame " << i << " of " << rec;
  }
}

// Renders each scene (`rutd synth` options) as `frames` pairs, and replays it with the defaults (into
// `with`) and with `off` added (into `without`); every frame counted in both.
inline void replay_with_and_without(std::span<const char* const> scenes, int frames, const std::string& off,
                                    ReplayOutcomes& with, ReplayOutcomes& without) {
  int tag = 0;
  for (const char* scene : scenes) {
    const TempDir tmp;
    const std::string rec = (tmp.path() / "rec").string();
    ASSERT_EQ(run_rutd("synth " + rec + " --frames " + std::to_string(frames) + " " + scene), 0);
    replay_and_count(rec, "", tmp, ++tag, with);
    replay_and_count(rec, off, tmp, ++tag, without);
  }
  ASSERT_EQ(with.frames, frames * static_cast<int>(scenes.size()));
  ASSERT_EQ(without.frames, with.frames);
}

}  // namespace rutd::test
