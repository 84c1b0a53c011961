#include "uplink/outbox.hpp"

#include <sqlite3.h>

#include <algorithm>
#include <stdexcept>

namespace rutd {
namespace {

constexpr const char* kSchema =
    "CREATE TABLE IF NOT EXISTS outbox("
    " id INTEGER PRIMARY KEY AUTOINCREMENT,"
    " topic TEXT NOT NULL,"
    " payload TEXT NOT NULL,"
    " created_unix_ns INTEGER NOT NULL)";

// RAII for one statement's bindings and state: reset on scope exit, so a statement is reusable.
struct Reset {
  sqlite3_stmt* s;
  ~Reset() {
    sqlite3_reset(s);
    sqlite3_clear_bindings(s);
  }
};

}  // namespace

Outbox::Outbox(OutboxConfig config) : config_(std::move(config)) {
  if (sqlite3_open_v2(config_.path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                      nullptr) != SQLITE_OK) {
    const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error(config_.path + ": cannot open the uplink queue: " + why);
  }
  sqlite3_busy_timeout(db_, 1000);
  std::string error;
  const bool ok =
      exec("PRAGMA journal_mode=WAL", error) &&
      exec(config_.sync == OutboxSync::Full ? "PRAGMA synchronous=FULL" : "PRAGMA synchronous=NORMAL", error) &&
      exec(kSchema, error);
  insert_ = ok ? prepare("INSERT INTO outbox(topic, payload, created_unix_ns) VALUES(?, ?, ?)") : nullptr;
  select_ =
      ok ? prepare("SELECT id, topic, payload, created_unix_ns FROM outbox WHERE id > ? ORDER BY id LIMIT ?") : nullptr;
  delete_ = ok ? prepare("DELETE FROM outbox WHERE id = ?") : nullptr;
  if (!ok || !insert_ || !select_ || !delete_) {
    const std::string why = error.empty() ? sqlite3_errmsg(db_) : error;
    close();
    throw std::runtime_error(config_.path + ": not a usable uplink queue: " + why);
  }
  // The highest id ever given: AUTOINCREMENT keeps it in sqlite_sequence even when the table is empty.
  sqlite3_stmt* seq = prepare("SELECT seq FROM sqlite_sequence WHERE name = 'outbox'");
  if (seq && sqlite3_step(seq) == SQLITE_ROW) last_id_ = sqlite3_column_int64(seq, 0);
  sqlite3_finalize(seq);
  refresh_totals();
}

Outbox::~Outbox() { close(); }

void Outbox::close() noexcept {
  sqlite3_finalize(insert_);
  sqlite3_finalize(select_);
  sqlite3_finalize(delete_);
  insert_ = select_ = delete_ = nullptr;
  if (db_) sqlite3_close(db_);
  db_ = nullptr;
}

sqlite3_stmt* Outbox::prepare(const char* sql) {
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(db_, sql, -1, &s, nullptr) != SQLITE_OK) return nullptr;
  return s;
}

bool Outbox::exec(const char* sql, std::string& error) {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) == SQLITE_OK) return true;
  error = message ? message : sqlite3_errmsg(db_);
  sqlite3_free(message);
  return false;
}

void Outbox::refresh_totals() {
  sqlite3_stmt* s = prepare(
      "SELECT count(*), coalesce(sum(length(payload)), 0), coalesce(min(created_unix_ns), 0) "
      "FROM outbox");
  if (s && sqlite3_step(s) == SQLITE_ROW) {
    stats_.messages = static_cast<std::uint64_t>(sqlite3_column_int64(s, 0));
    stats_.bytes = static_cast<std::uint64_t>(sqlite3_column_int64(s, 1));
    stats_.oldest_created_unix_ns = sqlite3_column_int64(s, 2);
  }
  sqlite3_finalize(s);
}

void Outbox::refresh_oldest() {
  sqlite3_stmt* s = prepare("SELECT created_unix_ns FROM outbox ORDER BY id LIMIT 1");
  stats_.oldest_created_unix_ns = s && sqlite3_step(s) == SQLITE_ROW ? sqlite3_column_int64(s, 0) : 0;
  sqlite3_finalize(s);
}

void Outbox::enforce_bound() {
  if (stats_.bytes <= config_.max_bytes && stats_.messages <= config_.max_messages) return;
  // Drop the oldest until within the bound: count how many, then one DELETE.
  sqlite3_stmt* s = prepare("SELECT id, length(payload) FROM outbox ORDER BY id");
  std::uint64_t bytes = stats_.bytes, messages = stats_.messages;
  std::int64_t up_to = 0;
  std::uint64_t dropped = 0;
  while (s && (bytes > config_.max_bytes || messages > config_.max_messages) && sqlite3_step(s) == SQLITE_ROW) {
    up_to = sqlite3_column_int64(s, 0);
    bytes -= static_cast<std::uint64_t>(sqlite3_column_int64(s, 1));
    --messages;
    ++dropped;
  }
  sqlite3_finalize(s);
  if (dropped == 0) return;
  const std::string sql = "DELETE FROM outbox WHERE id <= " + std::to_string(up_to);
  std::string error;
  if (exec(sql.c_str(), error)) {
    stats_.dropped_oldest += dropped;
  } else {
    ++stats_.write_errors;
  }
  refresh_totals();
}

bool Outbox::append(const std::vector<Pending>& pending, std::string& error) {
  if (pending.empty()) return true;
  if (!exec("BEGIN IMMEDIATE", error)) {
    ++stats_.write_errors;
    return false;
  }
  std::int64_t id = last_id_;
  std::uint64_t bytes = 0;
  for (const Pending& p : pending) {
    // The id is the row's; AUTOINCREMENT gives last_id_ + 1 inside this transaction (one writer).
    const std::string payload = "{\"id\":" + std::to_string(id + 1) + (p.body.empty() ? "" : ",") + p.body + "}";
    Reset reset{insert_};
    sqlite3_bind_text(insert_, 1, p.topic.data(), static_cast<int>(p.topic.size()), SQLITE_TRANSIENT);
    sqlite3_bind_text(insert_, 2, payload.data(), static_cast<int>(payload.size()), SQLITE_TRANSIENT);
    sqlite3_bind_int64(insert_, 3, p.created_unix_ns);
    if (sqlite3_step(insert_) != SQLITE_DONE || sqlite3_last_insert_rowid(db_) != id + 1) {
      error = sqlite3_errmsg(db_);
      std::string ignored;
      exec("ROLLBACK", ignored);
      ++stats_.write_errors;
      return false;
    }
    ++id;
    bytes += payload.size();
  }
  if (!exec("COMMIT", error)) {
    std::string ignored;
    exec("ROLLBACK", ignored);
    ++stats_.write_errors;
    return false;
  }
  stats_.appended += pending.size();
  if (stats_.messages == 0) stats_.oldest_created_unix_ns = pending.front().created_unix_ns;
  stats_.messages += pending.size();
  stats_.bytes += bytes;
  last_id_ = id;
  enforce_bound();
  return true;
}

std::vector<OutboxMessage> Outbox::next(std::int64_t after_id, std::size_t limit) {
  std::vector<OutboxMessage> out;
  Reset reset{select_};
  sqlite3_bind_int64(select_, 1, after_id);
  sqlite3_bind_int64(select_, 2, static_cast<sqlite3_int64>(limit));
  while (sqlite3_step(select_) == SQLITE_ROW) {
    OutboxMessage m;
    m.id = sqlite3_column_int64(select_, 0);
    m.topic = reinterpret_cast<const char*>(sqlite3_column_text(select_, 1));
    m.payload = reinterpret_cast<const char*>(sqlite3_column_text(select_, 2));
    m.created_unix_ns = sqlite3_column_int64(select_, 3);
    out.push_back(std::move(m));
  }
  return out;
}

bool Outbox::remove(const std::vector<Acked>& acked, std::string& error) {
  if (acked.empty()) return true;
  if (!exec("BEGIN IMMEDIATE", error)) {
    ++stats_.write_errors;
    return false;
  }
  std::uint64_t bytes = 0, removed = 0;
  for (const Acked& a : acked) {
    Reset reset{delete_};
    sqlite3_bind_int64(delete_, 1, a.id);
    if (sqlite3_step(delete_) != SQLITE_DONE) {
      error = sqlite3_errmsg(db_);
      std::string ignored;
      exec("ROLLBACK", ignored);
      ++stats_.write_errors;
      return false;
    }
    // A message dropped by the bound while in flight is acknowledged all the same: nothing to subtract.
    if (sqlite3_changes(db_) > 0) bytes += a.bytes, ++removed;
  }
  if (!exec("COMMIT", error)) {
    std::string ignored;
    exec("ROLLBACK", ignored);
    ++stats_.write_errors;
    return false;
  }
  stats_.removed += removed;
  stats_.messages -= std::min(stats_.messages, removed);
  stats_.bytes -= std::min(stats_.bytes, bytes);
  refresh_oldest();
  return true;
}

}  // namespace rutd
