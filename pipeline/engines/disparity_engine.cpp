#include "engines/disparity_engine.hpp"

namespace rutd {

std::optional<EngineKind> parse_engine(std::string_view name) {
  for (EngineKind kind : {EngineKind::Bm, EngineKind::Sgbm, EngineKind::Sgbm3Way, EngineKind::Hh4, EngineKind::Hh,
                          EngineKind::Gpu, EngineKind::SgmRef}) {
    if (name == to_string(kind)) return kind;
  }
  return std::nullopt;
}

std::string_view to_string(EngineKind kind) {
  switch (kind) {
    case EngineKind::Bm: return "bm";
    case EngineKind::Sgbm: return "sgbm";
    case EngineKind::Sgbm3Way: return "sgbm3way";
    case EngineKind::Hh4: return "hh4";
    case EngineKind::Hh: return "hh";
    case EngineKind::Gpu: return "gpu";
    case EngineKind::SgmRef: return "sgmref";
  }
  return "unknown";
}

}  // namespace rutd
