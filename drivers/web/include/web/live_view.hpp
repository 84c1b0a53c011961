#pragma once
// The live view (docs/web.md): a MeasurementSink that hands a few pairs a second to a view thread of its
// own, which draws and encodes them, and an HTTP server (cpp-httplib, private) whose worker threads serve
// what the view thread built last. The publish thread only copies into a preallocated slot and pushes
// pointers through lock-free bounded queues: a pair that finds no free slot, or a sample that finds its
// queue full, is dropped and counted, so no number of clients can slow the measurement. The view's threads
// run at nice 10, below the pipeline's.
//
// Thread safety: publish, publish_status and publish_segment from the publish thread only (the sink
// contract); port() and stats() from any thread; stop() from the thread that owns the object.
#include <memory>

#include "core/measurement_sink.hpp"
#include "web/web_config.hpp"
#include "web/web_view.hpp"

namespace rutd {

class WebLiveView final : public MeasurementSink {
 public:
  // Reads the token file when one is configured, binds and starts serving. Start-up errors: throws
  // std::invalid_argument naming the token file when it is unusable, std::runtime_error naming the
  // address when it cannot listen there.
  WebLiveView(const WebConfig& config, WebContext context);
  ~WebLiveView() override;  // stop()
  WebLiveView(const WebLiveView&) = delete;
  WebLiveView& operator=(const WebLiveView&) = delete;

  int port() const noexcept;  // the port listened on (the configured one, or the one chosen for 0)

  void publish(const PublishedFrame& frame) override;
  void publish_status(const SensorHealth& health, std::int64_t t_ns) override;
  void publish_segment(const Segment& segment) override;

  // Stops serving and joins the threads; later publishes are ignored. Idempotent.
  void stop();
  WebHandoff stats() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rutd
