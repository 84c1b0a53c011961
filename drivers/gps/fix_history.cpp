#include "gps/fix_history.hpp"

#include <cmath>

namespace rutd {

void complete_from_same_epoch(GeoFix& fix, const GeoFix& previous) noexcept {
  if (!fix.valid() || !previous.valid()) return;
  if (fix.utc_ns != 0 && fix.utc_ns == previous.utc_ns) {
    for (auto member : {&GeoFix::altitude_m, &GeoFix::horizontal_error_m, &GeoFix::heading_deg, &GeoFix::speed_m_s})
      if (std::isnan(fix.*member)) fix.*member = previous.*member;
  } else if (fix.t_ns - previous.t_ns <= kHeadingCarryNs) {
    for (auto member : {&GeoFix::heading_deg, &GeoFix::speed_m_s})
      if (std::isnan(fix.*member)) fix.*member = previous.*member;
  }
}

bool FixHistory::add(const GeoFix& fix) noexcept {
  GeoFix kept = fix;
  if (count_ > 0) {
    const GeoFix& last = ring_[(next_ + kCapacity - 1) % kCapacity];
    if (fix.t_ns < last.t_ns) return false;
    complete_from_same_epoch(kept, last);
  }
  ring_[next_] = kept;
  next_ = (next_ + 1) % kCapacity;
  if (count_ < kCapacity) ++count_;
  return true;
}

GeoFix FixHistory::at(std::int64_t t_ns, std::int64_t max_age_ns) const noexcept {
  GeoFix none;
  none.mode = GeoFix::Mode::NoFix;
  // Newest first: the first fix received at or before t_ns is the one in force.
  for (std::size_t i = 1; i <= count_; ++i) {
    const GeoFix& f = ring_[(next_ + kCapacity - i) % kCapacity];
    if (f.t_ns > t_ns) continue;
    if (!f.valid() || t_ns - f.t_ns > max_age_ns) {
      none.t_ns = f.t_ns;
      return none;
    }
    return f;
  }
  return none;  // every fix kept arrived after t_ns: none known in force then
}

}  // namespace rutd

#include <algorithm>

#include "gps/position_source.hpp"

namespace rutd {

RecordedPositions::RecordedPositions(std::vector<GeoFix> fixes, std::int64_t max_age_ns) : max_age_ns_(max_age_ns) {
  fixes_.reserve(fixes.size());
  for (GeoFix f : fixes) {
    if (fixes_.empty()) {
      fixes_.push_back(f);
    } else if (f.t_ns >= fixes_.back().t_ns) {
      complete_from_same_epoch(f, fixes_.back());
      fixes_.push_back(f);
    }
  }
}

GeoFix RecordedPositions::position_at(std::int64_t t_ns) const {
  GeoFix none;
  none.mode = GeoFix::Mode::NoFix;
  // The first fix received after t_ns; the one before it is in force (as FixHistory::at).
  const auto after =
      std::upper_bound(fixes_.begin(), fixes_.end(), t_ns, [](std::int64_t t, const GeoFix& f) { return t < f.t_ns; });
  if (after == fixes_.begin()) return none;
  const GeoFix& f = *(after - 1);
  if (!f.valid() || t_ns - f.t_ns > max_age_ns_) {
    none.t_ns = f.t_ns;
    return none;
  }
  return f;
}

}  // namespace rutd
