#include "core/track.hpp"

namespace rutd {

std::string_view to_string(Advisory advisory) noexcept {
  switch (advisory) {
    case Advisory::Unknown: return "UNKNOWN";
    case Advisory::Go: return "GO";
    case Advisory::Caution: return "CAUTION";
    case Advisory::NoGo: return "NO_GO";
  }
  return "UNKNOWN";
}

std::string_view to_string(SpeedState state) noexcept {
  switch (state) {
    case SpeedState::Ok: return "OK";
    case SpeedState::NotAvailable: return "NOT_AVAILABLE";
    case SpeedState::Error: return "ERROR";
    case SpeedState::Stale: return "STALE";
    case SpeedState::NoSource: return "NO_SOURCE";
  }
  return "NO_SOURCE";
}

}  // namespace rutd
