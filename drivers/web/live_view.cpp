#include "web/live_view.hpp"

#include <httplib.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include <boost/lockfree/spsc_queue.hpp>

#include "core/monotonic_clock.hpp"
#include "core/slot_queue.hpp"
#include "web/web_routes.hpp"
#include "web_http.hpp"

namespace rutd {
namespace {

// The view's threads yield to the pipeline's: nice 10 weighs a tenth of a normal thread, and a waking
// pipeline thread preempts them. Not SCHED_IDLE: on a machine kept busy by other work, the page would
// freeze altogether (measured: a minute without an answer beside two busy loops).
void lower_priority() { ::setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), 10); }

// cpp-httplib's connection tasks on a fixed number of threads with a bounded backlog: when it is full the
// accepting thread waits, so further connections wait in the kernel's listen queue (itself bounded).
class BoundedPool final : public httplib::TaskQueue {
 public:
  BoundedPool(int threads, std::size_t backlog) : backlog_(backlog) {
    for (int i = 0; i < threads; ++i) threads_.emplace_back([this] { work(); });
  }
  void enqueue(std::function<void()> fn) override {
    std::unique_lock lock(mutex_);
    room_.wait(lock, [&] { return jobs_.size() < backlog_ || shutdown_; });
    if (shutdown_) return;  // cpp-httplib has closed its listening socket; the task would find none
    jobs_.push_back(std::move(fn));
    ready_.notify_one();
  }
  void shutdown() override {
    {
      const std::lock_guard lock(mutex_);
      shutdown_ = true;
    }
    ready_.notify_all();
    room_.notify_all();
    for (std::thread& t : threads_) t.join();
  }

 private:
  void work() {
    lower_priority();
    for (;;) {
      std::function<void()> fn;
      {
        std::unique_lock lock(mutex_);
        ready_.wait(lock, [&] { return !jobs_.empty() || shutdown_; });
        if (jobs_.empty()) return;  // shut down, and every accepted connection answered
        fn = std::move(jobs_.front());
        jobs_.pop_front();
      }
      room_.notify_one();
      fn();
    }
  }

  std::size_t backlog_;
  std::mutex mutex_;
  std::condition_variable ready_, room_;
  std::deque<std::function<void()>> jobs_;
  bool shutdown_ = false;
  std::vector<std::thread> threads_;
};

struct StatusItem {
  SensorHealth health;
  std::int64_t t_ns = 0;
};

constexpr std::size_t kSlots = 2;

}  // namespace

struct WebLiveView::Impl {
  Impl(const WebConfig& c, WebContext context)
      : config(c),
        min_interval_ns(static_cast<std::int64_t>(1e9 / c.rate_hz)),
        routes(c.token_file.empty() ? std::string() : read_web_token(c.token_file)),
        view(std::move(context)),
        ready(kSlots),
        free(kSlots),
        samples(8192),
        statuses(64),
        segments(256) {
    for (WebFrame& f : frames) free.push(&f);
  }

  WebConfig config;
  std::int64_t min_interval_ns;
  WebRoutes routes;
  WebView view;  // view thread only
  std::array<WebFrame, kSlots> frames;
  SlotQueue<WebFrame> ready, free;  // publish -> view, view -> publish
  boost::lockfree::spsc_queue<WebSample> samples;
  boost::lockfree::spsc_queue<StatusItem> statuses;
  boost::lockfree::spsc_queue<Segment> segments;
  std::int64_t last_offer_ns = 0;  // publish thread
  std::atomic<std::uint64_t> offered{0}, dropped{0}, samples_dropped{0};
  WebHttpCounters counters;
  // The frames' clock against this machine's, at the newest sample: the view's "now" (ages of figures).
  std::atomic<std::int64_t> newest_t_ns{0}, newest_at_ns{0};

  mutable std::mutex content_mutex;
  std::shared_ptr<const WebContent> content;  // guarded by content_mutex

  httplib::Server server;
  int port = 0;
  std::thread http_thread, view_thread;
  std::atomic<bool> stopping{false};
  bool stopped = false;

  std::shared_ptr<const WebContent> current() const {
    const std::lock_guard lock(content_mutex);
    return content;
  }
  WebHandoff handoff() const {
    return WebHandoff{offered.load(), dropped.load(), samples_dropped.load(), counters.requests.load(),
                      counters.refused.load()};
  }
  void view_loop();
};

void WebLiveView::Impl::view_loop() {
  lower_priority();
  std::int64_t last_build = 0;
  while (!stopping.load(std::memory_order_acquire)) {
    const std::uint64_t since = ready.mark();
    WebSample s;
    while (samples.pop(s)) view.add_sample(s);
    StatusItem st;
    while (statuses.pop(st)) view.add_status(st.health, st.t_ns);
    Segment seg;
    while (segments.pop(seg)) view.add_segment(seg);
    WebFrame* f = ready.pop();
    if (f != nullptr) {
      view.add_frame(*f);
      free.push(f);
    }
    const std::int64_t mono = monotonic_now_ns();
    // Twice a second at least, with or without pairs: the page shows a lost camera as it happens.
    if (f != nullptr || mono - last_build >= 250'000'000) {
      const std::int64_t at = newest_at_ns.load(std::memory_order_relaxed);
      const std::int64_t now = at == 0 ? 0 : newest_t_ns.load(std::memory_order_relaxed) + (mono - at);
      auto built = view.build(now, handoff());
      const std::lock_guard lock(content_mutex);
      content = std::move(built);
      last_build = mono;
    }
    if (f == nullptr) ready.wait(since, std::chrono::milliseconds(100));
  }
}

WebLiveView::WebLiveView(const WebConfig& config, WebContext context)
    : impl_(std::make_unique<Impl>(config, std::move(context))) {
  Impl& i = *impl_;
  httplib::Server& s = i.server;
  s.new_task_queue = [n = config.threads] { return new BoundedPool(n, 64); };
  web_http_configure(
      s, i.routes, [&i] { return i.current(); }, i.counters);
  if (config.port == 0) {
    i.port = s.bind_to_any_port(config.bind);
  } else {
    i.port = s.bind_to_port(config.bind, config.port) ? config.port : -1;
  }
  if (i.port <= 0)
    throw std::runtime_error(config.bind + ":" + std::to_string(config.port) +
                             ": cannot listen (address not on this machine, or the port in use)");
  i.view_thread = std::thread([&i] { i.view_loop(); });
  i.http_thread = std::thread([&i] { i.server.listen_after_bind(); });
}

WebLiveView::~WebLiveView() { stop(); }

int WebLiveView::port() const noexcept { return impl_->port; }

void WebLiveView::publish(const PublishedFrame& f) {
  Impl& i = *impl_;
  if (i.stopping.load(std::memory_order_relaxed)) return;
  const std::int64_t mono = monotonic_now_ns();
  i.newest_t_ns.store(f.t_ns, std::memory_order_relaxed);
  i.newest_at_ns.store(mono, std::memory_order_relaxed);
  const RutMeasurement& m = f.measurement;
  if (!i.samples.push(WebSample{f.t_ns, static_cast<float>(m.depth_mm), m.status, m.conditions}))
    i.samples_dropped.fetch_add(1, std::memory_order_relaxed);
  if (i.last_offer_ns != 0 && mono - i.last_offer_ns < i.min_interval_ns) return;
  i.last_offer_ns = mono;
  i.offered.fetch_add(1, std::memory_order_relaxed);
  WebFrame* slot = i.free.pop();
  if (slot == nullptr) {
    i.dropped.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  web_frame_copy(f, *slot);
  i.ready.push(slot);  // cannot fail: at most kSlots slots exist
}

void WebLiveView::publish_status(const SensorHealth& health, std::int64_t t_ns) {
  if (!impl_->statuses.push(StatusItem{health, t_ns})) impl_->samples_dropped.fetch_add(1, std::memory_order_relaxed);
}

void WebLiveView::publish_segment(const Segment& segment) {
  if (!impl_->segments.push(segment)) impl_->samples_dropped.fetch_add(1, std::memory_order_relaxed);
}

void WebLiveView::stop() {
  Impl& i = *impl_;
  if (i.stopped) return;
  i.stopped = true;
  i.stopping.store(true, std::memory_order_release);
  i.ready.wake();
  i.server.stop();
  if (i.http_thread.joinable()) i.http_thread.join();
  if (i.view_thread.joinable()) i.view_thread.join();
}

WebHandoff WebLiveView::stats() const noexcept { return impl_->handoff(); }

}  // namespace rutd
