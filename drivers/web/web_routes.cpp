#include "web/web_routes.hpp"

namespace rutd {
namespace {

WebAnswer error(int status, std::string message) {
  WebAnswer a;
  a.status = status;
  a.message = std::move(message) + "\n";
  return a;
}

// Constant time over the token's characters, so a wrong token's answer time tells nothing of the right
// one (its length is no secret).
bool same(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

}  // namespace

bool WebRoutes::authorised(const WebRequest& r, bool& presented) const {
  presented = false;
  if (token_.empty()) return true;
  constexpr std::string_view bearer = "Bearer ";
  if (r.authorization.compare(0, bearer.size(), bearer) == 0) {
    presented = true;
    if (same(std::string_view(r.authorization).substr(bearer.size()), token_)) return true;
  }
  if (!r.token.empty()) {
    presented = true;
    if (same(r.token, token_)) return true;
  }
  return false;
}

WebAnswer WebRoutes::answer(const WebRequest& r, std::shared_ptr<const WebContent> content) const {
  if (r.header_count > kWebMaxHeaders) return error(431, "too many header fields");
  if (r.method != "GET" && r.method != "HEAD") return error(405, "read-only: GET and HEAD only");
  if (r.path.empty() || r.path[0] != '/' || r.path.find("..") != std::string::npos ||
      r.path.find('\0') != std::string::npos || r.path.find('\\') != std::string::npos)
    return error(400, "bad path");
  WebAnswer a;
  const auto page = [&](std::string_view body, std::string_view type) {
    a.body = body;
    a.content_type = type;
    return a;
  };
  // The page, its script and its style are the same for everyone and tell nothing of the vehicle: served
  // without the token, so a browser can load them from an address that carries it (/?token=...), whose
  // script then presents it with every request for data.
  if (r.path == "/" || r.path == "/index.html") return page(web_page_html(), "text/html; charset=utf-8");
  if (r.path == "/app.js") return page(web_page_js(), "text/javascript; charset=utf-8");
  if (r.path == "/style.css") return page(web_page_css(), "text/css; charset=utf-8");
  bool presented = false;
  if (!authorised(r, presented))
    return presented ? error(403, "wrong token")
                     : error(401, "a token is required (Authorization: Bearer, or ?token=)");
  const std::string* body = nullptr;
  std::string_view type;
  if (r.path == "/api/live.json") body = content ? &content->live_json : nullptr, type = "application/json";
  else if (r.path == "/api/history.json") body = content ? &content->history_json : nullptr, type = "application/json";
  else if (r.path == "/api/image/left.jpg") body = content ? &content->left_jpeg : nullptr, type = "image/jpeg";
  else if (r.path == "/api/image/right.jpg") body = content ? &content->right_jpeg : nullptr, type = "image/jpeg";
  else if (r.path == "/api/image/strip.png") body = content ? &content->strip_png : nullptr, type = "image/png";
  else return error(404, "no such page: the view serves /, /api/live.json, /api/history.json and /api/image/*");
  if (body == nullptr || body->empty()) return error(503, "nothing measured yet");
  a.keep = std::move(content);
  a.body = *body;
  a.content_type = type;
  return a;
}

}  // namespace rutd
