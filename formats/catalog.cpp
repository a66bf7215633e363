#include "solid/formats/catalog.h"

#include <fmt/format.h>

#include <cmath>

#include "solid/formats/checksum.h"
#include "solid/formats/files.h"
#include "solid/formats/json_schema.h"
#include "solid/formats/schemas.h"
#include "sqlite_schema.h"
#include "sqlite_util.h"

namespace solid {
namespace fs = std::filesystem;
using sqlite::Db;
using sqlite::Stmt;

namespace {

constexpr std::string_view kColumns =
    "key, kind, source, file, status, input_files, input_hash, converter_version, options_hash, vertices, "
    "triangles, materials, textures, min_x, min_y, min_z, max_x, max_y, max_z, bytes_in, bytes_out, output_xxh64, "
    "warnings, error_code, error, counts, extras";

Result<AssetStatus> ParseAssetStatus(std::string_view s) {
  if (s == "ok") return AssetStatus::kOk;
  if (s == "ok_with_warnings") return AssetStatus::kOkWithWarnings;
  if (s == "failed") return AssetStatus::kFailed;
  return CorruptError(fmt::format("unknown asset status '{}'", s));
}

Result<nlohmann::json> ParseJsonColumn(const Stmt& s, int col, std::string_view where) {
  // The limits' nesting depth keeps a crafted row from exhausting the stack.
  Result<nlohmann::json> j = json::ParseJson(s.Text(col), fmt::format("{}: {}", where, s.ColumnName(col)));
  if (!j.ok() && j.status().code() == StatusCode::kParseError) {
    return CorruptError(fmt::format("{}: {}: not JSON", where, s.ColumnName(col)));
  }
  return j;
}

Result<CatalogEntry> ParseEntry(const Stmt& s, const std::string& file) {
  std::string where = fmt::format("{}: assets row '{}'", file, s.Text(0));
  for (int c : {0, 1, 2, 4, 5, 6, 7, 8, 22, 25, 26}) {
    if (s.ColumnType(c) != SQLITE_TEXT) return CorruptError(fmt::format("{}: {}: not text", where, s.ColumnName(c)));
  }
  CatalogEntry e;
  e.key = s.Text(0);
  e.kind = s.Text(1);
  e.source = s.Text(2);
  if (s.ColumnType(3) == SQLITE_TEXT) e.file = std::string(s.Text(3));
  SOLID_ASSIGN_OR_RETURN(e.status, ParseAssetStatus(s.Text(4)));
  SOLID_ASSIGN_OR_RETURN(e.input_files, ParseJsonColumn(s, 5, where));
  if (!ParseHex64(s.Text(6), &e.input_hash)) return CorruptError(where + ": input_hash: not 16 hex digits");
  e.converter_version = s.Text(7);
  if (!ParseHex64(s.Text(8), &e.options_hash)) return CorruptError(where + ": options_hash: not 16 hex digits");
  e.vertices = s.Int(9);
  e.triangles = s.Int(10);
  e.materials = s.Int(11);
  e.textures = s.Int(12);
  if (s.ColumnType(13) != SQLITE_NULL) {
    std::array<double, 6> b;
    for (int k = 0; k < 6; ++k) b[static_cast<size_t>(k)] = s.Real(13 + k);
    e.bounds = b;
  }
  e.bytes_in = s.Int(19);
  e.bytes_out = s.Int(20);
  if (s.ColumnType(21) == SQLITE_INTEGER) e.output_xxh64 = FromSqlInt(s.Int(21));
  SOLID_ASSIGN_OR_RETURN(e.warnings, ParseJsonColumn(s, 22, where));
  if (s.ColumnType(23) == SQLITE_TEXT) e.error_code = std::string(s.Text(23));
  if (s.ColumnType(24) == SQLITE_TEXT) e.error = std::string(s.Text(24));
  SOLID_ASSIGN_OR_RETURN(e.counts, ParseJsonColumn(s, 25, where));
  SOLID_ASSIGN_OR_RETURN(e.extras, ParseJsonColumn(s, 26, where));
  return e;
}

// A version-1 catalog (schemas/catalog_v1.sql) becomes version 2 in one transaction: the
// tables are made anew from catalog.sql (SQLite cannot alter a CHECK) and the rows copied.
// Any other file is refused as CheckSchema refuses it.
Status MigrateFromV1(Db& db) {
  SOLID_RETURN_IF_ERROR(sqlite::CheckSchema(db, "catalog_v1.sql"));
  SOLID_ASSIGN_OR_RETURN(std::string_view ddl, schemas::Get("catalog.sql"));
  SOLID_RETURN_IF_ERROR(db.Exec("BEGIN IMMEDIATE"));
  Status s = db.Exec(fmt::format(
      "ALTER TABLE catalog_meta RENAME TO catalog_meta_v1; ALTER TABLE assets RENAME TO assets_v1; {}\n"
      "INSERT INTO catalog_meta SELECT * FROM catalog_meta_v1; INSERT INTO assets ({}) SELECT {} FROM assets_v1;"
      "DROP TABLE catalog_meta_v1; DROP TABLE assets_v1;",
      ddl, kColumns, kColumns));
  if (!s.ok()) {
    (void)db.Exec("ROLLBACK");
    return s.WithContext("migrating the catalog from version 1");
  }
  SOLID_RETURN_IF_ERROR(db.Exec("COMMIT").WithContext("migrating the catalog from version 1"));
  return sqlite::CheckSchema(db, "catalog.sql");
}

}  // namespace

std::string_view AssetStatusName(AssetStatus s) {
  switch (s) {
    case AssetStatus::kOk: return "ok";
    case AssetStatus::kOkWithWarnings: return "ok_with_warnings";
    case AssetStatus::kFailed: return "failed";
  }
  return "failed";
}

struct Catalog::Impl {
  fs::path path;
  Db db;
};

Catalog::Catalog(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Catalog::Catalog(Catalog&&) noexcept = default;
Catalog& Catalog::operator=(Catalog&&) noexcept = default;
Catalog::~Catalog() = default;

Result<Catalog> Catalog::OpenForWriting(const fs::path& path) {
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    // Made aside and renamed into place: a creation cut short (a full disk) must not leave
    // half a schema, which the next run would refuse as a foreign file.
    files::RemoveStaleTemps(path);
    const fs::path temp = files::TempPathFor(path);
    Status created = [&]() -> Status {
      SOLID_ASSIGN_OR_RETURN(Db db, Db::Open(temp, sqlite::OpenMode::kCreate, path.string()));
      SOLID_RETURN_IF_ERROR(sqlite::CreateSchema(db, "catalog.sql"));
      db.Close();
      return files::SyncAndPublish(temp, path, /*replace=*/false);
    }();
    if (!created.ok()) fs::remove(temp, ec);
    // kAlreadyExists: another converter made it first, which is as good.
    if (!created.ok() && created.code() != StatusCode::kAlreadyExists) return created;
  }
  SOLID_ASSIGN_OR_RETURN(impl->db, Db::Open(path, sqlite::OpenMode::kCreate));
  if (Status s = sqlite::CheckSchema(impl->db, "catalog.sql"); !s.ok()) {
    if (s.code() != StatusCode::kUnsupportedVersion) return s;
    SOLID_RETURN_IF_ERROR(MigrateFromV1(impl->db));
  }
  // WAL: each Put is one small durable commit, and readers never block the converter.
  SOLID_RETURN_IF_ERROR(impl->db.Exec("PRAGMA journal_mode = WAL; PRAGMA synchronous = NORMAL;"));
  return Catalog(std::move(impl));
}

Status Catalog::Close() {
  Status s = impl_->db.Exec("PRAGMA wal_checkpoint(TRUNCATE)");
  impl_->db.Close();
  return s.WithContext("closing the catalog");
}

Result<Catalog> Catalog::OpenReadOnly(const fs::path& path) {
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return NotFoundError(path.string() + ": no catalog");
  SOLID_ASSIGN_OR_RETURN(impl->db, Db::Open(path, sqlite::OpenMode::kUntrustedRead));
  // Version 1 has the same columns: its rows read as they are.
  if (Status s = sqlite::CheckSchema(impl->db, "catalog.sql"); !s.ok()) {
    if (s.code() != StatusCode::kUnsupportedVersion || !sqlite::CheckSchema(impl->db, "catalog_v1.sql").ok()) return s;
  }
  return Catalog(std::move(impl));
}

Status Catalog::Put(const CatalogEntry& e) {
  SOLID_ASSIGN_OR_RETURN(Stmt s, Stmt::Prepare(impl_->db, fmt::format("INSERT OR REPLACE INTO assets ({}) VALUES "
                                                                      "(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,"
                                                                      "?,?,?,?)",
                                                                      kColumns)));
  s.Bind(1, std::string_view(e.key)).Bind(2, std::string_view(e.kind)).Bind(3, std::string_view(e.source));
  if (e.file) {
    s.Bind(4, std::string_view(*e.file));
  } else {
    s.BindNull(4);
  }
  // Warnings quote input text (material names, paths), which need not be UTF-8; dump()
  // would throw on it, so invalid bytes become U+FFFD.
  auto dump = [](const nlohmann::json& j) { return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace); };
  std::string input_files = dump(e.input_files), warnings = dump(e.warnings), counts = dump(e.counts),
              extras = dump(e.extras);
  s.Bind(5, AssetStatusName(e.status)).Bind(6, std::string_view(input_files));
  s.Bind(7, std::string_view(Hex64(e.input_hash))).Bind(8, std::string_view(e.converter_version));
  s.Bind(9, std::string_view(Hex64(e.options_hash)));
  s.Bind(10, e.vertices).Bind(11, e.triangles).Bind(12, e.materials).Bind(13, e.textures);
  for (int k = 0; k < 6; ++k) {
    if (e.bounds) {
      s.Bind(14 + k, (*e.bounds)[static_cast<size_t>(k)]);
    } else {
      s.BindNull(14 + k);
    }
  }
  s.Bind(20, e.bytes_in).Bind(21, e.bytes_out);
  if (e.output_xxh64) {
    s.Bind(22, ToSqlInt(*e.output_xxh64));
  } else {
    s.BindNull(22);
  }
  s.Bind(23, std::string_view(warnings));
  if (e.error_code) {
    s.Bind(24, std::string_view(*e.error_code));
  } else {
    s.BindNull(24);
  }
  if (e.error) {
    s.Bind(25, std::string_view(*e.error));
  } else {
    s.BindNull(25);
  }
  s.Bind(26, std::string_view(counts)).Bind(27, std::string_view(extras));
  SOLID_RETURN_IF_ERROR(s.Run().WithContext(fmt::format("catalog row '{}'", e.key)));
  // Backfilled at once (PASSIVE: a reader never blocks it), so that the WAL holds nothing
  // the file lacks: when the disk fills later, closing deletes the WAL and -shm without a
  // write instead of leaving them beside the catalog.
  return impl_->db.Exec("PRAGMA wal_checkpoint(PASSIVE)")
      .WithContext(fmt::format("catalog row '{}': checkpoint", e.key));
}

Result<std::optional<CatalogEntry>> Catalog::Find(std::string_view key) {
  SOLID_ASSIGN_OR_RETURN(Stmt s, Stmt::Prepare(impl_->db, fmt::format("SELECT {} FROM assets WHERE key = ?", kColumns)));
  s.Bind(1, key);
  SOLID_ASSIGN_OR_RETURN(bool row, s.Step());
  if (!row) return std::optional<CatalogEntry>();
  SOLID_ASSIGN_OR_RETURN(CatalogEntry e, ParseEntry(s, impl_->path.string()));
  // A damaged key index can lead the lookup to another row (catalog_fuzz crash-11d85253):
  // that row must not stand in for the asset asked for.
  if (e.key != key) {
    return CorruptError(fmt::format("{}: looking up '{}' found the row of '{}': the catalog's key index is damaged",
                                    impl_->path.string(), key, e.key));
  }
  return std::optional<CatalogEntry>(std::move(e));
}

Result<std::vector<CatalogEntry>> Catalog::All() {
  SOLID_ASSIGN_OR_RETURN(Stmt s, Stmt::Prepare(impl_->db, fmt::format("SELECT {} FROM assets ORDER BY key", kColumns)));
  std::vector<CatalogEntry> out;
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, s.Step());
    if (!row) return out;
    SOLID_ASSIGN_OR_RETURN(CatalogEntry e, ParseEntry(s, impl_->path.string()));
    out.push_back(std::move(e));
  }
}

Result<uint64_t> Catalog::ContentHash() {
  SOLID_ASSIGN_OR_RETURN(Stmt s, Stmt::Prepare(impl_->db, "SELECT key, output_xxh64 FROM assets WHERE status != "
                                                          "'failed' ORDER BY key"));
  std::string text;
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, s.Step());
    if (!row) break;
    text += fmt::format("{}\t{}\n", s.Text(0), s.Int(1));
  }
  return Xxh64(text);
}

}  // namespace solid
