#pragma once
// Private to drivers/web (and its fuzz target): how the live view sets up cpp-httplib, so that the
// server the fuzz target drives in memory is the one rutd runs.
#include <httplib.h>

#include <atomic>
#include <functional>
#include <memory>

#include "web/web_routes.hpp"

namespace rutd {

struct WebHttpCounters {
  std::atomic<std::uint64_t> requests{0}, refused{0};  // answered; of those, with a status of 400 or more
};

// Limits (one request a connection, 5 s timeouts, 4 kB bodies), socket options (SO_REUSEADDR only), and
// one handler for every method and path, which asks `routes` with `content()`. Thread-safe as routes
// and content are: the handler runs on cpp-httplib's worker threads.
void web_http_configure(httplib::Server& server, const WebRoutes& routes,
                        std::function<std::shared_ptr<const WebContent>()> content, WebHttpCounters& counters);

}  // namespace rutd
