#include "solid/formats/shard.h"

#include <fmt/format.h>

#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <algorithm>
#include <optional>

#include "solid/formats/files.h"
#include "solid/formats/checksum.h"
#include "solid/formats/metrics.h"
#include "sqlite_schema.h"
#include "sqlite_util.h"

namespace solid {
namespace fs = std::filesystem;
using sqlite::Db;
using sqlite::Stmt;

static_assert(std::endian::native == std::endian::little, "matrix blobs are stored little-endian");

namespace {

constexpr std::string_view kTargetDdl = "shard.sql";
constexpr std::string_view kQueryDdl = "queries.sql";
constexpr int64_t kMaxImageSide = 65535;
constexpr size_t kMaxKeyLength = 1024;

Result<int64_t> ParseShardFileName(std::string_view name, std::string_view prefix) {
  constexpr std::string_view kSuffix = ".sqlite";
  if (!name.starts_with(prefix) || !name.ends_with(kSuffix) || name.size() < prefix.size() + kSuffix.size() + 6) {
    return InvalidArgumentError(fmt::format("'{}' is not named {}NNNNNN{}", name, prefix, kSuffix));
  }
  std::string_view digits = name.substr(prefix.size(), name.size() - prefix.size() - kSuffix.size());
  int64_t index = -1;
  auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), index);
  if (ec != std::errc() || end != digits.data() + digits.size() || index < 0 ||
      digits.find_first_not_of("0123456789") != std::string_view::npos) {
    return InvalidArgumentError(fmt::format("'{}' is not named {}NNNNNN{}", name, prefix, kSuffix));
  }
  return index;
}

std::vector<uint8_t> AffineBytes(const Affine3x4& m) {
  std::vector<uint8_t> out(sizeof(double) * 12);
  std::memcpy(out.data(), m.data(), out.size());
  return out;
}

bool AllFinite(std::initializer_list<double> values) {
  for (double v : values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

bool AllFinite(const Affine3x4& m) {
  for (double v : m) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

// row_xxh64 (docs/dataset-format.md, "Checksums"): XXH64 over each value of the row in
// column order, as a type byte and its bytes. A BLOB or mask string with a sibling
// checksum column adds only its length: the sibling covers its bytes, and checking a row
// then costs no pass over its image.
class RowHash {
 public:
  void Null() { Tag(0); }
  void Int(int64_t v) {
    Tag(1);
    Word(static_cast<uint64_t>(v));
  }
  void Real(double v) {
    Tag(2);
    Word(std::bit_cast<uint64_t>(v));
  }
  void Text(std::string_view t) {
    Tag(3);
    Word(t.size());
    bytes_.append(t);
  }
  void Blob(std::span<const uint8_t> b) {
    Tag(4);
    Word(b.size());
    bytes_.append(reinterpret_cast<const char*>(b.data()), b.size());
  }
  void Covered(size_t length) {
    Tag(5);
    Word(length);
  }
  uint64_t Digest() const { return Xxh64(bytes_); }

 private:
  void Tag(char t) { bytes_.push_back(t); }
  void Word(uint64_t v) {
    for (int i = 0; i < 8; ++i) bytes_.push_back(static_cast<char>(v >> (8 * i)));
  }
  std::string bytes_;
};

// SQLite may keep an integral REAL as an integer on disk and reads it back as +0.0
// whatever its sign: store zero as +0.0, so that what is hashed is what is read.
double Canonical(double v) { return v == 0 ? 0.0 : v; }

// Binds the values of one INSERT in column order and hashes them as RowHash does;
// Finish() binds row_xxh64 as the last column.
class RowBinder {
 public:
  explicit RowBinder(Stmt& stmt) : stmt_(stmt) {}
  RowBinder& Int(int64_t v) {
    stmt_.Bind(++col_, v);
    hash_.Int(v);
    return *this;
  }
  RowBinder& Real(double v) {
    v = Canonical(v);
    stmt_.Bind(++col_, v);
    hash_.Real(v);
    return *this;
  }
  RowBinder& Real(const std::optional<double>& v) { return v ? Real(*v) : Null(); }
  RowBinder& Text(std::string_view v) {
    stmt_.Bind(++col_, v);
    hash_.Text(v);
    return *this;
  }
  RowBinder& Text(const std::string& v) { return Text(std::string_view(v)); }
  RowBinder& Text(const std::optional<std::string>& v) { return v ? Text(std::string_view(*v)) : Null(); }
  RowBinder& Null() {
    stmt_.BindNull(++col_);
    hash_.Null();
    return *this;
  }
  // A blob (or mask string) and its checksum column.
  RowBinder& Checked(std::span<const uint8_t> bytes, bool text) {
    if (text) {
      stmt_.Bind(++col_, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    } else {
      stmt_.BindBlob(++col_, bytes);
    }
    hash_.Covered(bytes.size());
    return Int(ToSqlInt(Xxh64(bytes)));
  }
  RowBinder& CheckedText(std::string_view text) {
    return Checked({reinterpret_cast<const uint8_t*>(text.data()), text.size()}, true);
  }
  Stmt& Finish() {
    stmt_.Bind(++col_, ToSqlInt(hash_.Digest()));
    return stmt_;
  }

 private:
  Stmt& stmt_;
  int col_ = 0;
  RowHash hash_;
};

// The row_xxh64 of the values in columns [0, checksum_col) of the current row; `covered`
// lists the columns whose bytes a sibling checksum covers.
uint64_t RowHashOf(const Stmt& stmt, int checksum_col, const std::vector<int>& covered) {
  RowHash hash;
  for (int c = 0; c < checksum_col; ++c) {
    const int type = stmt.ColumnType(c);
    if (type != SQLITE_NULL && std::find(covered.begin(), covered.end(), c) != covered.end()) {
      hash.Covered(type == SQLITE_TEXT ? stmt.Text(c).size() : stmt.Blob(c).size());
      continue;
    }
    switch (type) {
      case SQLITE_NULL: hash.Null(); break;
      case SQLITE_INTEGER: hash.Int(stmt.Int(c)); break;
      case SQLITE_FLOAT: hash.Real(stmt.Real(c)); break;
      case SQLITE_TEXT: hash.Text(stmt.Text(c)); break;
      default: hash.Blob(stmt.Blob(c)); break;
    }
  }
  return hash.Digest();
}

// A table as the checksums see it: every column in table order, row_xxh64 last.
struct TableLayout {
  std::string_view name;
  std::string_view columns;
  int checksum_col;                       // of row_xxh64
  std::vector<int> covered;               // columns whose bytes a sibling checksum covers
  std::vector<std::pair<int, int>> blobs;  // (content, its checksum) column pairs
  std::string_view order;                 // the canonical row order of content_xxh64
};

constexpr std::string_view kContentKey = "content_xxh64";

constexpr std::string_view kMetaColumns = "key, value, row_xxh64";

constexpr std::string_view kImageColumns =
    "image_id, seed, width, height, image_format, image, image_xxh64, fx, fy, cx, cy, "
    "world_from_camera, world_from_camera_xxh64, depth, depth_xxh64, room_key, row_xxh64";

constexpr std::string_view kInstanceColumns =
    "instance_id, image_id, ordinal, model_key, visible_rle, visible_rle_xxh64, full_rle, full_rle_xxh64, "
    "visible_x, visible_y, visible_w, visible_h, full_x, full_y, full_w, full_h, visible_area, full_area, "
    "occlusion, truncation, scale_class, world_from_object, world_from_object_xxh64, object_scale, "
    "camera_distance, view_azimuth, view_elevation, row_xxh64";

constexpr std::string_view kModelColumns = "model_key, view_count, failure, row_xxh64";

constexpr std::string_view kViewColumns =
    "query_id, model_key, view_index, azimuth, elevation, width, height, image_format, image, image_xxh64, "
    "box_x, box_y, box_w, box_h, row_xxh64";

const TableLayout& MetaTable() {
  static const TableLayout t{"shard_meta", kMetaColumns, 2, {}, {}, "key"};
  return t;
}
const TableLayout& ImagesTable() {
  static const TableLayout t{"images", kImageColumns, 16, {5, 11, 13}, {{5, 6}, {11, 12}, {13, 14}}, "image_id"};
  return t;
}
const TableLayout& InstancesTable() {
  static const TableLayout t{"instances", kInstanceColumns, 27, {4, 6, 21}, {{4, 5}, {6, 7}, {21, 22}}, "instance_id"};
  return t;
}
const TableLayout& ModelsTable() {
  static const TableLayout t{"query_models", kModelColumns, 3, {}, {}, "model_key"};
  return t;
}
const TableLayout& ViewsTable() {
  static const TableLayout t{"query_views", kViewColumns, 14, {8}, {{8, 9}}, "query_id"};
  return t;
}

std::string RowLabel(const Stmt& stmt, const TableLayout& table) {
  if (stmt.ColumnType(0) == SQLITE_INTEGER) return fmt::format("{} row {}", table.name, stmt.Int(0));
  return fmt::format("{} '{}'", table.name, stmt.Text(0).substr(0, 80));
}

Status RowChecksumMismatch(const std::string& where, uint64_t stored, uint64_t actual) {
  return CorruptError(fmt::format("{}: row_xxh64: checksum mismatch (stored {}, the row's values give {})", where,
                                  Hex64(stored), Hex64(actual)));
}

// content_xxh64: XXH64 over the row checksums (8 bytes little-endian each) of shard_meta
// (by key, without content_xxh64 itself), then of each table in its canonical order. A row
// added, removed or changed changes it.
class ContentDigest {
 public:
  void Add(uint64_t row_xxh64) {
    for (int i = 0; i < 8; ++i) bytes_.push_back(static_cast<char>(row_xxh64 >> (8 * i)));
  }
  uint64_t Digest() const { return Xxh64(bytes_); }

 private:
  std::string bytes_;
};

// Recomputes every row checksum (and, with kVerify, every blob checksum) of `tables` and
// content_xxh64; the first disagreement, naming its row.
Status VerifyTables(Db& db, const std::vector<const TableLayout*>& tables, ChecksumPolicy policy) {
  ContentDigest digest;
  std::optional<uint64_t> stored_content;
  for (const TableLayout* table : tables) {
    SOLID_ASSIGN_OR_RETURN(Stmt stmt, Stmt::Prepare(db, fmt::format("SELECT {} FROM {} ORDER BY {}", table->columns,
                                                                    table->name, table->order)));
    const bool meta = table == &MetaTable();
    for (;;) {
      SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
      if (!row) break;
      const std::string where = fmt::format("{}: {}", db.name(), RowLabel(stmt, *table));
      if (stmt.ColumnType(table->checksum_col) != SQLITE_INTEGER) {
        return CorruptError(where + ": row_xxh64: not an integer");
      }
      const uint64_t stored = FromSqlInt(stmt.Int(table->checksum_col));
      const uint64_t actual = RowHashOf(stmt, table->checksum_col, table->covered);
      if (stored != actual) return RowChecksumMismatch(where, stored, actual);
      if (policy == ChecksumPolicy::kVerify) {
        for (const auto& [content, checksum] : table->blobs) {
          const int type = stmt.ColumnType(content);
          if (type == SQLITE_NULL) continue;
          std::span<const uint8_t> bytes = stmt.Blob(content);
          if (stmt.ColumnType(checksum) != SQLITE_INTEGER || FromSqlInt(stmt.Int(checksum)) != Xxh64(bytes)) {
            return CorruptError(fmt::format("{}: {}: checksum mismatch", where, stmt.ColumnName(content)));
          }
        }
      }
      if (meta && stmt.Text(0) == kContentKey) {
        uint64_t value = 0;
        if (!ParseHex64(stmt.Text(1), &value)) return CorruptError(where + ": value: not 16 hex digits");
        stored_content = value;
        continue;
      }
      digest.Add(stored);
    }
  }
  if (!stored_content) return CorruptError(fmt::format("{}: shard_meta: no {}", db.name(), kContentKey));
  if (*stored_content != digest.Digest()) {
    return CorruptError(fmt::format("{}: shard_meta '{}': stored {}, the rows give {} (a row was added, removed or "
                                    "changed)",
                                    db.name(), kContentKey, Hex64(*stored_content), Hex64(digest.Digest())));
  }
  return Status::Ok();
}

// Common part of both shard writers: the temporary file, its transaction, publication.
class AtomicShard {
 public:
  static Result<AtomicShard> Begin(const fs::path& final_path, const ShardWriteOptions& options,
                                   std::string_view ddl) {
    AtomicShard shard;
    shard.final_path_ = final_path;
    shard.replace_ = options.replace_existing;
    std::error_code ec;
    if (!options.replace_existing && fs::exists(final_path, ec)) {
      return AlreadyExistsError(final_path.string() + ": shard exists (it is complete; delete it to rewrite)");
    }
    files::RemoveStaleTemps(final_path);
    shard.temp_path_ = files::TempPathFor(final_path);
    fs::remove(shard.temp_path_, ec);
    SOLID_ASSIGN_OR_RETURN(shard.db_, Db::Open(shard.temp_path_, sqlite::OpenMode::kCreate, final_path.string()));
    shard.open_ = true;
    // The temporary file is never trusted before the rename, so SQLite's own
    // crash safety (journal, syncs) would only cost time: we sync once at the end.
    SOLID_RETURN_IF_ERROR(shard.db_.Exec(
        "PRAGMA page_size = 16384; PRAGMA journal_mode = OFF; PRAGMA synchronous = OFF;"
        "PRAGMA locking_mode = EXCLUSIVE; PRAGMA foreign_keys = ON;"));
    SOLID_RETURN_IF_ERROR(sqlite::CreateSchema(shard.db_, ddl));
    SOLID_RETURN_IF_ERROR(shard.db_.Exec("BEGIN"));
    return shard;
  }

  AtomicShard() = default;
  AtomicShard(AtomicShard&& o) noexcept { *this = std::move(o); }
  AtomicShard& operator=(AtomicShard&& o) noexcept {
    Abandon();
    final_path_ = std::move(o.final_path_);
    temp_path_ = std::move(o.temp_path_);
    db_ = std::move(o.db_);
    replace_ = o.replace_;
    open_ = std::exchange(o.open_, false);
    return *this;
  }
  ~AtomicShard() { Abandon(); }

  Db& db() { return db_; }
  const fs::path& final_path() const { return final_path_; }

 private:
  Status PutMeta(std::string_view key, std::string_view value) {
    SOLID_ASSIGN_OR_RETURN(Stmt stmt, Stmt::Prepare(db_, "INSERT OR REPLACE INTO shard_meta VALUES (?, ?, ?)"));
    RowBinder(stmt).Text(key).Text(value).Finish();
    return stmt.Run().WithContext(fmt::format("{}: shard_meta '{}'", final_path_.string(), key));
  }

  Status WriteContentDigest(const std::vector<const TableLayout*>& tables) {
    ContentDigest digest;
    for (const TableLayout* table : tables) {
      SOLID_ASSIGN_OR_RETURN(Stmt stmt, Stmt::Prepare(db_, fmt::format("SELECT row_xxh64 FROM {} ORDER BY {}",
                                                                       table->name, table->order)));
      for (;;) {
        SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
        if (!row) break;
        digest.Add(FromSqlInt(stmt.Int(0)));
      }
    }
    return PutMeta(kContentKey, Hex64(digest.Digest()));
  }

 public:

  Status Usable() const {
    if (!open_) return InvalidArgumentError(final_path_.string() + ": writer already committed or failed");
    return Status::Ok();
  }

  Status SetMeta(std::string_view key, std::string_view value) {
    SOLID_RETURN_IF_ERROR(Usable());
    if (key == kContentKey) return InvalidArgumentError(fmt::format("{}: {} is the writer's", final_path_.string(), key));
    return PutMeta(key, value);
  }

  // Publishes the shard, after content_xxh64 over `tables` (their canonical order).
  Status Commit(const std::vector<const TableLayout*>& tables, const std::function<void()>& release_statements) {
    SOLID_RETURN_IF_ERROR(Usable());
    Status s = WriteContentDigest(tables);
    if (s.ok()) s = db_.Exec("COMMIT");
    release_statements();
    db_.Close();
    if (s.ok()) s = files::SyncAndPublish(temp_path_, final_path_, replace_);
    open_ = false;
    if (!s.ok()) {
      std::error_code ec;
      fs::remove(temp_path_, ec);
    }
    return s;
  }

  void Abandon() {
    if (!open_) return;
    db_.Close();
    std::error_code ec;
    fs::remove(temp_path_, ec);
    open_ = false;
  }

 private:
  fs::path final_path_, temp_path_;
  Db db_;
  bool replace_ = false;
  bool open_ = false;
};

// Typed, checked access to one row of an untrusted file; errors name the row.
class RowReader {
 public:
  RowReader(const Stmt& stmt, std::string where) : stmt_(stmt), where_(std::move(where)) {}

  Status Fail(std::string_view field, std::string_view what) const {
    return CorruptError(fmt::format("{}: {}: {}", where_, field, what));
  }

  Result<int64_t> Int(int col, std::string_view field, int64_t lo = INT64_MIN, int64_t hi = INT64_MAX) const {
    if (stmt_.ColumnType(col) != SQLITE_INTEGER) return Fail(field, "not an integer");
    int64_t v = stmt_.Int(col);
    if (v < lo || v > hi) return Fail(field, fmt::format("{} outside [{}, {}]", v, lo, hi));
    return v;
  }

  Result<double> Real(int col, std::string_view field) const {
    int type = stmt_.ColumnType(col);
    if (type != SQLITE_FLOAT && type != SQLITE_INTEGER) return Fail(field, "not a number");
    double v = stmt_.Real(col);
    if (!std::isfinite(v)) return Fail(field, "not finite");
    return v;
  }

  Result<std::optional<double>> OptionalReal(int col, std::string_view field) const {
    if (stmt_.ColumnType(col) == SQLITE_NULL) return std::optional<double>();
    SOLID_ASSIGN_OR_RETURN(double v, Real(col, field));
    return std::optional<double>(v);
  }

  Result<std::string> Text(int col, std::string_view field, size_t max_length) const {
    if (stmt_.ColumnType(col) != SQLITE_TEXT) return Fail(field, "not text");
    std::string_view v = stmt_.Text(col);
    if (v.size() > max_length) return Fail(field, fmt::format("{} bytes, more than {}", v.size(), max_length));
    return std::string(v);
  }

  Result<std::optional<std::string>> OptionalText(int col, std::string_view field, size_t max_length) const {
    if (stmt_.ColumnType(col) == SQLITE_NULL) return std::optional<std::string>();
    SOLID_ASSIGN_OR_RETURN(std::string v, Text(col, field, max_length));
    return std::optional<std::string>(std::move(v));
  }

  // Bytes of a BLOB (or TEXT, for RLE strings) checked against the checksum column.
  Result<std::span<const uint8_t>> Checked(int col, int checksum_col, std::string_view field,
                                           ChecksumPolicy policy, bool text) const {
    int type = stmt_.ColumnType(col);
    if (type != (text ? SQLITE_TEXT : SQLITE_BLOB)) return Fail(field, text ? "not text" : "not a blob");
    std::span<const uint8_t> bytes;
    if (text) {
      std::string_view t = stmt_.Text(col);
      bytes = {reinterpret_cast<const uint8_t*>(t.data()), t.size()};
    } else {
      bytes = stmt_.Blob(col);
    }
    if (stmt_.ColumnType(checksum_col) != SQLITE_INTEGER) return Fail(field, "checksum is not an integer");
    if (policy == ChecksumPolicy::kVerify) {
      uint64_t stored = FromSqlInt(stmt_.Int(checksum_col));
      uint64_t actual = Xxh64(bytes);
      if (stored != actual) {
        return Fail(field, fmt::format("checksum mismatch (stored {}, computed {} over {} bytes)", Hex64(stored),
                                       Hex64(actual), bytes.size()));
      }
    }
    return bytes;
  }

  Result<Affine3x4> Affine(int col, int checksum_col, std::string_view field, ChecksumPolicy policy) const {
    SOLID_ASSIGN_OR_RETURN(std::span<const uint8_t> bytes, Checked(col, checksum_col, field, policy, false));
    if (bytes.size() != sizeof(double) * 12) return Fail(field, fmt::format("{} bytes, expected 96", bytes.size()));
    Affine3x4 m;
    std::memcpy(m.data(), bytes.data(), bytes.size());
    if (!AllFinite(m)) return Fail(field, "not finite");
    return m;
  }

  // row_xxh64 of a row read with all of its table's columns (TableLayout).
  Status RowChecksum(const TableLayout& table) const {
    if (stmt_.ColumnType(table.checksum_col) != SQLITE_INTEGER) return Fail("row_xxh64", "not an integer");
    const uint64_t stored = FromSqlInt(stmt_.Int(table.checksum_col));
    const uint64_t actual = RowHashOf(stmt_, table.checksum_col, table.covered);
    if (stored != actual) return RowChecksumMismatch(where_, stored, actual);
    return Status::Ok();
  }

  Result<rle::Box> Box(int first_col, std::string_view field) const {
    rle::Box b;
    SOLID_ASSIGN_OR_RETURN(b.x, Int(first_col, fmt::format("{}_x", field), 0, kMaxImageSide));
    SOLID_ASSIGN_OR_RETURN(b.y, Int(first_col + 1, fmt::format("{}_y", field), 0, kMaxImageSide));
    SOLID_ASSIGN_OR_RETURN(b.w, Int(first_col + 2, fmt::format("{}_w", field), 0, kMaxImageSide));
    SOLID_ASSIGN_OR_RETURN(b.h, Int(first_col + 3, fmt::format("{}_h", field), 0, kMaxImageSide));
    return b;
  }

 private:
  const Stmt& stmt_;
  std::string where_;
};

Result<std::vector<std::pair<std::string, std::string>>> ReadMeta(Db& db) {
  SOLID_ASSIGN_OR_RETURN(Stmt stmt, Stmt::Prepare(db, fmt::format("SELECT {} FROM shard_meta ORDER BY key",
                                                                  kMetaColumns)));
  std::vector<std::pair<std::string, std::string>> meta;
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    RowReader r(stmt, fmt::format("{}: {}", db.name(), RowLabel(stmt, MetaTable())));
    SOLID_RETURN_IF_ERROR(r.RowChecksum(MetaTable()));
    SOLID_ASSIGN_OR_RETURN(std::string key, r.Text(0, "key", kMaxKeyLength));
    SOLID_ASSIGN_OR_RETURN(std::string value, r.Text(1, "value", 1 << 20));
    if (key == kContentKey) continue;  // the writer's, checked by VerifyContent
    meta.emplace_back(std::move(key), std::move(value));
  }
  return meta;
}

Result<Db> OpenUntrusted(const fs::path& path, std::string_view ddl) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return NotFoundError(path.string() + ": no such shard file");
  SOLID_ASSIGN_OR_RETURN(Db db, Db::Open(path, sqlite::OpenMode::kUntrustedRead));
  SOLID_RETURN_IF_ERROR(sqlite::CheckSchema(db, ddl));
  return db;
}

Result<InstanceRecord> ParseInstance(const Stmt& stmt, const std::string& file, ChecksumPolicy policy) {
  RowReader r(stmt, fmt::format("{}: instances row {}", file, stmt.Int(0)));
  InstanceRecord in;
  SOLID_ASSIGN_OR_RETURN(in.image_id, r.Int(1, "image_id", 0));
  SOLID_ASSIGN_OR_RETURN(int64_t ordinal, r.Int(2, "ordinal", 0, INT32_MAX));
  if (ordinal >= kMaxInstancesPerImage) {
    return LimitExceededError(fmt::format("{}: instances row {}: ordinal {}: more than the limit of {} instances per "
                                          "image",
                                          file, stmt.Int(0), ordinal, kMaxInstancesPerImage));
  }
  in.ordinal = static_cast<int32_t>(ordinal);
  SOLID_ASSIGN_OR_RETURN(in.model_key, r.Text(3, "model_key", kMaxKeyLength));
  SOLID_ASSIGN_OR_RETURN(auto visible, r.Checked(4, 5, "visible_rle", policy, true));
  in.visible_rle.assign(visible.begin(), visible.end());
  SOLID_ASSIGN_OR_RETURN(auto full, r.Checked(6, 7, "full_rle", policy, true));
  in.full_rle.assign(full.begin(), full.end());
  SOLID_ASSIGN_OR_RETURN(in.visible_box, r.Box(8, "visible"));
  SOLID_ASSIGN_OR_RETURN(in.full_box, r.Box(12, "full"));
  constexpr int64_t kMaxArea = kMaxImageSide * kMaxImageSide;
  SOLID_ASSIGN_OR_RETURN(int64_t visible_area, r.Int(16, "visible_area", 0, kMaxArea));
  SOLID_ASSIGN_OR_RETURN(int64_t full_area, r.Int(17, "full_area", 0, kMaxArea));
  in.visible_area = static_cast<uint64_t>(visible_area);
  in.full_area = static_cast<uint64_t>(full_area);
  SOLID_ASSIGN_OR_RETURN(in.occlusion, r.OptionalReal(18, "occlusion"));
  if (in.occlusion && (*in.occlusion < 0 || *in.occlusion > 1)) return r.Fail("occlusion", "outside [0, 1]");
  SOLID_ASSIGN_OR_RETURN(in.truncation, r.Real(19, "truncation"));
  if (in.truncation < 0 || in.truncation > 1) return r.Fail("truncation", "outside [0, 1]");
  SOLID_ASSIGN_OR_RETURN(std::optional<std::string> scale, r.OptionalText(20, "scale_class", 16));
  if (scale) {
    Result<ScaleClass> parsed = ParseScaleClass(*scale);
    if (!parsed.ok()) return r.Fail("scale_class", parsed.status().message());
    in.scale_class = *parsed;
  }
  SOLID_ASSIGN_OR_RETURN(in.world_from_object, r.Affine(21, 22, "world_from_object", policy));
  SOLID_ASSIGN_OR_RETURN(in.object_scale, r.Real(23, "object_scale"));
  SOLID_ASSIGN_OR_RETURN(in.camera_distance, r.Real(24, "camera_distance"));
  SOLID_ASSIGN_OR_RETURN(in.view_azimuth, r.Real(25, "view_azimuth"));
  SOLID_ASSIGN_OR_RETURN(in.view_elevation, r.Real(26, "view_elevation"));
  // Last: a value's own check names the field more precisely.
  SOLID_RETURN_IF_ERROR(r.RowChecksum(InstancesTable()));
  return in;
}

Result<QueryViewRecord> ParseView(const Stmt& stmt, const std::string& file, ChecksumPolicy policy) {
  RowReader r(stmt, fmt::format("{}: query_views row {}", file, stmt.Int(0)));
  QueryViewRecord v;
  SOLID_ASSIGN_OR_RETURN(v.model_key, r.Text(1, "model_key", kMaxKeyLength));
  SOLID_ASSIGN_OR_RETURN(int64_t view_index, r.Int(2, "view_index", 0, 1 << 16));
  v.view_index = static_cast<int32_t>(view_index);
  SOLID_ASSIGN_OR_RETURN(v.azimuth, r.Real(3, "azimuth"));
  SOLID_ASSIGN_OR_RETURN(v.elevation, r.Real(4, "elevation"));
  SOLID_ASSIGN_OR_RETURN(int64_t width, r.Int(5, "width", 1, kMaxImageSide));
  SOLID_ASSIGN_OR_RETURN(int64_t height, r.Int(6, "height", 1, kMaxImageSide));
  v.width = static_cast<uint32_t>(width);
  v.height = static_cast<uint32_t>(height);
  SOLID_ASSIGN_OR_RETURN(std::string format, r.Text(7, "image_format", 16));
  Result<ImageFormat> parsed = ParseImageFormat(format);
  if (!parsed.ok()) return r.Fail("image_format", parsed.status().message());
  v.format = *parsed;
  SOLID_ASSIGN_OR_RETURN(auto image, r.Checked(8, 9, "image", policy, false));
  v.image.assign(image.begin(), image.end());
  SOLID_ASSIGN_OR_RETURN(v.box, r.Box(10, "box"));
  // Last: a value's own check names the field more precisely.
  SOLID_RETURN_IF_ERROR(r.RowChecksum(ViewsTable()));
  return v;
}

}  // namespace

std::string TargetShardFileName(int64_t shard_index) { return fmt::format("shard-{:06d}.sqlite", shard_index); }
std::string QueryShardFileName(int64_t shard_index) { return fmt::format("queries-{:06d}.sqlite", shard_index); }
Result<int64_t> ParseTargetShardFileName(std::string_view name) { return ParseShardFileName(name, "shard-"); }
Result<int64_t> ParseQueryShardFileName(std::string_view name) { return ParseShardFileName(name, "queries-"); }

// ---------------------------------------------------------------------------------------------
// ShardWriter

struct ShardWriter::Impl {
  AtomicShard shard;
  std::optional<Stmt> insert_image, insert_instance;
  int64_t next_instance_id = 1;
};

ShardWriter::ShardWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ShardWriter::ShardWriter(ShardWriter&&) noexcept = default;
ShardWriter& ShardWriter::operator=(ShardWriter&&) noexcept = default;
ShardWriter::~ShardWriter() = default;  // members go in reverse order: statements before the file

Result<ShardWriter> ShardWriter::Create(const fs::path& path, const ShardWriteOptions& options) {
  auto impl = std::make_unique<Impl>();
  SOLID_ASSIGN_OR_RETURN(impl->shard, AtomicShard::Begin(path, options, kTargetDdl));
  Db& db = impl->shard.db();
  SOLID_ASSIGN_OR_RETURN(impl->insert_image,
                         Stmt::Prepare(db, fmt::format("INSERT INTO images ({}) VALUES "
                                                       "(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)",
                                                       kImageColumns)));
  SOLID_ASSIGN_OR_RETURN(
      impl->insert_instance,
      Stmt::Prepare(db, fmt::format("INSERT INTO instances ({}) VALUES "
                                    "(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)",
                                    kInstanceColumns)));
  return ShardWriter(std::move(impl));
}

const fs::path& ShardWriter::path() const { return impl_->shard.final_path(); }

Status ShardWriter::SetMeta(std::string_view key, std::string_view value) { return impl_->shard.SetMeta(key, value); }

Status ShardWriter::AddImage(const ImageRecord& im) {
  SOLID_RETURN_IF_ERROR(impl_->shard.Usable());
  std::string where = fmt::format("{}: image {}", path().string(), im.image_id);
  if (im.width == 0 || im.height == 0 || im.width > kMaxImageSide || im.height > kMaxImageSide) {
    return InvalidArgumentError(fmt::format("{}: size {}x{} outside 1..{}", where, im.width, im.height, kMaxImageSide));
  }
  if (im.image.empty()) return InvalidArgumentError(where + ": no encoded image bytes");
  const Camera& c = im.camera;
  if (!AllFinite({c.fx, c.fy, c.cx, c.cy}) || !AllFinite(c.world_from_camera)) {
    return InvalidArgumentError(where + ": camera has a non-finite value");
  }
  std::vector<uint8_t> pose = AffineBytes(c.world_from_camera);
  RowBinder row(*impl_->insert_image);
  row.Int(im.image_id).Int(ToSqlInt(im.seed)).Int(im.width).Int(im.height).Text(ImageFormatName(im.format));
  row.Checked(im.image, false).Real(c.fx).Real(c.fy).Real(c.cx).Real(c.cy).Checked(pose, false);
  if (im.depth_exr) {
    row.Checked(*im.depth_exr, false);
  } else {
    row.Null().Null();
  }
  return row.Text(im.room_key).Finish().Run().WithContext(where);
}

Status ShardWriter::AddInstance(const InstanceRecord& in) {
  SOLID_RETURN_IF_ERROR(impl_->shard.Usable());
  std::string where = fmt::format("{}: image {} instance {}", path().string(), in.image_id, in.ordinal);
  if (!AllFinite({in.truncation, in.object_scale, in.camera_distance, in.view_azimuth, in.view_elevation,
                  in.occlusion.value_or(0.0)}) ||
      !AllFinite(in.world_from_object)) {
    return InvalidArgumentError(where + ": a non-finite value");
  }
  if (in.model_key.empty() || in.model_key.size() > kMaxKeyLength) {
    return InvalidArgumentError(where + ": model_key must have 1.." + std::to_string(kMaxKeyLength) + " bytes");
  }
  if (in.ordinal < 0 || in.ordinal >= kMaxInstancesPerImage) {
    return LimitExceededError(
        fmt::format("{}: ordinal outside [0, {}): the limit is {} instances per image", where, kMaxInstancesPerImage,
                    kMaxInstancesPerImage));
  }
  std::vector<uint8_t> pose = AffineBytes(in.world_from_object);
  RowBinder row(*impl_->insert_instance);
  row.Int(impl_->next_instance_id).Int(in.image_id).Int(in.ordinal).Text(in.model_key);
  row.CheckedText(in.visible_rle).CheckedText(in.full_rle);
  row.Int(in.visible_box.x).Int(in.visible_box.y).Int(in.visible_box.w).Int(in.visible_box.h);
  row.Int(in.full_box.x).Int(in.full_box.y).Int(in.full_box.w).Int(in.full_box.h);
  row.Int(static_cast<int64_t>(in.visible_area)).Int(static_cast<int64_t>(in.full_area));
  row.Real(in.occlusion).Real(in.truncation);
  if (in.scale_class) {
    row.Text(ScaleClassName(*in.scale_class));
  } else {
    row.Null();
  }
  row.Checked(pose, false).Real(in.object_scale).Real(in.camera_distance).Real(in.view_azimuth);
  row.Real(in.view_elevation);
  SOLID_RETURN_IF_ERROR(row.Finish().Run().WithContext(where));
  ++impl_->next_instance_id;
  return Status::Ok();
}

Status ShardWriter::Commit() {
  return impl_->shard.Commit({&MetaTable(), &ImagesTable(), &InstancesTable()}, [this] {
    impl_->insert_image.reset();
    impl_->insert_instance.reset();
  });
}

// ---------------------------------------------------------------------------------------------
// QueryShardWriter

struct QueryShardWriter::Impl {
  AtomicShard shard;
  std::optional<Stmt> insert_model, insert_view;
  int64_t next_query_id = 1;
};

QueryShardWriter::QueryShardWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
QueryShardWriter::QueryShardWriter(QueryShardWriter&&) noexcept = default;
QueryShardWriter& QueryShardWriter::operator=(QueryShardWriter&&) noexcept = default;
QueryShardWriter::~QueryShardWriter() = default;

Result<QueryShardWriter> QueryShardWriter::Create(const fs::path& path, const ShardWriteOptions& options) {
  auto impl = std::make_unique<Impl>();
  SOLID_ASSIGN_OR_RETURN(impl->shard, AtomicShard::Begin(path, options, kQueryDdl));
  Db& db = impl->shard.db();
  SOLID_ASSIGN_OR_RETURN(impl->insert_model, Stmt::Prepare(db, fmt::format("INSERT INTO query_models ({}) VALUES "
                                                                           "(?, ?, ?, ?)",
                                                                           kModelColumns)));
  SOLID_ASSIGN_OR_RETURN(impl->insert_view,
                         Stmt::Prepare(db, fmt::format("INSERT INTO query_views ({}) VALUES "
                                                       "(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)",
                                                       kViewColumns)));
  return QueryShardWriter(std::move(impl));
}

const fs::path& QueryShardWriter::path() const { return impl_->shard.final_path(); }

Status QueryShardWriter::SetMeta(std::string_view key, std::string_view value) {
  return impl_->shard.SetMeta(key, value);
}

Status QueryShardWriter::AddModel(const QueryModelRecord& m) {
  SOLID_RETURN_IF_ERROR(impl_->shard.Usable());
  if (m.model_key.empty() || m.model_key.size() > kMaxKeyLength) {
    return InvalidArgumentError(path().string() + ": model_key must have 1.." + std::to_string(kMaxKeyLength) +
                                " bytes");
  }
  return RowBinder(*impl_->insert_model)
      .Text(m.model_key)
      .Int(m.view_count)
      .Text(m.failure)
      .Finish()
      .Run()
      .WithContext(fmt::format("{}: model {}", path().string(), m.model_key));
}

Status QueryShardWriter::AddView(const QueryViewRecord& v) {
  SOLID_RETURN_IF_ERROR(impl_->shard.Usable());
  std::string where = fmt::format("{}: model {} view {}", path().string(), v.model_key, v.view_index);
  if (v.width == 0 || v.height == 0 || v.image.empty()) return InvalidArgumentError(where + ": empty image");
  if (!AllFinite({v.azimuth, v.elevation})) return InvalidArgumentError(where + ": a non-finite angle");
  RowBinder row(*impl_->insert_view);
  row.Int(impl_->next_query_id).Text(v.model_key).Int(v.view_index).Real(v.azimuth).Real(v.elevation);
  row.Int(v.width).Int(v.height).Text(ImageFormatName(v.format)).Checked(v.image, false);
  row.Int(v.box.x).Int(v.box.y).Int(v.box.w).Int(v.box.h);
  SOLID_RETURN_IF_ERROR(row.Finish().Run().WithContext(where));
  ++impl_->next_query_id;
  return Status::Ok();
}

Status QueryShardWriter::Commit() {
  Db& db = impl_->shard.db();
  // view_count is what readers trust for sampling: make it agree with the rows.
  if (impl_->shard.Usable().ok()) {
    SOLID_ASSIGN_OR_RETURN(Stmt check, Stmt::Prepare(db,
                                                     "SELECT m.model_key FROM query_models m WHERE m.view_count != "
                                                     "(SELECT count(*) FROM query_views v WHERE v.model_key = "
                                                     "m.model_key) LIMIT 1"));
    SOLID_ASSIGN_OR_RETURN(bool mismatch, check.Step());
    if (mismatch) {
      return InvalidArgumentError(fmt::format("{}: model {}: view_count differs from the views added",
                                              path().string(), check.Text(0)));
    }
  }
  return impl_->shard.Commit({&MetaTable(), &ModelsTable(), &ViewsTable()}, [this] {
    impl_->insert_model.reset();
    impl_->insert_view.reset();
  });
}

// ---------------------------------------------------------------------------------------------
// ShardReader

struct ShardReader::Impl {
  fs::path path;
  Db db;
};

ShardReader::ShardReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ShardReader::ShardReader(ShardReader&&) noexcept = default;
ShardReader& ShardReader::operator=(ShardReader&&) noexcept = default;
ShardReader::~ShardReader() = default;

Result<ShardReader> ShardReader::Open(const fs::path& path) {
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  SOLID_ASSIGN_OR_RETURN(impl->db, OpenUntrusted(path, kTargetDdl));
  return ShardReader(std::move(impl));
}

const fs::path& ShardReader::path() const { return impl_->path; }

Result<std::vector<std::pair<std::string, std::string>>> ShardReader::Meta() { return ReadMeta(impl_->db); }

Status ShardReader::VerifyContent(ChecksumPolicy policy) {
  return VerifyTables(impl_->db, {&MetaTable(), &ImagesTable(), &InstancesTable()}, policy);
}

Result<ShardCounts> ShardReader::Counts() {
  ShardCounts counts;
  SOLID_ASSIGN_OR_RETURN(counts.images, impl_->db.QueryInt("SELECT count(*) FROM images"));
  SOLID_ASSIGN_OR_RETURN(counts.instances, impl_->db.QueryInt("SELECT count(*) FROM instances"));
  if (counts.images > 0) {
    SOLID_ASSIGN_OR_RETURN(counts.first_image_id, impl_->db.QueryInt("SELECT min(image_id) FROM images"));
    SOLID_ASSIGN_OR_RETURN(counts.last_image_id, impl_->db.QueryInt("SELECT max(image_id) FROM images"));
  }
  return counts;
}

Result<ShardSummary> ShardReader::Summarize() {
  ShardSummary summary;
  Db& db = impl_->db;
  SOLID_ASSIGN_OR_RETURN(summary.counts, Counts());
  SOLID_ASSIGN_OR_RETURN(summary.image_bytes, db.QueryInt("SELECT ifnull(sum(length(image)), 0) FROM images"));
  SOLID_ASSIGN_OR_RETURN(summary.depth_images, db.QueryInt("SELECT count(depth) FROM images"));
  SOLID_ASSIGN_OR_RETURN(summary.depth_bytes, db.QueryInt("SELECT ifnull(sum(length(depth)), 0) FROM images"));
  SOLID_ASSIGN_OR_RETURN(summary.rle_bytes,
                         db.QueryInt("SELECT ifnull(sum(length(visible_rle) + length(full_rle)), 0) FROM instances"));
  SOLID_ASSIGN_OR_RETURN(summary.visible_instances, db.QueryInt("SELECT count(*) FROM instances WHERE visible_area > 0"));
  SOLID_ASSIGN_OR_RETURN(summary.distinct_models, db.QueryInt("SELECT count(DISTINCT model_key) FROM instances"));
  return summary;
}

Status ShardReader::AddToMetrics(MetricsAccumulator& metrics) {
  Db& db = impl_->db;
  SOLID_ASSIGN_OR_RETURN(Stmt per_image, Stmt::Prepare(db, "SELECT count(n.instance_id), ifnull(sum(n.visible_area > 0), 0) "
                                                           "FROM images i LEFT JOIN instances n USING (image_id) "
                                                           "GROUP BY i.image_id ORDER BY i.image_id"));
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, per_image.Step());
    if (!row) break;
    metrics.AddImageCounts(per_image.Int(0), per_image.Int(1));
  }
  SOLID_ASSIGN_OR_RETURN(Stmt visible, Stmt::Prepare(db, "SELECT visible_area, full_area FROM instances "
                                                         "WHERE visible_area > 0 ORDER BY image_id, ordinal"));
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, visible.Step());
    if (!row) break;
    RowReader r(visible, impl_->path.string() + ": instances");
    SOLID_ASSIGN_OR_RETURN(int64_t visible_area, r.Int(0, "visible_area", 0));
    SOLID_ASSIGN_OR_RETURN(int64_t full_area, r.Int(1, "full_area", visible_area));
    metrics.AddVisibleInstance(static_cast<uint64_t>(visible_area), static_cast<uint64_t>(full_area));
  }
  return Status::Ok();
}

Result<std::vector<int64_t>> ShardReader::ImageIds() {
  SOLID_ASSIGN_OR_RETURN(Stmt stmt, Stmt::Prepare(impl_->db, "SELECT image_id FROM images ORDER BY image_id"));
  std::vector<int64_t> ids;
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    SOLID_ASSIGN_OR_RETURN(int64_t id, RowReader(stmt, impl_->path.string() + ": images").Int(0, "image_id", 0));
    ids.push_back(id);
  }
  return ids;
}

Result<ImageRecord> ShardReader::ReadImage(int64_t image_id, ChecksumPolicy policy) {
  SOLID_ASSIGN_OR_RETURN(Stmt stmt,
                         Stmt::Prepare(impl_->db, fmt::format("SELECT {} FROM images WHERE image_id = ?", kImageColumns)));
  stmt.Bind(1, image_id);
  SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row) return NotFoundError(fmt::format("{}: no image {}", impl_->path.string(), image_id));
  RowReader r(stmt, fmt::format("{}: images row {}", impl_->path.string(), image_id));
  ImageRecord im;
  SOLID_ASSIGN_OR_RETURN(im.image_id, r.Int(0, "image_id", 0));
  SOLID_ASSIGN_OR_RETURN(int64_t seed, r.Int(1, "seed"));
  im.seed = FromSqlInt(seed);
  SOLID_ASSIGN_OR_RETURN(int64_t width, r.Int(2, "width", 1, kMaxImageSide));
  SOLID_ASSIGN_OR_RETURN(int64_t height, r.Int(3, "height", 1, kMaxImageSide));
  im.width = static_cast<uint32_t>(width);
  im.height = static_cast<uint32_t>(height);
  SOLID_ASSIGN_OR_RETURN(std::string format, r.Text(4, "image_format", 16));
  Result<ImageFormat> parsed = ParseImageFormat(format);
  if (!parsed.ok()) return r.Fail("image_format", parsed.status().message());
  im.format = *parsed;
  SOLID_ASSIGN_OR_RETURN(auto image, r.Checked(5, 6, "image", policy, false));
  im.image.assign(image.begin(), image.end());
  SOLID_ASSIGN_OR_RETURN(im.camera.fx, r.Real(7, "fx"));
  SOLID_ASSIGN_OR_RETURN(im.camera.fy, r.Real(8, "fy"));
  SOLID_ASSIGN_OR_RETURN(im.camera.cx, r.Real(9, "cx"));
  SOLID_ASSIGN_OR_RETURN(im.camera.cy, r.Real(10, "cy"));
  SOLID_ASSIGN_OR_RETURN(im.camera.world_from_camera, r.Affine(11, 12, "world_from_camera", policy));
  if (stmt.ColumnType(13) != SQLITE_NULL) {
    SOLID_ASSIGN_OR_RETURN(auto depth, r.Checked(13, 14, "depth", policy, false));
    im.depth_exr.emplace(depth.begin(), depth.end());
  }
  SOLID_ASSIGN_OR_RETURN(im.room_key, r.OptionalText(15, "room_key", kMaxKeyLength));
  // Last: a value's own check names the field more precisely.
  SOLID_RETURN_IF_ERROR(r.RowChecksum(ImagesTable()));
  return im;
}

namespace {
Status IndexLedAstray(const fs::path& path, std::string_view table, std::string_view wanted, std::string_view found) {
  return CorruptError(fmt::format("{}: {}: looking up model '{}' found a row of '{}': the index is damaged",
                                  path.string(), table, wanted, found));
}

Result<std::vector<InstanceRecord>> CollectInstances(Stmt& stmt, const std::string& file, ChecksumPolicy policy) {
  std::vector<InstanceRecord> out;
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    SOLID_ASSIGN_OR_RETURN(InstanceRecord in, ParseInstance(stmt, file, policy));
    out.push_back(std::move(in));
  }
  return out;
}
}  // namespace

Result<std::vector<InstanceRecord>> ShardReader::InstancesOfImage(int64_t image_id, ChecksumPolicy policy) {
  SOLID_ASSIGN_OR_RETURN(
      Stmt stmt, Stmt::Prepare(impl_->db, fmt::format("SELECT {} FROM instances WHERE image_id = ? ORDER BY ordinal",
                                                      kInstanceColumns)));
  stmt.Bind(1, image_id);
  return CollectInstances(stmt, impl_->path.string(), policy);
}

Result<std::vector<InstanceRecord>> ShardReader::InstancesOfModel(std::string_view model_key, ChecksumPolicy policy) {
  SOLID_ASSIGN_OR_RETURN(
      Stmt stmt,
      Stmt::Prepare(impl_->db, fmt::format("SELECT {} FROM instances WHERE model_key = ? ORDER BY image_id, ordinal",
                                           kInstanceColumns)));
  stmt.Bind(1, model_key);
  SOLID_ASSIGN_OR_RETURN(std::vector<InstanceRecord> instances, CollectInstances(stmt, impl_->path.string(), policy));
  // The lookup goes through instances_by_model; a damaged index can lead it to rows of
  // another model (shard_fuzz crash-e10be1c3), which must not pass as this one's.
  for (const InstanceRecord& in : instances) {
    if (in.model_key != model_key) return IndexLedAstray(impl_->path, "instances", model_key, in.model_key);
  }
  return instances;
}

Status ShardReader::ForEachInstance(const std::function<Status(const InstanceRecord&)>& fn, ChecksumPolicy policy) {
  SOLID_ASSIGN_OR_RETURN(
      Stmt stmt,
      Stmt::Prepare(impl_->db, fmt::format("SELECT {} FROM instances ORDER BY image_id, ordinal", kInstanceColumns)));
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) return Status::Ok();
    SOLID_ASSIGN_OR_RETURN(InstanceRecord in, ParseInstance(stmt, impl_->path.string(), policy));
    SOLID_RETURN_IF_ERROR(fn(in));
  }
}

// ---------------------------------------------------------------------------------------------
// QueryShardReader

struct QueryShardReader::Impl {
  fs::path path;
  Db db;
};

QueryShardReader::QueryShardReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
QueryShardReader::QueryShardReader(QueryShardReader&&) noexcept = default;
QueryShardReader& QueryShardReader::operator=(QueryShardReader&&) noexcept = default;
QueryShardReader::~QueryShardReader() = default;

Result<QueryShardReader> QueryShardReader::Open(const fs::path& path) {
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  SOLID_ASSIGN_OR_RETURN(impl->db, OpenUntrusted(path, kQueryDdl));
  return QueryShardReader(std::move(impl));
}

const fs::path& QueryShardReader::path() const { return impl_->path; }

Result<std::vector<std::pair<std::string, std::string>>> QueryShardReader::Meta() { return ReadMeta(impl_->db); }

Status QueryShardReader::VerifyContent(ChecksumPolicy policy) {
  return VerifyTables(impl_->db, {&MetaTable(), &ModelsTable(), &ViewsTable()}, policy);
}

Result<std::vector<QueryModelRecord>> QueryShardReader::Models() {
  SOLID_ASSIGN_OR_RETURN(Stmt stmt, Stmt::Prepare(impl_->db, fmt::format("SELECT {} FROM query_models ORDER BY "
                                                                         "model_key",
                                                                         kModelColumns)));
  std::vector<QueryModelRecord> models;
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    RowReader r(stmt, fmt::format("{}: query_models row {}", impl_->path.string(), models.size()));
    QueryModelRecord m;
    SOLID_ASSIGN_OR_RETURN(m.model_key, r.Text(0, "model_key", kMaxKeyLength));
    SOLID_ASSIGN_OR_RETURN(int64_t count, r.Int(1, "view_count", 0, 1 << 16));
    m.view_count = static_cast<int32_t>(count);
    SOLID_ASSIGN_OR_RETURN(m.failure, r.OptionalText(2, "failure", 1 << 16));
    SOLID_RETURN_IF_ERROR(r.RowChecksum(ModelsTable()));
    models.push_back(std::move(m));
  }
  return models;
}

Result<std::vector<QueryViewRecord>> QueryShardReader::ViewsOfModel(std::string_view model_key, ChecksumPolicy policy) {
  SOLID_ASSIGN_OR_RETURN(
      Stmt stmt, Stmt::Prepare(impl_->db, fmt::format("SELECT {} FROM query_views WHERE model_key = ? "
                                                      "ORDER BY view_index",
                                                      kViewColumns)));
  stmt.Bind(1, model_key);
  std::vector<QueryViewRecord> views;
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    SOLID_ASSIGN_OR_RETURN(QueryViewRecord v, ParseView(stmt, impl_->path.string(), policy));
    // As in ShardReader::InstancesOfModel: the (model_key, view_index) index may be damaged.
    if (v.model_key != model_key) return IndexLedAstray(impl_->path, "query_views", model_key, v.model_key);
    views.push_back(std::move(v));
  }
  return views;
}

Status QueryShardReader::ForEachView(const std::function<Status(const QueryViewRecord&)>& fn, ChecksumPolicy policy) {
  SOLID_ASSIGN_OR_RETURN(Stmt stmt, Stmt::Prepare(impl_->db, fmt::format("SELECT {} FROM query_views ORDER BY "
                                                                         "model_key, view_index",
                                                                         kViewColumns)));
  for (;;) {
    SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) return Status::Ok();
    SOLID_ASSIGN_OR_RETURN(QueryViewRecord v, ParseView(stmt, impl_->path.string(), policy));
    SOLID_RETURN_IF_ERROR(fn(v));
  }
}

}  // namespace solid
