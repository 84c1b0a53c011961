#include "rut/rut_measurement.hpp"

namespace rutd {

std::string_view to_string(RutStatus status) noexcept {
  switch (status) {
    case RutStatus::Ok: return "OK";
    case RutStatus::NoRut: return "NO_RUT";
    case RutStatus::TooFewPoints: return "TOO_FEW_POINTS";
    case RutStatus::NoGround: return "NO_GROUND";
    case RutStatus::RutAtEdge: return "RUT_AT_EDGE";
    case RutStatus::NoMeasurement: return "NO_MEASUREMENT";
  }
  return "UNKNOWN";
}

}  // namespace rutd
