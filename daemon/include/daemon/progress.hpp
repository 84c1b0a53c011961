#pragma once
// A one-line progress display for long commands (replay, bench, synth): pairs done / total, rate and
// time left, redrawn in place on stderr at most 4 times a second once the work has run for a couple of
// seconds. Shown only on a terminal: nothing at all when stderr is a file or pipe, or under systemd
// (INVOCATION_ID or JOURNAL_STREAM set), so logs and scripts never see it. Main thread only.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

namespace rutd {

// Whether a progress line belongs on `fd`: a terminal, and not a systemd service's stream.
bool progress_wanted(int fd);

class ProgressLine {
 public:
  // what: "replay", "table 1", ... total: 0 when unknown (then no time left is shown).
  ProgressLine(std::string what, std::uint64_t total);
  // For tests: draw on `out` when `enabled`, after `delay`.
  ProgressLine(std::string what, std::uint64_t total, std::FILE* out, bool enabled, std::chrono::milliseconds delay);
  ~ProgressLine();  // clear()
  void update(std::uint64_t done);
  void set_total(std::uint64_t total) { total_ = total; }
  // Erases the line (before other output, and at the end).
  void clear();
  // The text for `done` pairs after `elapsed_s` seconds, e.g. "replay 120/400 pairs  31.2 /s  0:09 left".
  std::string text(std::uint64_t done, double elapsed_s) const;

 private:
  std::string what_;
  std::uint64_t total_;
  std::FILE* out_;
  bool enabled_;
  std::chrono::steady_clock::duration delay_;
  std::chrono::steady_clock::time_point start_, next_draw_;
  bool drawn_ = false;
};

}  // namespace rutd
