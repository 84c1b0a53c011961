#include "gps/gps_jsonl.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>

#include "core/input_error.hpp"
#include "gps/gpsd_report.hpp"

namespace rutd {

GpsJsonlWriter::GpsJsonlWriter(const std::string& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0) throw InputError(path, "file", std::string("cannot create: ") + std::strerror(errno));
  line_.reserve(1024);
}

GpsJsonlWriter::~GpsJsonlWriter() {
  if (fd_ >= 0) ::close(fd_);
}

bool GpsJsonlWriter::append(std::int64_t t_ns, std::string_view report) {
  while (!report.empty() && (report.back() == '\n' || report.back() == '\r')) report.remove_suffix(1);
  char number[24];
  const auto end = std::to_chars(number, number + sizeof number, t_ns).ptr;
  line_.assign("{\"t_ns\":");
  line_.append(number, end);
  line_.append(",\"report\":");
  line_.append(report);
  line_.append("}\n");
  std::size_t done = 0;
  while (done < line_.size()) {
    const ssize_t n = ::write(fd_, line_.data() + done, line_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      error_ = path_ + ": cannot write: " + std::strerror(errno);
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  error_.clear();
  return true;
}

namespace {

// `{"t_ns":N,"report":{...}}` exactly as the writer lays it out.
bool parse_line(std::string_view line, GpsJsonlLine& out) {
  constexpr std::string_view head = "{\"t_ns\":", mid = ",\"report\":";
  if (line.substr(0, head.size()) != head || line.size() < head.size() + mid.size() + 3 || line.back() != '}')
    return false;
  const char* begin = line.data() + head.size();
  const auto [end, ec] = std::from_chars(begin, line.data() + line.size(), out.t_ns);
  if (ec != std::errc()) return false;
  std::string_view rest = line.substr(static_cast<std::size_t>(end - line.data()));
  if (rest.substr(0, mid.size()) != mid) return false;
  rest.remove_prefix(mid.size());
  rest.remove_suffix(1);
  if (rest.empty() || rest.front() != '{' || rest.back() != '}') return false;
  out.report.assign(rest);
  return true;
}

}  // namespace

GpsJsonl read_gps_jsonl(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "file", "cannot open");
  GpsJsonl result;
  std::string text;
  while (std::getline(in, text)) {
    const bool cut_off = in.eof();
    if (text.empty()) continue;
    GpsJsonlLine line;
    if (parse_line(text, line)) {
      result.lines.push_back(std::move(line));
    } else if (cut_off) {
      result.truncated_tail = true;
    } else {
      ++result.malformed;
    }
  }
  return result;
}

RecordedFixes read_recorded_fixes(const std::string& path) {
  const GpsJsonl jsonl = read_gps_jsonl(path);
  RecordedFixes result;
  result.malformed = jsonl.malformed;
  GpsdReportParser parser;
  for (const GpsJsonlLine& line : jsonl.lines) {
    ++result.reports;
    GeoFix fix;
    switch (parser.parse(line.report, line.t_ns, fix)) {
      case GpsdReportKind::Fix: result.fixes.push_back(fix); break;
      case GpsdReportKind::Other: break;
      case GpsdReportKind::Malformed: ++result.malformed; break;
    }
  }
  return result;
}

}  // namespace rutd
