# cmake -P embed_page.cmake -DOUT=page_assets.cpp -DPAGE_DIR=page: the live view's page, script and style
# as C++ raw strings (web/web_routes.hpp), so rutd serves them from its own binary.
cmake_policy(SET CMP0054 NEW)  # "html" in if() is a string, not a variable
foreach(part html js css)
  if(part STREQUAL "html")
    file(READ "${PAGE_DIR}/index.html" text)
  elseif(part STREQUAL "js")
    file(READ "${PAGE_DIR}/app.js" text)
  else()
    file(READ "${PAGE_DIR}/style.css" text)
  endif()
  string(FIND "${text}" ")rutdpage\"" clash)
  if(NOT clash EQUAL -1)
    message(FATAL_ERROR "${PAGE_DIR}: a page file contains the raw string's end marker")
  endif()
  set(page_${part} "${text}")
endforeach()
file(WRITE "${OUT}.tmp" "// Generated from drivers/web/page/ by embed_page.cmake; edit those files.
#include \"web/web_routes.hpp\"

namespace rutd {
namespace {
constexpr std::string_view kHtml = R\"rutdpage(${page_html})rutdpage\";
constexpr std::string_view kJs = R\"rutdpage(${page_js})rutdpage\";
constexpr std::string_view kCss = R\"rutdpage(${page_css})rutdpage\";
}  // namespace
std::string_view web_page_html() { return kHtml; }
std::string_view web_page_js() { return kJs; }
std::string_view web_page_css() { return kCss; }
}  // namespace rutd
")
file(COPY_FILE "${OUT}.tmp" "${OUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUT}.tmp")
