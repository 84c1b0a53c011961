#include "can/vehicle_speed.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace rutd {

std::string check_vehicle_speed_config(const VehicleSpeedConfig& c, const std::string& key) {
  const SpeedSignalLayout& s = c.signal;
  if (s.length < 1 || s.length > 32) return key + ": signal length must be 1..32 bits";
  if (s.start_bit < 0 || s.start_bit > 63) return key + ": signal start bit must be 0..63";
  if (s.little_endian && s.start_bit + s.length > 64) return key + ": signal does not fit in 8 bytes";
  if (!std::isfinite(s.factor_mm_s) || s.factor_mm_s == 0 || !std::isfinite(s.offset_mm_s))
    return key + ": signal factor must be finite and not 0, offset finite";
  if (s.id > (s.extended ? 0x1FFFFFFFu : 0x7FFu)) return key + ": identifier out of range";
  if (c.source_address < -1 || c.source_address > 0xFD) return key + ".source_address: must be 0..253 or any";
  if (!(c.max_speed_mm_s > 0)) return key + ".max_speed_kmh: must be > 0";
  if (!(c.max_accel_mm_s2 > 0)) return key + ".max_accel_m_s2: must be > 0";
  if (c.min_interval_ns < 0 || c.min_interval_ns > 1'000'000'000) return key + ".min_interval_ms: must be 0..1000";
  return {};
}

std::optional<std::uint64_t> extract_signal_raw(const CanFrame& f, int start_bit, int length,
                                                bool little_endian) noexcept {
  if (length < 1 || length > 64 || start_bit < 0 || start_bit > 63) return std::nullopt;
  std::uint64_t raw = 0;
  if (little_endian) {
    // Bits start_bit .. start_bit+length-1, bit i = byte i/8, bit i%8.
    const int last = start_bit + length - 1;
    if (last > 63 || last / 8 >= f.len) return std::nullopt;
    for (int i = length - 1; i >= 0; --i) {
      const int b = start_bit + i;
      raw = (raw << 1) | ((f.data[b / 8] >> (b % 8)) & 1U);
    }
  } else {
    // Motorola: start_bit is the most significant bit; walk down within a byte, then to the next byte.
    int b = start_bit;
    for (int i = 0; i < length; ++i) {
      if (b < 0 || b > 63 || b / 8 >= f.len) return std::nullopt;
      raw = (raw << 1) | ((f.data[b / 8] >> (b % 8)) & 1U);
      b = (b % 8 == 0) ? b + 15 : b - 1;
    }
  }
  return raw;
}

CanFrame encode_ccvs1(double speed_kmh, std::uint8_t source_address) noexcept {
  CanFrame f;
  f.extended = true;
  f.id = (6U << 26) | (0xFEF1U << 8) | source_address;
  f.len = 8;
  f.data.fill(0xFF);
  if (std::isfinite(speed_kmh)) {
    const double raw = std::min(std::round(std::abs(speed_kmh) * 256.0), 64255.0);  // 0xFAFF
    const auto r = static_cast<std::uint16_t>(raw);
    f.data[1] = static_cast<std::uint8_t>(r & 0xFF);
    f.data[2] = static_cast<std::uint8_t>(r >> 8);
  }
  return f;
}

CanFrame encode_etc2_gear(int gear, std::uint8_t source_address) noexcept {
  CanFrame f;
  f.extended = true;
  f.id = (3U << 26) | (0xF005U << 8) | source_address;
  f.len = 8;
  f.data.fill(0xFF);
  f.data[3] = static_cast<std::uint8_t>(std::clamp(gear + 125, 0, 250));
  return f;
}

VehicleSpeedDecoder::VehicleSpeedDecoder(VehicleSpeedConfig config) : config_(std::move(config)) {
  if (const std::string e = check_vehicle_speed_config(config_, "trafficability.speed"); !e.empty())
    throw std::invalid_argument(e);
}

bool VehicleSpeedDecoder::is_speed_id(const CanFrame& f) const noexcept {
  const SpeedSignalLayout& s = config_.signal;
  return f.extended == s.extended && (f.id & s.id_mask) == (s.id & s.id_mask);
}

bool VehicleSpeedDecoder::is_gear_id(const CanFrame& f) const noexcept {
  return config_.direction_from_gear && f.extended && (f.id & kJ1939PgnMask) == kEtc2Id;
}

SpeedSample VehicleSpeedDecoder::make(std::int64_t t_ns, SpeedState state, double speed_mm_s) noexcept {
  ++stats_.samples;
  if (state == SpeedState::Ok) ++stats_.ok;
  return {t_ns, state, state == SpeedState::Ok ? speed_mm_s : 0.0};
}

std::optional<SpeedSample> VehicleSpeedDecoder::on_frame(const CanFrame& f, std::int64_t t_ns) noexcept {
  ++stats_.frames;
  const bool speed = is_speed_id(f);
  const bool gear = !speed && is_gear_id(f);
  if (!speed && !gear) {
    ++stats_.other_id;
    return std::nullopt;
  }
  if (speed && f.extended && config_.source_address >= 0 && static_cast<int>(f.id & 0xFF) != config_.source_address) {
    ++stats_.spoofed;
    return std::nullopt;
  }
  if (gear) {
    if (f.len < 4) {
      ++stats_.wrong_length;
      return std::nullopt;
    }
    ++stats_.gear_frames;
    const int raw = f.data[3];
    gear_known_ = raw <= 251;
    gear_ = raw < 125 ? -1 : (raw > 125 && raw <= 250) ? 1 : 0;
    return std::nullopt;
  }
  const SpeedSignalLayout& s = config_.signal;
  const auto raw = extract_signal_raw(f, s.start_bit, s.length, s.little_endian);
  if (!raw) {
    ++stats_.wrong_length;
    return std::nullopt;
  }
  if (have_accepted_ && t_ns - last_accepted_ns_ < config_.min_interval_ns) {
    ++stats_.burst;
    return std::nullopt;
  }
  have_accepted_ = true;
  last_accepted_ns_ = t_ns;
  if (s.j1939_ranges && s.length >= 8) {
    // The top of the range in units of the parameter's width: for n bits, all ones is not available,
    // the 2^(n-8) values below are error, and those below 0xFB << (n-8) are reserved (J1939-71 5.1.4).
    const std::uint64_t unit = std::uint64_t{1} << (s.length - 8);
    if (*raw >= 0xFF * unit) {
      ++stats_.not_available;
      return make(t_ns, SpeedState::NotAvailable, 0);
    }
    if (*raw >= 0xFE * unit) {
      ++stats_.error_value;
      return make(t_ns, SpeedState::Error, 0);
    }
    if (*raw >= 0xFB * unit) {
      ++stats_.out_of_range;
      return make(t_ns, SpeedState::Error, 0);
    }
  }
  double value = 0;
  if (s.is_signed && s.length < 64 && (*raw >> (s.length - 1)) != 0) {
    value = static_cast<double>(static_cast<std::int64_t>(*raw) - (std::int64_t{1} << s.length));
  } else {
    value = static_cast<double>(*raw);
  }
  double v = value * s.factor_mm_s + s.offset_mm_s;
  if (!std::isfinite(v) || std::abs(v) > config_.max_speed_mm_s) {
    ++stats_.out_of_range;
    have_value_ = false;
    return make(t_ns, SpeedState::Error, 0);
  }
  const bool jump =
      have_value_ && t_ns > last_value_ns_ &&
      std::abs(v - last_value_mm_s_) > config_.max_accel_mm_s2 * static_cast<double>(t_ns - last_value_ns_) * 1e-9;
  have_value_ = true;
  last_value_mm_s_ = v;
  last_value_ns_ = t_ns;
  if (jump) {
    ++stats_.implausible;
    return make(t_ns, SpeedState::Error, 0);
  }
  if (config_.direction_from_gear && v != 0) {
    if (!gear_known_ || gear_ == 0) {
      ++stats_.direction_unknown;
      return make(t_ns, SpeedState::NotAvailable, 0);
    }
    v = std::abs(v) * gear_;
  }
  return make(t_ns, SpeedState::Ok, v);
}

}  // namespace rutd
