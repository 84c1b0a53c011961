#pragma once
// "640x480", "9x6": the one text form of a width and height on rutd's command line and configuration.
#include <optional>
#include <sstream>
#include <string>

#include <opencv2/core.hpp>

namespace rutd {

// WIDTHxHEIGHT with both in [min, max]; nullopt for anything else.
inline std::optional<cv::Size> parse_dimensions(const std::string& text, int min, int max) {
  int w = 0, h = 0;
  char x = 0;
  std::istringstream in(text);
  if (!(in >> w >> x >> h) || x != 'x' || !in.eof() || w < min || h < min || w > max || h > max) return std::nullopt;
  return cv::Size(w, h);
}

}  // namespace rutd
