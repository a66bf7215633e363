#include "solid/formats/index.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "solid/formats/files.h"
#include "solid/formats/checksum.h"
#include "solid/formats/dataset.h"
#include "solid/formats/shard.h"
#include "sqlite_schema.h"
#include "sqlite_util.h"

namespace solid {
namespace fs = std::filesystem;
using sqlite::Db;
using sqlite::Stmt;

namespace {

struct ModelTotals {
  int64_t instances = 0, images = 0;
  std::optional<int64_t> query_shard;
  int64_t view_count = 0;
};

// Everything one target shard contributes, gathered before any of it is merged so
// that a shard that fails half-way contributes nothing.
struct ShardContribution {
  files::FileDigest digest;
  ShardCounts counts;
  std::map<std::pair<std::string, int64_t>, int64_t> occurrences;  // (model, image) -> instances
  MetricsAccumulator metrics;  // the dataset's so far, with this shard
};

// A shard is indexed only when it belongs here and its checksums hold: the index's
// whole-file checksum must never bless a shard that is damaged or another dataset's.
template <typename Reader>
Status CheckBelongs(Reader& reader, const fs::path& path, const Manifest& manifest, int64_t shard_index) {
  SOLID_RETURN_IF_ERROR(reader.VerifyContent(ChecksumPolicy::kVerify));
  SOLID_ASSIGN_OR_RETURN(auto meta, reader.Meta());
  SOLID_ASSIGN_OR_RETURN(ShardProvenance found, ReadProvenance(meta, path.string()));
  return CheckProvenance(found, manifest, shard_index, path.string());
}

Result<ShardContribution> ReadContribution(const fs::path& path, const Manifest& manifest, int64_t shard_index,
                                           const MetricsAccumulator& metrics) {
  ShardContribution c;
  c.metrics = metrics;
  SOLID_ASSIGN_OR_RETURN(ShardReader reader, ShardReader::Open(path));
  SOLID_RETURN_IF_ERROR(CheckBelongs(reader, path, manifest, shard_index));
  SOLID_ASSIGN_OR_RETURN(c.counts, reader.Counts());
  SOLID_ASSIGN_OR_RETURN(std::vector<int64_t> ids, reader.ImageIds());
  const int64_t first = shard_index * manifest.shard_size;
  const int64_t end = std::min(first + manifest.shard_size, manifest.images);
  for (int64_t id : ids) {
    if (id < first || id >= end) {
      return CorruptError(fmt::format("{}: images row {}: image_id: outside shard {}'s range [{}, {})", path.string(),
                                      id, shard_index, first, end));
    }
  }
  SOLID_RETURN_IF_ERROR(reader.ForEachInstance(
      [&](const InstanceRecord& in) -> Status {
        if (!std::binary_search(ids.begin(), ids.end(), in.image_id)) {
          return CorruptError(fmt::format("{}: instance of image {} which the shard does not hold", path.string(),
                                          in.image_id));
        }
        ++c.occurrences[{in.model_key, in.image_id}];
        return Status::Ok();
      },
      ChecksumPolicy::kSkip));
  SOLID_RETURN_IF_ERROR(reader.AddToMetrics(c.metrics));
  SOLID_ASSIGN_OR_RETURN(c.digest, files::DigestFile(path));
  return c;
}

Status InsertMeta(Db& db, std::string_view key, std::string_view value) {
  SOLID_ASSIGN_OR_RETURN(Stmt stmt, Stmt::Prepare(db, "INSERT INTO index_meta VALUES (?, ?)"));
  stmt.Bind(1, key).Bind(2, value);
  return stmt.Run();
}

// Writes the whole index of the dataset at root into db, whose schema exists.
Result<IndexReport> FillIndex(Db& db, const fs::path& root, const ProgressCallback& progress) {
  SOLID_ASSIGN_OR_RETURN(Manifest manifest, ReadManifest(root));
  SOLID_ASSIGN_OR_RETURN(ShardListing listing, ListShards(root));
  IndexReport report;
  // The gaps between the listed shards (sorted by index), without a loop over the
  // manifest's shard count, which an untrusted manifest could make huge.
  int64_t expected = 0;
  for (const ShardFile& file : listing.targets) {
    if (file.index >= manifest.ShardCount()) break;
    if (file.index > expected) report.missing_shards.emplace_back(expected, file.index - 1);
    expected = file.index + 1;
  }
  if (expected < manifest.ShardCount()) report.missing_shards.emplace_back(expected, manifest.ShardCount() - 1);
  for (const fs::path& p : listing.unexpected) {
    const std::string name = p.filename().string();
    if (ParseTargetShardFileName(name).ok() || ParseQueryShardFileName(name).ok()) {
      report.skipped.push_back(CorruptError(p.string() + ": named as a shard, but not a regular file inside the "
                                                         "dataset (RenderOptions::repair replaces it)"));
    }
  }
  SOLID_RETURN_IF_ERROR(db.Exec("BEGIN"));
  SOLID_RETURN_IF_ERROR(InsertMeta(db, "format_version", std::to_string(manifest.format_version)));
  SOLID_RETURN_IF_ERROR(InsertMeta(db, "params_hash", Hex64(manifest.ParamsHash())));
  SOLID_RETURN_IF_ERROR(InsertMeta(db, "seed", "0x" + Hex64(manifest.seed)));
  SOLID_RETURN_IF_ERROR(InsertMeta(db, "planned_images", std::to_string(manifest.images)));
  SOLID_RETURN_IF_ERROR(InsertMeta(db, "shard_size", std::to_string(manifest.shard_size)));

  SOLID_ASSIGN_OR_RETURN(Stmt insert_shard, Stmt::Prepare(db, "INSERT INTO shards VALUES (?, ?, ?, ?, ?, ?, ?, ?)"));
  SOLID_ASSIGN_OR_RETURN(Stmt insert_occurrence, Stmt::Prepare(db, "INSERT INTO occurrences VALUES (?, ?, ?, ?)"));
  std::map<std::string, ModelTotals> models;
  MetricsAccumulator metrics(manifest.ScaleClassAreaScale());
  int64_t total = static_cast<int64_t>(listing.targets.size() + listing.queries.size()), done = 0;
  for (const ShardFile& file : listing.targets) {
    if (progress) progress(done++, total);
    Result<ShardContribution> c = ReadContribution(file.path, manifest, file.index, metrics);
    if (!c.ok()) {
      report.skipped.push_back(c.status());
      continue;
    }
    std::string relative = fs::relative(file.path, root).generic_string();
    insert_shard.Bind(1, file.index).Bind(2, std::string_view(relative)).Bind(3, static_cast<int64_t>(c->digest.bytes));
    insert_shard.Bind(4, ToSqlInt(c->digest.xxh64)).Bind(5, c->counts.images).Bind(6, c->counts.instances);
    if (c->counts.images > 0) {
      insert_shard.Bind(7, c->counts.first_image_id).Bind(8, c->counts.last_image_id);
    } else {
      insert_shard.BindNull(7).BindNull(8);
    }
    SOLID_RETURN_IF_ERROR(insert_shard.Run());
    for (const auto& [key, count] : c->occurrences) {
      insert_occurrence.Bind(1, std::string_view(key.first)).Bind(2, key.second).Bind(3, file.index).Bind(4, count);
      SOLID_RETURN_IF_ERROR(insert_occurrence.Run());
      ModelTotals& m = models[key.first];
      m.instances += count;
      ++m.images;
    }
    metrics = c->metrics;
    ++report.shards;
    report.images += c->counts.images;
    report.instances += c->counts.instances;
  }

  SOLID_ASSIGN_OR_RETURN(Stmt insert_query_shard, Stmt::Prepare(db, "INSERT INTO query_shards VALUES (?, ?, ?, ?, ?, ?)"));
  for (const ShardFile& file : listing.queries) {
    if (progress) progress(done++, total);
    auto read = [&]() -> Result<std::pair<std::vector<QueryModelRecord>, files::FileDigest>> {
      SOLID_ASSIGN_OR_RETURN(QueryShardReader reader, QueryShardReader::Open(file.path));
      SOLID_RETURN_IF_ERROR(CheckBelongs(reader, file.path, manifest, file.index));
      SOLID_ASSIGN_OR_RETURN(std::vector<QueryModelRecord> shard_models, reader.Models());
      SOLID_ASSIGN_OR_RETURN(files::FileDigest digest, files::DigestFile(file.path));
      return std::make_pair(std::move(shard_models), digest);
    };
    auto result = read();
    if (!result.ok()) {
      report.skipped.push_back(result.status());
      continue;
    }
    int64_t views = 0;
    for (const QueryModelRecord& m : result->first) {
      ModelTotals& totals = models[m.model_key];
      if (totals.query_shard) {
        report.skipped.push_back(CorruptError(fmt::format("{}: model {} already has views in query shard {}",
                                                          file.path.string(), m.model_key, *totals.query_shard)));
        continue;
      }
      totals.query_shard = file.index;
      totals.view_count = m.view_count;
      views += m.view_count;
    }
    std::string relative = fs::relative(file.path, root).generic_string();
    insert_query_shard.Bind(1, file.index).Bind(2, std::string_view(relative));
    insert_query_shard.Bind(3, static_cast<int64_t>(result->second.bytes)).Bind(4, ToSqlInt(result->second.xxh64));
    insert_query_shard.Bind(5, static_cast<int64_t>(result->first.size())).Bind(6, views);
    SOLID_RETURN_IF_ERROR(insert_query_shard.Run());
    ++report.query_shards;
    report.query_views += views;
  }

  SOLID_ASSIGN_OR_RETURN(Stmt insert_model, Stmt::Prepare(db, "INSERT INTO models VALUES (?, ?, ?, ?, ?)"));
  for (const auto& [key, m] : models) {
    insert_model.Bind(1, std::string_view(key)).Bind(2, m.instances).Bind(3, m.images);
    insert_model.Bind(4, m.query_shard).Bind(5, m.view_count);
    SOLID_RETURN_IF_ERROR(insert_model.Run());
  }
  report.models = static_cast<int64_t>(models.size());

  report.metrics = metrics.Finish();
  const ProxyMetrics& pm = report.metrics;
  SOLID_ASSIGN_OR_RETURN(Stmt insert_metric, Stmt::Prepare(db, "INSERT INTO metrics VALUES (?, ?)"));
  for (const auto& [name, value] : std::initializer_list<std::pair<std::string_view, double>>{
           {"images", static_cast<double>(pm.images)},
           {"instances", static_cast<double>(pm.instances)},
           {"visible_instances", static_cast<double>(pm.visible_instances)},
           {"objects_per_image", pm.objects_per_image.mean},
           {"objects_per_image_ci95", pm.objects_per_image.ci95},
           {"occlusion", pm.occlusion.mean},
           {"occlusion_ci95", pm.occlusion.ci95},
           {"share_small", pm.small.mean},
           {"share_medium", pm.medium.mean},
           {"share_large", pm.large.mean}}) {
    insert_metric.Bind(1, name).Bind(2, value);
    SOLID_RETURN_IF_ERROR(insert_metric.Run());
  }
  SOLID_RETURN_IF_ERROR(db.Exec("COMMIT"));
  if (progress) progress(total, total);
  return report;
}

std::string ValueText(const Stmt& s, int col) {
  switch (s.ColumnType(col)) {
    case SQLITE_NULL: return "NULL";
    case SQLITE_INTEGER: return std::to_string(s.Int(col));
    case SQLITE_FLOAT: return fmt::format("{}", s.Real(col));
    default: return std::string(s.Text(col).substr(0, 80));
  }
}

bool SameValue(const Stmt& a, const Stmt& b, int col) {
  if (a.ColumnType(col) != b.ColumnType(col)) return false;
  switch (a.ColumnType(col)) {
    case SQLITE_NULL: return true;
    case SQLITE_INTEGER: return a.Int(col) == b.Int(col);
    case SQLITE_FLOAT: {
      double x = a.Real(col), y = b.Real(col);
      return std::fabs(x - y) <= 1e-9 * std::max({1.0, std::fabs(x), std::fabs(y)});
    }
    default: return a.Text(col) == b.Text(col);
  }
}

}  // namespace

Result<IndexReport> BuildIndex(const fs::path& root, const ProgressCallback& progress) {
  DatasetPaths paths(root);
  std::error_code exists_ec;
  if (!fs::is_directory(root, exists_ec)) return NotFoundError(root.string() + ": no dataset directory");
  if (!fs::exists(paths.manifest(), exists_ec)) {
    return NotFoundError(fmt::format("{}: no manifest.json: adopting the shards (AdoptManifest) rebuilds it from "
                                     "their provenance, when they agree on what they were made from",
                                     root.string()));
  }
  fs::path temp = files::TempPathFor(paths.index());
  files::RemoveStaleTemps(paths.index());
  std::error_code ec;
  fs::remove(temp, ec);
  Result<IndexReport> report = [&]() -> Result<IndexReport> {
    SOLID_ASSIGN_OR_RETURN(Db db, Db::Open(temp, sqlite::OpenMode::kCreate, paths.index().string()));
    SOLID_RETURN_IF_ERROR(db.Exec("PRAGMA journal_mode = OFF; PRAGMA synchronous = OFF;"));
    SOLID_RETURN_IF_ERROR(sqlite::CreateSchema(db, "index.sql"));
    SOLID_ASSIGN_OR_RETURN(IndexReport r, FillIndex(db, root, progress));
    db.Close();
    SOLID_RETURN_IF_ERROR(files::SyncAndPublish(temp, paths.index(), /*replace=*/true));
    return r;
  }();
  if (!report.ok()) fs::remove(temp, ec);
  return report;
}

nlohmann::json IndexReport::ToJson() const {
  nlohmann::json skipped_json = nlohmann::json::array(), missing = nlohmann::json::array();
  for (const Status& s : skipped) skipped_json.push_back(s.message());
  for (const auto& [first, last] : missing_shards) missing.push_back({first, last});
  nlohmann::json j = {{"shards", shards},          {"query_shards", query_shards}, {"images", images},
                      {"instances", instances},    {"models", models},             {"query_views", query_views},
                      {"metrics", metrics.ToJson()}, {"skipped", skipped_json},   {"missing_shards", missing}};
  if (!adopted.empty()) j["adopted"] = adopted;
  return j;
}

Result<IndexReport> Index(const IndexOptions& options) {
  if (options.dataset.empty()) return OptionError("dataset", "no dataset directory given");
  std::string adopted;
  std::error_code ec;
  if (options.adopt && !fs::exists(DatasetPaths(options.dataset).manifest(), ec)) {
    SOLID_ASSIGN_OR_RETURN(AdoptReport adoption, AdoptManifest(options.dataset));
    adopted = adoption.Summary(options.dataset);
  }
  SOLID_ASSIGN_OR_RETURN(IndexReport report, BuildIndex(options.dataset, options.progress));
  report.adopted = std::move(adopted);
  return report;
}

Result<std::vector<std::string>> CompareIndex(const fs::path& root) {
  DatasetPaths paths(root);
  std::error_code ec;
  if (!fs::exists(paths.index(), ec)) {
    return NotFoundError(paths.index().string() + ": no index (BuildIndex builds it)");
  }
  SOLID_ASSIGN_OR_RETURN(Db expected, Db::OpenInMemory());
  SOLID_RETURN_IF_ERROR(sqlite::CreateSchema(expected, "index.sql"));
  SOLID_ASSIGN_OR_RETURN(IndexReport report, FillIndex(expected, root, {}));
  SOLID_ASSIGN_OR_RETURN(Db actual, Db::Open(paths.index(), sqlite::OpenMode::kUntrustedRead));
  SOLID_RETURN_IF_ERROR(sqlite::CheckSchema(actual, "index.sql"));

  std::vector<std::string> diffs;
  constexpr size_t kMaxDiffs = 50;
  for (std::string_view table : {"index_meta", "shards", "query_shards", "occurrences", "models", "metrics"}) {
    std::string sql = fmt::format("SELECT * FROM {} ORDER BY 1, 2", table);
    SOLID_ASSIGN_OR_RETURN(Stmt want, Stmt::Prepare(expected, sql));
    SOLID_ASSIGN_OR_RETURN(Stmt have, Stmt::Prepare(actual, sql));
    for (int64_t row = 0; diffs.size() < kMaxDiffs; ++row) {
      SOLID_ASSIGN_OR_RETURN(bool want_row, want.Step());
      SOLID_ASSIGN_OR_RETURN(bool have_row, have.Step());
      if (!want_row && !have_row) break;
      // Key/value tables name the row by its key.
      const bool keyed = want_row && (want.ColumnName(0) == "key" || want.ColumnName(0) == "name");
      std::string where = keyed ? fmt::format("{}: {} '{}'", paths.index().string(), table, want.Text(0))
                                : fmt::format("{}: {} row {}", paths.index().string(), table, row);
      // Name the shard file itself, which is what a user has to look at.
      for (int c = 0; want_row && c < want.ColumnCount(); ++c) {
        if (want.ColumnName(c) == "file") where = fmt::format("{} ({})", where, want.Text(c));
      }
      // index_meta is what the manifest says; every other table is what the shards hold.
      const std::string_view source = table == "index_meta" ? "from the manifest" : "from the shards";
      if (want_row != have_row) {
        diffs.push_back(fmt::format("{}: the index has {} rows than {} give", where, have_row ? "more" : "fewer",
                                    table == "index_meta" ? "the manifest and shards" : "the shards"));
        break;
      }
      for (int c = 0; c < want.ColumnCount(); ++c) {
        if (!SameValue(want, have, c)) {
          diffs.push_back(fmt::format("{}: {}: {} in the index, {} {}", where, want.ColumnName(c),
                                      ValueText(have, c), ValueText(want, c), source));
        }
      }
    }
  }
  for (const Status& s : report.skipped) diffs.push_back("not indexable: " + s.message());
  return diffs;
}

}  // namespace solid
