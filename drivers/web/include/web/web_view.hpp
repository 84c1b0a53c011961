#pragma once
// What the live view shows, built on the view thread from the pairs, samples, statuses and segments the
// publish thread handed over (web/live_view.hpp), and served as it is by the HTTP threads: each build is a
// new immutable WebContent, shared until the last request that holds it is answered. The figures and
// their JSON are documented in docs/web.md.
#include <cstdint>
#include <deque>
#include <memory>
#include <string>

#include "core/measurement_sink.hpp"
#include "core/stereo_calibration.hpp"
#include "web/aiming.hpp"
#include "web/web_frame.hpp"

namespace rutd {

// What the view needs of the rig to draw the strip and the rut on the raw camera images.
struct WebContext {
  StereoCalibration calibration;
  StereoRectification rectification;
};

struct WebContent {
  std::uint64_t seq = 0;              // the pair shown; 0 before the first
  std::string live_json;              // GET /api/live.json
  std::string history_json;           // GET /api/history.json
  std::string left_jpeg, right_jpeg;  // the raw images with the strip, rut edges and deepest point drawn
  std::string strip_png;              // the rectified strips, left over right, with the same marks
};

// Every published pair, small: for the last minute's depth and the frame rate.
struct WebSample {
  std::int64_t t_ns = 0;
  float depth_mm = 0;
  RutStatus status = RutStatus::NoMeasurement;
  std::uint8_t conditions = 0;
};

// Counts of the hand-over, reported in every live JSON (the view's own health).
struct WebHandoff {
  std::uint64_t pairs_offered = 0;  // pairs the rate limit let through
  std::uint64_t pairs_dropped = 0;  // of those, dropped: the view thread still had both slots
  std::uint64_t samples_dropped = 0;
  std::uint64_t requests = 0, refused = 0;  // HTTP requests answered; of those, with a 4xx
};

class WebView {
 public:
  explicit WebView(WebContext context);

  // View thread only, in any order.
  void add_sample(const WebSample& s);
  void add_status(const SensorHealth& health, std::int64_t t_ns);
  void add_segment(const Segment& segment);
  // Draws and encodes the pair's images and takes its figures for the next build.
  void add_frame(const WebFrame& frame);
  // The content for the figures so far; `now_ns` on the frames' clock, for the ages shown.
  std::shared_ptr<const WebContent> build(std::int64_t now_ns, const WebHandoff& handoff) const;

 private:
  struct Bin {             // 100 ms of samples
    std::int64_t key = 0;  // t_ns / 100 ms
    float depth_max = 0, depth_last = 0;
    bool has_depth = false;
    RutStatus worst = RutStatus::Ok;
    std::uint8_t conditions = 0;
    std::uint32_t frames = 0, ok = 0;
  };
  std::string live_json(std::int64_t now_ns, const WebHandoff& handoff) const;
  std::string history_json(std::int64_t now_ns) const;

  WebContext context_;
  WebFrame frame_;  // the last pair shown (its figures; images encoded below)
  bool have_frame_ = false;
  CameraAiming left_aiming_, right_aiming_;
  std::string left_jpeg_, right_jpeg_, strip_png_;
  SensorHealth health_;
  std::int64_t health_t_ns_ = 0;
  bool have_health_ = false;
  std::deque<Bin> bins_;             // the last minute, oldest first
  std::deque<std::int64_t> recent_;  // capture times of the last second's samples, for the frame rate
  std::deque<Segment> segments_;     // the last 100
  std::uint64_t segments_seen_ = 0;
  std::int64_t newest_t_ns_ = 0;
};

}  // namespace rutd
