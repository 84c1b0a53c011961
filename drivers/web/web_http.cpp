#include "web_http.hpp"

#include <sys/socket.h>

namespace rutd {

void web_http_configure(httplib::Server& s, const WebRoutes& routes,
                        std::function<std::shared_ptr<const WebContent>()> content, WebHttpCounters& counters) {
  // One request a connection: an idle keep-alive connection would hold a worker thread from other clients.
  s.set_keep_alive_max_count(1);
  s.set_read_timeout(5, 0);
  s.set_write_timeout(5, 0);
  s.set_payload_max_length(4096);
  // cpp-httplib's default also sets SO_REUSEPORT, with which a second rutd (or anything else) could
  // listen on the same port and take half the connections; a port in use must be a start-up error.
  s.set_socket_options([](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  const auto handler = [&routes, content](const httplib::Request& req, httplib::Response& res) {
    WebRequest r;
    r.method = req.method;
    r.path = req.path;
    r.header_count = req.headers.size();
    if (req.has_param("token")) r.token = req.get_param_value("token");
    if (req.has_header("Authorization")) r.authorization = req.get_header_value("Authorization");
    const WebAnswer a = routes.answer(r, content());
    res.status = a.status;
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Content-Type-Options", "nosniff");
    res.set_header("Content-Security-Policy", "default-src 'self'; img-src 'self' blob:");
    if (a.status == 401) res.set_header("WWW-Authenticate", "Bearer");
    if (a.status == 200) res.set_content(a.body.data(), a.body.size(), std::string(a.content_type).c_str());
    else res.set_content(a.message, "text/plain; charset=utf-8");
  };
  s.Get(".*", handler);
  s.Post(".*", handler);
  s.Put(".*", handler);
  s.Patch(".*", handler);
  s.Delete(".*", handler);
  s.Options(".*", handler);
  s.set_logger([&counters](const httplib::Request&, const httplib::Response& res) {
    counters.requests.fetch_add(1, std::memory_order_relaxed);
    if (res.status >= 400) counters.refused.fetch_add(1, std::memory_order_relaxed);
  });
}

}  // namespace rutd
