#include "sqlite_util.h"

#include <fcntl.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <cstring>

namespace solid::sqlite {

namespace {

// SQLite's message for a failed system call, with the cause the operating system gave:
// "disk I/O error" alone does not tell a full disk from a failing one.
std::string Cause(sqlite3* db, int rc, std::string_view message) {
  int primary = rc & 0xFF;
  // SQLITE_FULL is a short write or ENOSPC, and SQLite keeps no errno for it.
  if (primary == SQLITE_FULL) return fmt::format("{} ({})", message, std::strerror(ENOSPC));
  int err = db ? sqlite3_system_errno(db) : 0;
  if ((primary == SQLITE_IOERR || primary == SQLITE_CANTOPEN) && err != 0) {
    return fmt::format("{} ({})", message, std::strerror(err));
  }
  return std::string(message);
}

}  // namespace

Result<Db> Db::Open(const std::filesystem::path& path, OpenMode mode, std::string_view name) {
  Db db;
  db.name_ = name.empty() ? path.string() : std::string(name);
  sqlite3* raw = nullptr;
  if (mode == OpenMode::kCreate && path != ":memory:") {
    // SQLite falls back to read-only when it cannot open for writing and drops the
    // errno: find out first, so that a read-only or vanished directory says so.
    int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      return IoError(fmt::format("{}: cannot open for writing: {}", db.name_, std::strerror(errno)));
    }
    ::close(fd);
  }
  int flags = SQLITE_OPEN_NOMUTEX;
  flags |= mode == OpenMode::kCreate ? (SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE) : SQLITE_OPEN_READONLY;
  int rc = sqlite3_open_v2(path.c_str(), &raw, flags, nullptr);
  db.db_.reset(raw);
  if (rc != SQLITE_OK) {
    return IoError(fmt::format("{}: cannot open: {}", db.name_,
                               raw ? Cause(raw, rc, sqlite3_errmsg(raw)) : sqlite3_errstr(rc)));
  }
  sqlite3_extended_result_codes(raw, 1);
  // Farm processes open one catalog (WAL) and one dataset at once: a database busy with
  // another connection (a reader rebuilding the WAL index, a writer's lock) is a wait, not
  // an error. Without a handler SQLite returns SQLITE_BUSY at once.
  sqlite3_busy_timeout(raw, 30'000);
  if (mode == OpenMode::kUntrustedRead) {
    // https://www.sqlite.org/security.html: a hostile file must not be able to run
    // functions from its schema or corrupt the file through writable schema tricks.
    sqlite3_db_config(raw, SQLITE_DBCONFIG_DEFENSIVE, 1, nullptr);
    sqlite3_db_config(raw, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, nullptr);
    sqlite3_db_config(raw, SQLITE_DBCONFIG_ENABLE_TRIGGER, 0, nullptr);
    sqlite3_db_config(raw, SQLITE_DBCONFIG_ENABLE_VIEW, 0, nullptr);
    sqlite3_limit(raw, SQLITE_LIMIT_LENGTH, 512 << 20);
    sqlite3_limit(raw, SQLITE_LIMIT_SQL_LENGTH, 1 << 20);
    SOLID_RETURN_IF_ERROR(db.Exec("PRAGMA cell_size_check = ON"));
  }
  return db;
}

Result<Db> Db::OpenInMemory() { return Open(":memory:", OpenMode::kCreate); }

Status Db::Exec(std::string_view sql) {
  char* err = nullptr;
  std::string owned(sql);
  int rc = sqlite3_exec(db_.get(), owned.c_str(), nullptr, nullptr, &err);
  if (rc == SQLITE_OK) return Status::Ok();
  std::string msg = Cause(db_.get(), sqlite3_extended_errcode(db_.get()), err ? err : sqlite3_errstr(rc));
  sqlite3_free(err);
  const int primary = rc & 0xFF;
  StatusCode code = primary == SQLITE_CORRUPT || primary == SQLITE_NOTADB ? StatusCode::kCorrupt
                    : primary == SQLITE_IOERR || primary == SQLITE_FULL || primary == SQLITE_CANTOPEN ||
                            primary == SQLITE_READONLY || primary == SQLITE_PERM
                        ? StatusCode::kIoError
                        : StatusCode::kInternal;
  return Status(code, fmt::format("{}: {}", name_, msg));
}

Status Db::Error(std::string_view what) const {
  int rc = sqlite3_extended_errcode(db_.get());
  int primary = rc & 0xFF;
  StatusCode code = StatusCode::kInternal;
  if (primary == SQLITE_CORRUPT || primary == SQLITE_NOTADB || primary == SQLITE_FORMAT ||
      primary == SQLITE_TOOBIG || primary == SQLITE_RANGE) {
    code = StatusCode::kCorrupt;
  } else if (primary == SQLITE_IOERR || primary == SQLITE_FULL || primary == SQLITE_CANTOPEN ||
             primary == SQLITE_READONLY || primary == SQLITE_PERM || primary == SQLITE_BUSY) {
    code = StatusCode::kIoError;
  } else if (primary == SQLITE_CONSTRAINT) {
    code = StatusCode::kInvalidArgument;
  } else if (primary == SQLITE_ERROR) {
    // "no such table" and friends: a file that is SQLite but not ours.
    code = StatusCode::kCorrupt;
  }
  return Status(code, fmt::format("{}: {}: {} ({})", name_, what, Cause(db_.get(), rc, sqlite3_errmsg(db_.get())), rc));
}

Result<int64_t> Db::QueryInt(std::string_view sql) {
  SOLID_ASSIGN_OR_RETURN(Stmt stmt, Stmt::Prepare(*this, sql));
  SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row || stmt.ColumnType(0) != SQLITE_INTEGER) {
    return CorruptError(fmt::format("{}: {}: no integer result", name_, sql));
  }
  return stmt.Int(0);
}

Result<Stmt> Stmt::Prepare(Db& db, std::string_view sql) {
  Stmt s;
  s.db_ = &db;
  sqlite3_stmt* raw = nullptr;
  int rc = sqlite3_prepare_v2(db.get(), sql.data(), static_cast<int>(sql.size()), &raw, nullptr);
  s.stmt_.reset(raw);
  if (rc != SQLITE_OK) return db.Error(fmt::format("prepare '{}'", sql.substr(0, 60)));
  return s;
}

Stmt& Stmt::Bind(int index, int64_t v) {
  int rc = sqlite3_bind_int64(stmt_.get(), index, v);
  if (rc != SQLITE_OK) bind_error_ = rc;
  return *this;
}
Stmt& Stmt::Bind(int index, double v) {
  int rc = sqlite3_bind_double(stmt_.get(), index, v);
  if (rc != SQLITE_OK) bind_error_ = rc;
  return *this;
}
Stmt& Stmt::Bind(int index, std::string_view text) {
  int rc = sqlite3_bind_text64(stmt_.get(), index, text.data(), text.size(), SQLITE_TRANSIENT, SQLITE_UTF8);
  if (rc != SQLITE_OK) bind_error_ = rc;
  return *this;
}
Stmt& Stmt::BindBlob(int index, std::span<const uint8_t> blob) {
  // A zero-length blob must still be a BLOB, not NULL: pass a non-null pointer.
  static const uint8_t kEmpty = 0;
  int rc = sqlite3_bind_blob64(stmt_.get(), index, blob.empty() ? &kEmpty : blob.data(), blob.size(),
                               SQLITE_TRANSIENT);
  if (rc != SQLITE_OK) bind_error_ = rc;
  return *this;
}
Stmt& Stmt::BindNull(int index) {
  int rc = sqlite3_bind_null(stmt_.get(), index);
  if (rc != SQLITE_OK) bind_error_ = rc;
  return *this;
}

Result<bool> Stmt::Step() {
  if (bind_error_ != SQLITE_OK) {
    int rc = bind_error_;
    bind_error_ = SQLITE_OK;
    return InternalError(fmt::format("{}: bind: {}", db_->name(), sqlite3_errstr(rc)));
  }
  int rc = sqlite3_step(stmt_.get());
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  return db_->Error("step");
}

Status Stmt::Run() {
  Result<bool> row = Step();
  Reset();
  if (!row.ok()) return row.status();
  if (*row) return InternalError(fmt::format("{}: statement returned a row", db_->name()));
  return Status::Ok();
}

void Stmt::Reset() {
  sqlite3_reset(stmt_.get());
  sqlite3_clear_bindings(stmt_.get());
}

std::string_view Stmt::Text(int i) const {
  const unsigned char* p = sqlite3_column_text(stmt_.get(), i);
  int n = sqlite3_column_bytes(stmt_.get(), i);
  if (!p) return {};
  return {reinterpret_cast<const char*>(p), static_cast<size_t>(n)};
}

std::span<const uint8_t> Stmt::Blob(int i) const {
  const void* p = sqlite3_column_blob(stmt_.get(), i);
  int n = sqlite3_column_bytes(stmt_.get(), i);
  if (!p) return {};
  return {static_cast<const uint8_t*>(p), static_cast<size_t>(n)};
}

}  // namespace solid::sqlite
