#include "core/rut_measurement.hpp"

#include <array>

namespace rutd {

namespace {

constexpr std::array<std::uint8_t, kRutStatusCount> kStatusSeverity = {
    0,   // Ok
    1,   // NoRut
    6,   // TooFewPoints
    7,   // NoGround
    5,   // RutAtEdge
    12,  // NoMeasurement
    11,  // LensObstructed
    8,   // BadExposure
    10,  // CalibrationDrift
    4,   // BottomNotSeen
    3,   // Vegetation
    2,   // Uncertain
    9,   // Unsynchronised
};

}  // namespace

int status_severity(RutStatus status) noexcept {
  const auto i = static_cast<std::size_t>(status);
  return i < kStatusSeverity.size() ? kStatusSeverity[i] : kRutStatusCount;
}

std::string_view to_string(RutStatus status) noexcept {
  switch (status) {
    case RutStatus::Ok: return "OK";
    case RutStatus::NoRut: return "NO_RUT";
    case RutStatus::TooFewPoints: return "TOO_FEW_POINTS";
    case RutStatus::NoGround: return "NO_GROUND";
    case RutStatus::RutAtEdge: return "RUT_AT_EDGE";
    case RutStatus::NoMeasurement: return "NO_MEASUREMENT";
    case RutStatus::LensObstructed: return "LENS_OBSTRUCTED";
    case RutStatus::BadExposure: return "BAD_EXPOSURE";
    case RutStatus::CalibrationDrift: return "CALIBRATION_DRIFT";
    case RutStatus::BottomNotSeen: return "BOTTOM_NOT_SEEN";
    case RutStatus::Vegetation: return "VEGETATION";
    case RutStatus::Uncertain: return "UNCERTAIN";
    case RutStatus::Unsynchronised: return "UNSYNCHRONISED";
  }
  return "UNKNOWN";
}

}  // namespace rutd
