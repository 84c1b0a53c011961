#include "core/rut_measurement.hpp"

namespace rutd {

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
