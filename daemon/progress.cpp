#include "daemon/progress.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

namespace rutd {

bool progress_wanted(int fd) {
  if (std::getenv("INVOCATION_ID") != nullptr || std::getenv("JOURNAL_STREAM") != nullptr) return false;
  return ::isatty(fd) == 1;
}

ProgressLine::ProgressLine(std::string what, std::uint64_t total)
    : ProgressLine(std::move(what), total, stderr, progress_wanted(STDERR_FILENO), std::chrono::seconds(2)) {}

ProgressLine::ProgressLine(std::string what, std::uint64_t total, std::FILE* out, bool enabled,
                           std::chrono::milliseconds delay)
    : what_(std::move(what)),
      total_(total),
      out_(out),
      enabled_(enabled),
      delay_(delay),
      start_(std::chrono::steady_clock::now()),
      next_draw_(start_ + delay_) {}

ProgressLine::~ProgressLine() { clear(); }

std::string ProgressLine::text(std::uint64_t done, double elapsed_s) const {
  const double rate = elapsed_s > 0 ? static_cast<double>(done) / elapsed_s : 0.0;
  std::string s = total_ > 0 ? fmt::format("{} {}/{} pairs  {:.1f} /s", what_, done, total_, rate)
                             : fmt::format("{} {} pairs  {:.1f} /s", what_, done, rate);
  if (total_ > 0 && rate > 0 && done <= total_) {
    const auto left = static_cast<long>(std::lround(static_cast<double>(total_ - done) / rate));
    s += fmt::format("  {}:{:02d} left", left / 60, left % 60);
  }
  return s;
}

void ProgressLine::update(std::uint64_t done) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now < next_draw_) return;
  next_draw_ = now + std::chrono::milliseconds(250);
  const std::string line = text(done, std::chrono::duration<double>(now - start_).count());
  // \r and erase-to-end-of-line: the line is redrawn in place, whatever its previous length.
  std::fprintf(out_, "\r%s\x1b[K", line.c_str());
  std::fflush(out_);
  drawn_ = true;
}

void ProgressLine::clear() {
  if (!drawn_) return;
  std::fprintf(out_, "\r\x1b[K");
  std::fflush(out_);
  drawn_ = false;
}

}  // namespace rutd
