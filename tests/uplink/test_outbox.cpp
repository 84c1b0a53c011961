// The uplink's store and forward (uplink/outbox.hpp) on its own: order, ids across restarts, the bound,
// a process killed with SIGKILL in the middle of appending, a file-size limit (the disk full), and what
// the database holds read by sqlite3's own command-line shell, not by our code.
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "test_support.hpp"
#include "uplink/outbox.hpp"
#include "uplink/uplink_json.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;

std::vector<Outbox::Pending> messages(int n, int from = 0, std::size_t body_bytes = 40) {
  std::vector<Outbox::Pending> out;
  for (int i = 0; i < n; ++i)
    out.push_back({"health", "\"n\":" + std::to_string(from + i) + ",\"pad\":\"" + std::string(body_bytes, 'x') + "\"",
                   1'700'000'000'000'000'000 + (from + i) * 1'000'000'000LL});
  return out;
}

OutboxConfig config(const fs::path& file) {
  OutboxConfig c;
  c.path = file.string();
  return c;
}

// What sqlite3's shell says the file holds: "count min max".
std::string shell_view(const fs::path& file) {
  const fs::path out = file.string() + ".view";
  test::run_shell("sqlite3 " + test::quoted(file) + " 'SELECT count(*), min(id), max(id) FROM outbox' > " +
                  test::quoted(out) + " 2>&1");
  std::string text = test::read_text(out);
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  return text;
}

TEST(Outbox, KeepsOrderAndIdsAcrossRestartsAndRemovesWhatWasAcknowledged) {
  const test::TempDir tmp;
  const fs::path file = tmp.path() / "q.sqlite";
  std::string error;
  {
    Outbox box(config(file));
    ASSERT_TRUE(box.append(messages(5), error)) << error;
    const auto all = box.next(0, 100);
    ASSERT_EQ(all.size(), 5u);
    for (std::size_t i = 0; i < all.size(); ++i) {
      EXPECT_EQ(all[i].id, static_cast<std::int64_t>(i + 1));
      EXPECT_EQ(all[i].payload.rfind("{\"id\":" + std::to_string(i + 1) + ",\"n\":" + std::to_string(i), 0), 0u)
          << all[i].payload;
    }
    EXPECT_EQ(box.next(3, 100).front().id, 4);
    // The broker acknowledged 1..4: removed; 5 stays.
    std::vector<Outbox::Acked> acked;
    for (int i = 0; i < 4; ++i) acked.push_back({all[static_cast<std::size_t>(i)].id, all[i].payload.size()});
    ASSERT_TRUE(box.remove(acked, error)) << error;
    EXPECT_EQ(box.stats().messages, 1u);
    EXPECT_EQ(box.stats().bytes, all[4].payload.size());
    EXPECT_EQ(box.stats().oldest_created_unix_ns, all[4].created_unix_ns);
  }
  EXPECT_EQ(shell_view(file), "1|5|5");
  Outbox again(config(file));
  EXPECT_EQ(again.stats().messages, 1u);
  EXPECT_EQ(again.last_id(), 5);
  ASSERT_TRUE(again.append(messages(2, 5), error)) << error;
  const auto rest = again.next(0, 100);
  ASSERT_EQ(rest.size(), 3u);
  // Ids go on from the highest ever given, never reusing an acknowledged one.
  EXPECT_EQ(rest[0].id, 5);
  EXPECT_EQ(rest[1].id, 6);
  EXPECT_EQ(rest[2].id, 7);
}

TEST(Outbox, DropsTheOldestBeyondItsBoundAndCountsThem) {
  const test::TempDir tmp;
  OutboxConfig c = config(tmp.path() / "q.sqlite");
  c.max_messages = 100;
  c.max_bytes = 1u << 30;
  Outbox box(c);
  std::string error;
  for (int k = 0; k < 25; ++k) ASSERT_TRUE(box.append(messages(10, 10 * k), error)) << error;
  EXPECT_EQ(box.stats().messages, 100u);
  EXPECT_EQ(box.stats().dropped_oldest, 150u);
  EXPECT_EQ(box.next(0, 1).front().id, 151);
  EXPECT_EQ(shell_view(c.path), "100|151|250");
  // By bytes: each payload is about 80 bytes; 8 KiB keeps about a hundred.
  OutboxConfig b = config(tmp.path() / "bytes.sqlite");
  b.max_bytes = 8192;
  Outbox by_bytes(b);
  for (int k = 0; k < 30; ++k) ASSERT_TRUE(by_bytes.append(messages(10, 10 * k), error)) << error;
  EXPECT_LE(by_bytes.stats().bytes, 8192u);
  EXPECT_GT(by_bytes.stats().bytes, 8192u - 200);
  EXPECT_EQ(by_bytes.stats().dropped_oldest + by_bytes.stats().messages, 300u);
}

// A child appends batches and reports each committed batch through a pipe; it is killed with SIGKILL at
// a moment of the parent's choosing, mid-way. Every batch the child saw committed is in the file, whole,
// and the file opens as a queue again.
TEST(Outbox, SurvivesSigkillMidAppend) {
  const test::TempDir tmp;
  const fs::path file = tmp.path() / "q.sqlite";
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(fds[0]);
    Outbox box(config(file));
    std::string error;
    for (int k = 0;; ++k) {
      if (!box.append(messages(50, 50 * k, 200), error)) ::_exit(3);
      const int committed = 50 * (k + 1);
      if (::write(fds[1], &committed, sizeof committed) != sizeof committed) ::_exit(4);
    }
  }
  ::close(fds[1]);
  int committed = 0, value = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(600);
  while (std::chrono::steady_clock::now() < until && ::read(fds[0], &value, sizeof value) == sizeof value)
    committed = value;
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  while (::read(fds[0], &value, sizeof value) == sizeof value) committed = value;  // reported before the kill
  ::close(fds[0]);
  ASSERT_TRUE(WIFSIGNALED(status));
  ASSERT_GT(committed, 0);
  Outbox box(config(file));
  EXPECT_GE(box.stats().messages, static_cast<std::uint64_t>(committed));
  EXPECT_EQ(box.stats().messages % 50, 0u) << "a batch is all or nothing";
  const auto all = box.next(0, 1'000'000);
  for (std::size_t i = 0; i < all.size(); ++i) ASSERT_EQ(all[i].id, static_cast<std::int64_t>(i + 1));
  std::printf("[ sigkill  ] %d messages reported committed, %zu in the file after the kill\n", committed, all.size());
}

// The disk full: a child under a file-size limit appends until the limit stops it. The failed append is
// reported (not thrown, not a crash), counted, and what was committed before stays readable.
TEST(Outbox, AFullDiskFailsTheAppendAndKeepsWhatWasQueued) {
  const test::TempDir tmp;
  const fs::path file = tmp.path() / "q.sqlite";
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{60'000, 60'000};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    Outbox box(config(file));
    std::string error;
    for (int k = 0; k < 1000; ++k) {
      if (!box.append(messages(10, 10 * k, 300), error)) {
        // Counted, and the queue still answers with what it held.
        ::_exit(box.stats().write_errors == 1 && box.next(0, 1).size() == 1 ? 0 : 5);
      }
    }
    ::_exit(7);  // never full
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  Outbox box(config(file));
  EXPECT_GT(box.stats().messages, 0u);
  EXPECT_EQ(box.stats().messages % 10, 0u);
}

// The JSON the uplink sends is the schema's (docs/uplink.schema.json, checked by python3-jsonschema), with
// values that are not known as null.
TEST(UplinkJson, MessagesFollowTheSchema) {
  const test::TempDir tmp;
  Segment s;
  s.index = 3;
  s.start_m = 3;
  s.end_m = 4;
  s.frames = 14;
  s.refused = 2;
  s.mean_depth_mm = 51.25;
  s.worst_status = RutStatus::Vegetation;
  s.advisory = Advisory::Caution;
  s.position.mode = GeoFix::Mode::Fix3d;
  s.position.latitude_deg = 61.5;
  s.position.longitude_deg = 24.25;
  SecondSummary second;
  second.start_unix_ns = 1'795'000'000'000'000'000;
  second.frames = 30;
  second.ok = 0;
  second.speed = SpeedState::Stale;
  SensorHealth h;
  h.frame_rate_hz = 29.9;
  UplinkHealth u;
  u.queued = 12;
  const std::int64_t t = 1'795'000'000'123'000'000;
  const std::vector<std::string> bodies = {uplink_segment_json(s, "truck-7", t),
                                           uplink_second_json(second, "truck-7", t),
                                           uplink_health_json(h, u, "truck-7", t)};
  {
    std::ofstream out(tmp.path() / "messages.jsonl");
    for (std::size_t i = 0; i < bodies.size(); ++i) out << "{\"id\":" << i + 1 << "," << bodies[i] << "}\n";
    out << uplink_status_json(true, "truck-7", "0.1.0-1") << "\n";
  }
  const std::string check =
      "/usr/bin/python3 -c 'import json,sys,jsonschema\n"
      "v=jsonschema.Draft202012Validator(json.load(open(sys.argv[1])))\n"
      "bad=[e.message for l in open(sys.argv[2]) for e in v.iter_errors(json.loads(l))]\n"
      "print(len(bad), bad[:3]); sys.exit(1 if bad else 0)' " RUTD_SOURCE_DIR "/docs/uplink.schema.json " +
      test::quoted(tmp.path() / "messages.jsonl") + " > " + test::quoted(tmp.path() / "check.txt") + " 2>&1";
  EXPECT_EQ(test::run_shell(check), 0) << test::read_text(tmp.path() / "check.txt");
  EXPECT_NE(bodies[0].find(R"("created":"2026-11-18T)"), std::string::npos) << bodies[0];
  EXPECT_NE(bodies[0].find(R"("max_depth_mm":null)"), std::string::npos) << bodies[0];
  EXPECT_NE(bodies[1].find(R"("mean_depth_mm":null)"), std::string::npos) << bodies[1];
}

}  // namespace
}  // namespace rutd
