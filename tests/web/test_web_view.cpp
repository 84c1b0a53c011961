// The live view as an installer sees it: rutd on the synthetic cameras with the web view on, the page
// loaded in headless Chromium (Debian's chromium) and read back from its rendered DOM (check_page.py):
// the pictures are there and follow the pairs, the figures are the measurement CSV's, a spoiled scene
// shows its condition. Requests it must refuse get a 4xx over raw sockets (bad_requests.py), and a start
// with an unusable web section is one clear error naming the key.
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "process_support.hpp"
#include "skip_policy.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using test::read_text;
using test::run_shell;

const std::string kDir = std::string(RUTD_SOURCE_DIR) + "/tests/web";
constexpr const char* kPython = "/usr/bin/python3";

std::string json_text(const std::string& json, const std::string& key) {
  std::smatch m;
  return std::regex_search(json, m, std::regex("\"" + key + "\": \"([^\"]*)\"")) ? m[1].str() : "<missing " + key + ">";
}

// The port rutd says it listens on, once it does.
int wait_for_view(const fs::path& log, test::ProcessGroup& rutd) {
  const std::regex re(R"(web view at http://[^:]+:(\d+)/)");
  for (int i = 0; i < 600; ++i) {
    std::smatch m;
    const std::string text = read_text(log);
    if (std::regex_search(text, m, re)) return std::stoi(m[1]);
    if (rutd.ended()) return -1;
    std::this_thread::sleep_for(50ms);
  }
  return -1;
}

// seq -> (status, depth text with two decimals) from the measurement CSV.
std::map<std::string, std::pair<std::string, std::string>> csv_rows(const fs::path& csv) {
  std::map<std::string, std::pair<std::string, std::string>> rows;
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line.rfind("seq,t_ns,status,rut_depth_mm,", 0), 0u) << line;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
    if (f.size() < 4) continue;
    rows[f[0]] = {f[2], f[3]};
  }
  return rows;
}

class WebView : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists("/usr/bin/chromium")) RUTD_SKIP_NEEDS_INSTALLED("/usr/bin/chromium (Debian chromium)");
  }
  fs::path dir() const { return tmp_.path(); }
  fs::path config(const std::string& name, const std::string& extra) const {
    const fs::path p = dir() / (name + ".yaml");
    // The embedded default's source (8 pairs rendered once, played at 30 Hz as cameras deliver), unless
    // the case replays a recording.
    std::ofstream(p) << (extra.find("source:") == std::string::npos ? "source:\n  synthetic:\n    cycle_frames: 8\n"
                                                                    : "")
                     << "web:\n  enabled: true\n  port: 0\n"
                     << extra;
    return p;
  }
  // Loads the page twice; the report of check_page.py.
  std::string load_page(int port, const std::string& query = "", const fs::path& screenshot = {}) {
    const fs::path report = dir() / "page.json";
    const int rc = run_shell(std::string(kPython) + " " + test::quoted(kDir + "/check_page.py") + " " +
                             test::quoted("http://127.0.0.1:" + std::to_string(port) + "/" + query) + " " +
                             test::quoted(report) + (screenshot.empty() ? "" : " " + test::quoted(screenshot)));
    EXPECT_EQ(rc, 0);
    return read_text(report);
  }

 private:
  test::TempDir tmp_;
};

TEST_F(WebView, ThePageShowsLivePicturesAndTheFiguresOfTheCsv) {
  const fs::path log = dir() / "rutd.log", csv = dir() / "m.csv";
  test::ProcessGroup rutd(
      {RUTD_BINARY, "run", "--config", config("live", "").string(), "--candump", "", "--csv", csv.string()}, log);
  const int port = wait_for_view(log, rutd);
  ASSERT_GT(port, 0) << read_text(log);
  // A screenshot too, as the README's docs/web-view.png was taken.
  const std::string page = load_page(port, "", dir() / "page.png");
  // The bits' names are the CAN signals', as canmatrix reads the DBC.
  EXPECT_EQ(run_shell(std::string(kPython) + " " + test::quoted(kDir + "/check_bit_names.py") + " http://127.0.0.1:" +
                      std::to_string(port) + "/api/live.json " RUTD_SOURCE_DIR "/config/rutd.dbc"),
            0);
  rutd.stop();
  std::printf("[ page     ] %s\n", page.c_str());
  const auto rows = csv_rows(csv);
  ASSERT_GT(rows.size(), 5u);
  for (const char* load : {"first", "second"}) {
    const std::string k = load;
    EXPECT_EQ(json_text(page, k + "_connection"), "live");
    const std::string seq = json_text(page, k + "_seq");
    ASSERT_TRUE(rows.count(seq)) << "the page shows pair " << seq << ", which the CSV does not have";
    // The figures as displayed: the CSV's, to the page's two decimals.
    EXPECT_EQ(json_text(page, k + "_status"), rows.at(seq).first);
    EXPECT_NEAR(std::stod(json_text(page, k + "_depth")), std::stod(rows.at(seq).second), 0.0051) << seq;
    // Each picture decoded by the browser, of the pair the figures are of.
    for (const char* img : {"img_left", "img_right", "img_strip"}) {
      EXPECT_EQ(json_text(page, k + "_" + img + "_seq"), seq) << img;
      EXPECT_EQ(json_text(page, k + "_" + img + "_width"), "640") << img;
    }
    EXPECT_EQ(json_text(page, k + "_conditions_listed"), "8");
    EXPECT_EQ(json_text(page, k + "_health_listed"), "8");
    EXPECT_EQ(json_text(page, k + "_conditions_set"), "");
    EXPECT_GT(std::stod(json_text(page, k + "_focus_left")), 50) << "a sharp, textured strip";
    EXPECT_GE(std::stoi(json_text(page, k + "_updates")), 2) << "polled at least twice in the page's time";
  }
  EXPECT_GT(std::stoll(json_text(page, "second_seq")), std::stoll(json_text(page, "first_seq")))
      << "the pictures and figures follow the pairs";
  EXPECT_GT(fs::file_size(dir() / "page.png"), 10000u);
  const std::string text = read_text(log);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(text, m, std::regex(R"(web view: (\d+) pairs shown, (\d+) dropped)"))) << text;
  EXPECT_GT(std::stoi(m[1]), 4);
}

// A covered left lens (a mud blob over the whole window), replayed in a loop: the page names the status
// and raises the condition bit.
TEST_F(WebView, ASpoiledSceneShowsItsCondition) {
  const fs::path rec = dir() / "covered";
  ASSERT_EQ(test::run_rutd("synth " + test::quoted(rec) +
                           " --frames 6 --size 320x240 --depth 50 --splash 1 --splash-camera left --seed 45"),
            0);
  const fs::path log = dir() / "rutd.log";
  test::ProcessGroup rutd(
      {RUTD_BINARY, "run", "--config", config("covered", "source:\n  replay:\n    loop: true\n").string(), "--replay",
       rec.string(), "--candump", ""},
      log);
  const int port = wait_for_view(log, rutd);
  ASSERT_GT(port, 0) << read_text(log);
  const std::string page = load_page(port);
  rutd.stop();
  std::printf("[ page     ] %s\n", page.c_str());
  for (const char* load : {"first", "second"}) {
    const std::string k = load;
    EXPECT_EQ(json_text(page, k + "_status"), "LENS_OBSTRUCTED");
    EXPECT_NE(json_text(page, k + "_conditions_set").find("LeftLensObstructed"), std::string::npos);
    EXPECT_EQ(json_text(page, k + "_depth"), "-") << "no depth shown for a refused pair";
  }
}

// On an address beyond this machine the token is required; bad requests get a 4xx, nothing outside
// the page is served, and rutd goes on answering and measuring.
TEST_F(WebView, BadRequestsGetA4xxAndTheViewGoesOn) {
  const fs::path token = dir() / "token";
  std::ofstream(token) << "k7V9wQ2mZr4Lx8Tn3Pb6\n";
  ::chmod(token.c_str(), 0600);
  const fs::path log = dir() / "rutd.log";
  test::ProcessGroup rutd(
      {RUTD_BINARY, "run", "--config",
       config("open", "  bind: 0.0.0.0\n  token_file: " + token.string() + "\n").string(), "--candump", ""},
      log);
  const int port = wait_for_view(log, rutd);
  ASSERT_GT(port, 0) << read_text(log);
  for (int i = 0; i < 100 && read_text(log).find("ready: first good") == std::string::npos; ++i)
    std::this_thread::sleep_for(50ms);
  const fs::path report = dir() / "bad.json";
  ASSERT_EQ(run_shell(std::string(kPython) + " " + test::quoted(kDir + "/bad_requests.py") + " 127.0.0.1 " +
                      std::to_string(port) + " k7V9wQ2mZr4Lx8Tn3Pb6 " + test::quoted(report)),
            0);
  const std::string r = read_text(report);
  EXPECT_EQ(test::json_number(r, "cases"), 22) << r;
  EXPECT_EQ(test::json_number(r, "failed"), 0) << r;
  EXPECT_EQ(test::json_number(r, "leaks"), 0) << r;
  EXPECT_NE(r.find("\"good_after\":true"), std::string::npos) << r;
  // The page with the token in its address (its script passes it on to every request).
  const std::string page = load_page(port, "?token=k7V9wQ2mZr4Lx8Tn3Pb6");
  EXPECT_EQ(json_text(page, "second_connection"), "live") << page;
  EXPECT_EQ(json_text(page, "second_img_left_width"), "640") << page;
  EXPECT_FALSE(rutd.ended()) << read_text(log);
}

TEST_F(WebView, AnUnusableWebSectionIsOneErrorNamingTheKey) {
  const fs::path token = dir() / "token";
  std::ofstream(token) << "k7V9wQ2mZr4Lx8Tn3Pb6\n";
  ::chmod(token.c_str(), 0644);
  struct Case {
    std::string extra, expected;
  };
  const std::vector<Case> cases{
      {"  bind: 0.0.0.0\n", "web.token_file: required when bind is not a loopback address (0.0.0.0)"},
      {"  bind: 0.0.0.0\n  token_file: " + token.string() + "\n",
       "web.token_file: " + token.string() + ": the token file is readable by others (mode 644)"},
      {"  bind: localhost\n", "web.bind: expected a numeric IPv4 or IPv6 address"},
      {"  bind: 192.0.2.1\n  token_file: " + token.string() + "\n", "web.token_file"},
      {"  rate_hz: 100\n", "web.rate_hz: expected 0.5..30"},
      {"  colour: red\n", "web.colour"},
  };
  int checked = 0;
  for (const Case& c : cases) {
    const fs::path cfg = config("bad" + std::to_string(checked), c.extra), err = dir() / "err.txt";
    EXPECT_EQ(test::run_rutd("run --config " + test::quoted(cfg) + " --candump '' --frames 1", err.string()), 2)
        << c.extra;
    const std::string text = read_text(err);
    EXPECT_NE(text.find(cfg.string()), std::string::npos) << text;
    EXPECT_NE(text.find(c.expected), std::string::npos) << c.extra << "\n" << text;
    ++checked;
  }
  EXPECT_EQ(checked, 6);
  // An address that is not this machine's, with a usable token: it cannot listen there.
  ::chmod(token.c_str(), 0600);
  const fs::path cfg = config("elsewhere", "  bind: 192.0.2.1\n  token_file: " + token.string() + "\n");
  const fs::path err = dir() / "err.txt";
  EXPECT_EQ(test::run_rutd("run --config " + test::quoted(cfg) + " --candump '' --frames 1", err.string()), 2);
  EXPECT_NE(read_text(err).find("web.port: 192.0.2.1:0: cannot listen"), std::string::npos) << read_text(err);
}

}  // namespace
}  // namespace rutd
