#pragma once
// The live view's answers to requests, apart from HTTP itself (cpp-httplib parses the requests and
// writes the answers; web/live_view.cpp joins the two). Read-only: GET and HEAD on a fixed set of paths
// (docs/web.md), nothing served from the file system. Pure and thread-safe: the fuzz target calls it as
// the HTTP threads do.
#include <memory>
#include <string>
#include <string_view>

#include "web/web_view.hpp"

namespace rutd {

struct WebRequest {
  std::string method;         // as received
  std::string path;           // decoded, without the query
  std::string token;          // the `token` query parameter, if any
  std::string authorization;  // the Authorization header, if any ("Bearer TOKEN")
  std::size_t header_count = 0;
};

// More header fields than a browser or a polling tool sends: 431. (cpp-httplib 0.11 bounds each header
// line to 8 kB but not their number; it has read them all by the time the request is answered.)
inline constexpr std::size_t kWebMaxHeaders = 64;

struct WebAnswer {
  int status = 200;
  std::string_view content_type = "text/plain; charset=utf-8";
  std::string_view body;                   // status 200: points into `keep` or into the page's static text
  std::shared_ptr<const WebContent> keep;  // holds `body` alive while it is sent
  std::string message;                     // any other status: the body, one line saying why
};

class WebRoutes {
 public:
  // token: "" when none is required (a loopback address), else what every request must present.
  explicit WebRoutes(std::string token) : token_(std::move(token)) {}
  // content: the current WebContent, null before the first build.
  WebAnswer answer(const WebRequest& request, std::shared_ptr<const WebContent> content) const;

 private:
  bool authorised(const WebRequest& request, bool& presented) const;
  std::string token_;
};

// The page, its script and its style, embedded at build time (drivers/web/page/).
std::string_view web_page_html();
std::string_view web_page_js();
std::string_view web_page_css();

}  // namespace rutd
