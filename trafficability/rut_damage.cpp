#include "trafficability/rut_damage.hpp"

#include <utility>

namespace rutd {

RutDamage::RutDamage(std::vector<RutDamageRule> rules) : rules_(std::move(rules)), runs_(rules_.size()) {}

void RutDamage::add(double distance_m, const RutMeasurement& m) noexcept {
  if (have_previous_) {
    // The previous measurement covers [previous_m_, distance_m).
    const double covered = distance_m - previous_m_;
    const bool measured = previous_status_ == RutStatus::Ok || previous_status_ == RutStatus::NoRut;
    for (std::size_t i = 0; i < rules_.size(); ++i) {
      Run& r = runs_[i];
      (measured ? r.done.measured_m : r.done.unmeasured_m) += covered;
      if (previous_status_ == RutStatus::Ok && previous_depth_mm_ > rules_[i].depth_mm) {
        r.stretch_m += covered;
        continue;
      }
      if (r.stretch_m >= rules_[i].min_length_m) {
        r.done.rutted_m += r.stretch_m;
        ++r.done.stretches;
      }
      r.stretch_m = 0;
    }
  }
  have_previous_ = true;
  previous_m_ = distance_m;
  previous_status_ = m.status;
  previous_depth_mm_ = m.depth_mm;
}

RutDamageFigures RutDamage::figures(std::size_t rule) const noexcept {
  RutDamageFigures f = runs_[rule].done;
  if (runs_[rule].stretch_m >= rules_[rule].min_length_m) {
    f.rutted_m += runs_[rule].stretch_m;
    ++f.stretches;
  }
  return f;
}

}  // namespace rutd
