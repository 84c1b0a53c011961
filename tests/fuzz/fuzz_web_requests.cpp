// libFuzzer target: the live view's HTTP requests, whole, through the server rutd runs (cpp-httplib
// configured by web_http_configure, answered by WebRoutes) in memory: the input is the bytes a client
// sends on one connection. Checked beyond "no crash, no leak, no hang": the answer is one HTTP/1.1
// response; a 2xx answer is only ever one of the page's files (to anyone) or the data (to a request that
// carried the token), byte for byte, so nothing else can ever be served.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "fuzz_check.hpp"
#include "web_http.hpp"

namespace {

constexpr const char* kToken = "fuzz-token-0123456789";

// A connection held in memory: reads come from the input, writes go to the answer.
class MemoryStream final : public httplib::Stream {
 public:
  MemoryStream(const std::uint8_t* data, std::size_t size) : data_(reinterpret_cast<const char*>(data)), size_(size) {}
  bool is_readable() const override { return at_ < size_; }
  bool is_writable() const override { return true; }
  ssize_t read(char* ptr, std::size_t size) override {
    const std::size_t n = std::min(size, size_ - at_);
    std::copy(data_ + at_, data_ + at_ + n, ptr);
    at_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* ptr, std::size_t size) override {
    out.append(ptr, size);
    return static_cast<ssize_t>(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 40000;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 8080;
  }
  socket_t socket() const override { return INVALID_SOCKET; }
  std::string out;

 private:
  const char* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

class Server final : public httplib::Server {
 public:
  using httplib::Server::process_request;
};

struct Fixture {
  Fixture() : routes(kToken) {
    auto c = std::make_shared<rutd::WebContent>();
    c->seq = 7;
    c->live_json = R"({"seq":7,"marker":"LIVE-JSON"})";
    c->history_json = R"({"bins":[],"marker":"HISTORY-JSON"})";
    c->left_jpeg = "LEFT-JPEG-BYTES";
    c->right_jpeg = "RIGHT-JPEG-BYTES";
    c->strip_png = "STRIP-PNG-BYTES";
    content = c;
    rutd::web_http_configure(
        server, routes, [this] { return content; }, counters);
  }
  rutd::WebRoutes routes;
  std::shared_ptr<const rutd::WebContent> content;
  rutd::WebHttpCounters counters;
  Server server;
};

bool body_is(const std::string& answer, std::string_view body) {
  const auto split = answer.find("\r\n\r\n");
  return split != std::string::npos && std::string_view(answer).substr(split + 4) == body;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Fixture f;
  MemoryStream stream(data, size);
  bool closed = false;
  f.server.process_request(stream, true, closed, [](httplib::Request&) {});
  const std::string& out = stream.out;
  if (out.empty()) return 0;  // nothing parsed far enough to answer (a closed connection)
  if (out.rfind("HTTP/1.1 ", 0) != 0) rutd::fuzz::fail("not an HTTP/1.1 answer", out.substr(0, 80));
  const int status = std::atoi(out.c_str() + 9);
  if (status < 200 || status > 599) rutd::fuzz::fail("status out of range", out.substr(0, 80));
  if (status >= 200 && status < 300) {
    const std::string& c = f.content->live_json;
    const bool page =
        body_is(out, rutd::web_page_html()) || body_is(out, rutd::web_page_js()) || body_is(out, rutd::web_page_css());
    const bool vehicle_data = body_is(out, c) || body_is(out, f.content->history_json) ||
                              body_is(out, f.content->left_jpeg) || body_is(out, f.content->right_jpeg) ||
                              body_is(out, f.content->strip_png);
    // HEAD answers carry no body. The server reads the request line's words between blanks (spaces and
    // tabs, any number).
    const std::string_view in(reinterpret_cast<const char*>(data), size);
    const std::size_t method = std::min(in.find_first_not_of(" \t"), in.size());
    const std::size_t method_end = std::min(in.find_first_of(" \t", method), in.size());
    const bool head = in.substr(method, method_end - method) == "HEAD" && body_is(out, "");
    if (!page && !vehicle_data && !head)
      rutd::fuzz::fail("a 2xx answer that is none of the view's", out.substr(0, 200));
    if (vehicle_data && in.find(kToken) == std::string_view::npos)
      rutd::fuzz::fail("data served to a request without the token", out.substr(0, 200));
  }
  return 0;
}
