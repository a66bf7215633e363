#include "sqlite_schema.h"

#include <fmt/format.h>

#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "solid/formats/schemas.h"

namespace solid::sqlite {
namespace {

struct SchemaFingerprint {
  int64_t application_id = 0;
  int64_t user_version = 0;
  std::vector<std::string> objects;  // "type name tbl_name sql", sorted by name
};

Result<SchemaFingerprint> Fingerprint(Db& db) {
  SchemaFingerprint fp;
  SOLID_ASSIGN_OR_RETURN(fp.application_id, db.QueryInt("PRAGMA application_id"));
  SOLID_ASSIGN_OR_RETURN(fp.user_version, db.QueryInt("PRAGMA user_version"));
  SOLID_ASSIGN_OR_RETURN(Stmt stmt,
                         Stmt::Prepare(db, "SELECT type, name, tbl_name, ifnull(sql, '') FROM sqlite_schema "
                                           "ORDER BY name"));
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    fp.objects.push_back(fmt::format("{} {} {} {}", stmt.Text(0), stmt.Text(1), stmt.Text(2), stmt.Text(3)));
  }
  return fp;
}

// The DDL run once in memory: the reference every file is compared with.
Result<SchemaFingerprint> Expected(std::string_view ddl_name) {
  static std::mutex mu;
  static std::map<std::string, SchemaFingerprint, std::less<>> cache;
  std::lock_guard lock(mu);
  if (auto it = cache.find(ddl_name); it != cache.end()) return it->second;
  SOLID_ASSIGN_OR_RETURN(Db db, Db::OpenInMemory());
  SOLID_RETURN_IF_ERROR(CreateSchema(db, ddl_name));
  SOLID_ASSIGN_OR_RETURN(SchemaFingerprint fp, Fingerprint(db));
  cache.emplace(std::string(ddl_name), fp);
  return fp;
}

}  // namespace

Status CreateSchema(Db& db, std::string_view ddl_name) {
  SOLID_ASSIGN_OR_RETURN(std::string_view ddl, schemas::Get(ddl_name));
  return db.Exec(ddl);
}

Status CheckSchema(Db& db, std::string_view ddl_name) {
  SOLID_ASSIGN_OR_RETURN(SchemaFingerprint want, Expected(ddl_name));
  SOLID_ASSIGN_OR_RETURN(SchemaFingerprint have, Fingerprint(db));
  if (have.application_id != want.application_id) {
    return CorruptError(fmt::format("{}: application_id {:#x}, expected {:#x} (not a file of kind {})", db.name(),
                                    have.application_id, want.application_id, ddl_name));
  }
  if (have.user_version != want.user_version) {
    return UnsupportedVersionError(fmt::format("{}: schema version {} (user_version), this build reads {}",
                                               db.name(), have.user_version, want.user_version));
  }
  if (have.objects != want.objects) {
    for (size_t i = 0; i < std::max(have.objects.size(), want.objects.size()); ++i) {
      std::string h = i < have.objects.size() ? have.objects[i] : "(nothing)";
      std::string w = i < want.objects.size() ? want.objects[i] : "(nothing)";
      if (h != w) {
        return CorruptError(fmt::format("{}: schema differs from {}: found '{}', expected '{}'", db.name(),
                                        ddl_name, h.substr(0, 120), w.substr(0, 120)));
      }
    }
  }
  return Status::Ok();
}

}  // namespace solid::sqlite
