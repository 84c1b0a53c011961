#pragma once
// The uplink's store and forward (DESIGN.md, Fleet uplink): every message the uplink is to send is first
// appended here, in an SQLite database in WAL mode, and removed once the broker acknowledged it (MQTT QoS 1
// PUBACK). Why SQLite: one file, appends and deletes in transactions that a kill -9 or a power cut leave
// whole (the WAL is replayed or discarded at the next open), an index by id for the in-order drain, and a
// library every Debian system has; append-only files with checksums would need compaction and their own
// recovery code for the same guarantees.
//
// Durability (`sync`): Full (default) fsyncs the WAL at every commit, so a message appended survives a
// power cut; Normal fsyncs only at checkpoints, so a kill -9 loses nothing but a power cut may lose the
// last commits. The uplink commits once per loop turn (every message taken from the publish thread in
// that turn), so Full costs one fsync a turn, not one a message.
//
// Bound: at most max_bytes of payload (and max_messages); appending beyond drops the oldest messages,
// counted. Ids increase by one per message appended, across restarts (AUTOINCREMENT never reuses an id,
// even of a dropped message), so a consumer drops duplicates by id and sees gaps where messages were
// dropped.
//
// Not thread-safe: one thread (the uplink's) owns it. Errors (disk full, a read-only or corrupt file) are
// returned and counted, never thrown, after the constructor: the measurement goes on without the queue.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

struct sqlite3;
struct sqlite3_stmt;

namespace rutd {

enum class OutboxSync : std::uint8_t { Normal, Full };

struct OutboxConfig {
  std::string path;                        // the database file (its -wal and -shm beside it)
  std::uint64_t max_bytes = 64ull << 20;   // payload bytes kept at most
  std::uint64_t max_messages = 1'000'000;  // messages kept at most
  OutboxSync sync = OutboxSync::Full;
};

struct OutboxMessage {
  std::int64_t id = 0;
  std::string topic;    // below the uplink's topic prefix, e.g. "segment"
  std::string payload;  // the message's JSON, its id included
  std::int64_t created_unix_ns = 0;
};

struct OutboxStats {
  std::uint64_t appended = 0;
  std::uint64_t removed = 0;                // acknowledged by the broker
  std::uint64_t dropped_oldest = 0;         // dropped to stay within the bound
  std::uint64_t write_errors = 0;           // appends or removals that failed (disk full, I/O error)
  std::uint64_t messages = 0;               // queued now
  std::uint64_t bytes = 0;                  // payload bytes queued now
  std::int64_t oldest_created_unix_ns = 0;  // of the oldest queued message; 0 when empty
};

class Outbox {
 public:
  // Opens or creates the database (and its folder's file; not the folder). Throws std::runtime_error naming
  // the file when it cannot be opened as an outbox (start-up error).
  explicit Outbox(OutboxConfig config);
  ~Outbox();
  Outbox(const Outbox&) = delete;
  Outbox& operator=(const Outbox&) = delete;

  // Appends messages in one transaction; `make_payload(id)` gives each one's JSON once its id is known.
  // Returns false (nothing appended, counted) when the transaction failed; `error` says why.
  struct Pending {
    std::string topic;
    std::string body;  // the JSON object's members after "id" (without braces), see uplink_json.hpp
    std::int64_t created_unix_ns = 0;
  };
  bool append(const std::vector<Pending>& pending, std::string& error);

  // Up to `limit` messages with id > after_id, in id order.
  std::vector<OutboxMessage> next(std::int64_t after_id, std::size_t limit);

  // Removes acknowledged messages (one transaction): their ids and payload sizes. False, counted, when it
  // failed (they stay queued and are sent again: at-least-once).
  struct Acked {
    std::int64_t id = 0;
    std::size_t bytes = 0;
  };
  bool remove(const std::vector<Acked>& acked, std::string& error);

  // The highest id ever appended (0 if none).
  std::int64_t last_id() const noexcept { return last_id_; }
  const OutboxStats& stats() const noexcept { return stats_; }
  const std::string& path() const noexcept { return config_.path; }

 private:
  bool exec(const char* sql, std::string& error);
  void close() noexcept;
  void refresh_totals();
  void refresh_oldest();
  void enforce_bound();
  sqlite3_stmt* prepare(const char* sql);

  OutboxConfig config_;
  sqlite3* db_ = nullptr;
  sqlite3_stmt* insert_ = nullptr;
  sqlite3_stmt* select_ = nullptr;
  sqlite3_stmt* delete_ = nullptr;
  std::int64_t last_id_ = 0;
  OutboxStats stats_;
};

}  // namespace rutd
