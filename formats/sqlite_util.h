// Internal RAII over the SQLite C API, turning every failure into a Status that
// names the database file.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "solid/formats/status.h"

namespace solid::sqlite {

struct DbCloser {
  void operator()(sqlite3* db) const { sqlite3_close_v2(db); }
};
struct StmtFinalizer {
  void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
};

enum class OpenMode {
  kCreate,          // a new file we own (a shard being written): read-write, created
  kUntrustedRead,   // a file from anywhere: read-only, defensive, trusted_schema off
};

class Db {
 public:
  // `name` (default: path) is what messages call the file: the final name of a file
  // written under a temporary one.
  static Result<Db> Open(const std::filesystem::path& path, OpenMode mode, std::string_view name = {});
  static Result<Db> OpenInMemory();

  sqlite3* get() const { return db_.get(); }
  const std::string& name() const { return name_; }

  // Runs one or more statements with no results.
  Status Exec(std::string_view sql);
  // "file: what: sqlite message (code)"
  Status Error(std::string_view what) const;
  // Result of a one-row, one-integer query such as "PRAGMA user_version".
  Result<int64_t> QueryInt(std::string_view sql);
  void Close() { db_.reset(); }

 private:
  std::unique_ptr<sqlite3, DbCloser> db_;
  std::string name_;
};

class Stmt {
 public:
  static Result<Stmt> Prepare(Db& db, std::string_view sql);

  Stmt& Bind(int index, int64_t v);
  Stmt& Bind(int index, double v);
  Stmt& Bind(int index, std::string_view text);
  Stmt& BindBlob(int index, std::span<const uint8_t> blob);
  Stmt& BindNull(int index);
  template <typename T>
  Stmt& Bind(int index, const std::optional<T>& v) {
    return v ? Bind(index, *v) : BindNull(index);
  }

  // Returns true while a row is available, false when done.
  Result<bool> Step();
  // Step() that must finish without a row (INSERT, UPDATE...). Resets for reuse.
  Status Run();
  void Reset();

  int ColumnCount() const { return sqlite3_column_count(stmt_.get()); }
  std::string_view ColumnName(int i) const { return sqlite3_column_name(stmt_.get(), i); }
  int ColumnType(int i) const { return sqlite3_column_type(stmt_.get(), i); }
  int64_t Int(int i) const { return sqlite3_column_int64(stmt_.get(), i); }
  double Real(int i) const { return sqlite3_column_double(stmt_.get(), i); }
  std::string_view Text(int i) const;
  std::span<const uint8_t> Blob(int i) const;

 private:
  std::unique_ptr<sqlite3_stmt, StmtFinalizer> stmt_;
  Db* db_ = nullptr;
  int bind_error_ = SQLITE_OK;
};

}  // namespace solid::sqlite
