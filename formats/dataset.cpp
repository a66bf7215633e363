#include "solid/formats/dataset.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <map>
#include <mutex>

#include "solid/formats/file_lock.h"
#include "solid/formats/files.h"
#include "solid/formats/checksum.h"
#include "solid/formats/json_schema.h"
#include "solid/formats/schemas.h"
#include "sqlite_schema.h"
#include "sqlite_util.h"

namespace solid {
namespace fs = std::filesystem;

namespace {
constexpr uint64_t kMaxManifestBytes = 16 << 20;

Result<const json::Schema*> ManifestSchema() {
  static std::once_flag once;
  static std::optional<Result<json::Schema>> compiled;
  std::call_once(once, [] {
    Result<std::string_view> text = schemas::Get("manifest.schema.json");
    if (!text.ok()) {
      compiled.emplace(text.status());
      return;
    }
    Result<nlohmann::json> doc = json::ParseJson(*text, "schemas/manifest.schema.json");
    if (!doc.ok()) {
      compiled.emplace(doc.status());
      return;
    }
    compiled.emplace(json::Schema::Compile(*doc, "schemas/manifest.schema.json"));
  });
  if (!compiled->ok()) return compiled->status();
  return &compiled->value();
}
}  // namespace

uint64_t Manifest::ParamsHash() const { return Xxh64(params.dump()); }

std::pair<uint32_t, uint32_t> Manifest::ScaleClassResolution() const {
  if (scale_width > 0 && scale_height > 0) return {scale_width, scale_height};
  return {width, height};
}

double Manifest::ScaleClassAreaScale() const {
  const auto [w, h] = ScaleClassResolution();
  return static_cast<double>(w) * h / (static_cast<double>(width) * height);
}

nlohmann::json Manifest::ToJson() const {
  nlohmann::json generator = {{"name", generator_name},
                              {"version", generator_version.empty() ? std::string(SOLID_VERSION) : generator_version}};
  if (!git_sha.empty()) generator["git_sha"] = git_sha;
  return {{"format", "solid-dataset"},
          {"format_version", format_version},
          {"generator", generator},
          {"seed", "0x" + Hex64(seed)},
          {"images", images},
          {"shard_size", shard_size},
          {"width", width},
          {"height", height},
          {"scale_classes_at", {ScaleClassResolution().first, ScaleClassResolution().second}},
          {"image_format", ImageFormatName(image_format)},
          {"params", params},
          {"params_hash", Hex64(ParamsHash())},
          {"catalog_hash", Hex64(catalog_hash)}};
}

Result<Manifest> Manifest::Parse(std::string_view text, std::string_view name) {
  json::ParseLimits limits;
  limits.max_bytes = kMaxManifestBytes;
  limits.max_string_length = json::kMaxConfigStringBytes;
  SOLID_ASSIGN_OR_RETURN(nlohmann::json doc, json::ParseJson(text, name, limits));
  // Before the schema, which would only say that the number is out of range.
  if (doc.is_object() && doc.contains("format_version") && doc["format_version"].is_number_integer() &&
      doc["format_version"].get<int64_t>() != kDatasetFormatVersion) {
    return UnsupportedVersionError(fmt::format("{}: /format_version: {}, this build reads format version {}", name,
                                               doc["format_version"].get<int64_t>(), kDatasetFormatVersion));
  }
  SOLID_ASSIGN_OR_RETURN(const json::Schema* schema, ManifestSchema());
  SOLID_RETURN_IF_ERROR(schema->Check(doc, name, text));
  // The schema guarantees presence and types from here on.
  Manifest m;
  m.format_version = doc["format_version"].get<int>();
  m.generator_name = doc["generator"]["name"].get<std::string>();
  m.generator_version = doc["generator"]["version"].get<std::string>();
  m.git_sha = doc["generator"].value("git_sha", "");
  if (!ParseHex64(doc["seed"].get<std::string>(), &m.seed)) {
    return ParseError(fmt::format("{}: /seed: not a 64-bit hex number", name));
  }
  m.images = doc["images"].get<int64_t>();
  m.shard_size = doc["shard_size"].get<int64_t>();
  m.width = doc["width"].get<uint32_t>();
  m.height = doc["height"].get<uint32_t>();
  if (doc.contains("scale_classes_at")) {
    m.scale_width = doc["scale_classes_at"][0].get<uint32_t>();
    m.scale_height = doc["scale_classes_at"][1].get<uint32_t>();
  }
  SOLID_ASSIGN_OR_RETURN(m.image_format, ParseImageFormat(doc["image_format"].get<std::string>()));
  m.params = doc["params"];
  if (!ParseHex64(doc["catalog_hash"].get<std::string>(), &m.catalog_hash)) {
    return ParseError(fmt::format("{}: /catalog_hash: not a 64-bit hex number", name));
  }
  std::string stored_params_hash = doc["params_hash"].get<std::string>();
  if (stored_params_hash != Hex64(m.ParamsHash())) {
    return CorruptError(fmt::format("{}: /params_hash: {} does not match the params ({})", name, stored_params_hash,
                                    Hex64(m.ParamsHash())));
  }
  return m;
}

std::string ManifestDifference(const Manifest& a, const Manifest& b) { return ManifestDifference(a, b, "", ""); }

std::string ManifestDifference(const Manifest& a, const Manifest& b, std::string_view a_label,
                               std::string_view b_label) {
  std::vector<std::string> diffs;
  auto cmp = [&](std::string_view what, const auto& x, const auto& y) {
    if (x == y) return;
    if (a_label.empty()) {
      diffs.push_back(fmt::format("{} {} vs {}", what, x, y));
    } else {
      diffs.push_back(fmt::format("{} {} {}, {} {}", what, x, a_label, y, b_label));
    }
  };
  cmp("format_version", a.format_version, b.format_version);
  cmp("generator", a.generator_name + " " + a.generator_version, b.generator_name + " " + b.generator_version);
  cmp("seed", "0x" + Hex64(a.seed), "0x" + Hex64(b.seed));
  cmp("images", a.images, b.images);
  cmp("shard_size", a.shard_size, b.shard_size);
  cmp("width", a.width, b.width);
  cmp("height", a.height, b.height);
  cmp("scale_classes_at", fmt::format("{}x{}", a.ScaleClassResolution().first, a.ScaleClassResolution().second),
      fmt::format("{}x{}", b.ScaleClassResolution().first, b.ScaleClassResolution().second));
  cmp("image_format", ImageFormatName(a.image_format), ImageFormatName(b.image_format));
  cmp("params_hash", Hex64(a.ParamsHash()), Hex64(b.ParamsHash()));
  if (a.params != b.params && !diffs.empty() && diffs.back().starts_with("params_hash")) {
    const nlohmann::json patch = nlohmann::json::diff(a.params, b.params);
    if (!patch.empty()) diffs.back() += fmt::format(" (params differ first at {})", patch[0].value("path", "/"));
  }
  cmp("catalog_hash", Hex64(a.catalog_hash), Hex64(b.catalog_hash));
  std::string out;
  for (const auto& d : diffs) out += (out.empty() ? "" : "; ") + d;
  return out;
}

Status CreateDataset(const fs::path& root, const Manifest& manifest) {
  DatasetPaths paths(root);
  std::error_code ec;
  for (const fs::path& dir : {paths.root, paths.shards_dir(), paths.queries_dir()}) {
    fs::create_directories(dir, ec);
    if (ec) return IoError(fmt::format("{}: cannot create directory: {}", dir.string(), ec.message()));
  }
  std::string text = manifest.ToJson().dump(2) + "\n";
  return files::WriteFileAtomically(paths.manifest(), {reinterpret_cast<const uint8_t*>(text.data()), text.size()});
}

Result<Manifest> ReadManifest(const fs::path& root) {
  fs::path path = DatasetPaths(root).manifest();
  SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, files::ReadFile(path, kMaxManifestBytes));
  return Manifest::Parse({reinterpret_cast<const char*>(bytes.data()), bytes.size()}, path.string());
}

namespace {
constexpr std::string_view kManifestKey = "manifest";
constexpr std::string_view kShardIndexKey = "shard_index";

template <typename Writer>
Status WriteProvenanceTo(Writer& writer, const Manifest& manifest, int64_t shard_index) {
  SOLID_RETURN_IF_ERROR(writer.SetMeta(kShardIndexKey, std::to_string(shard_index)));
  return writer.SetMeta(kManifestKey, manifest.ToJson().dump());
}
}  // namespace

Status WriteProvenance(ShardWriter& writer, const Manifest& manifest, int64_t shard_index) {
  return WriteProvenanceTo(writer, manifest, shard_index);
}
Status WriteProvenance(QueryShardWriter& writer, const Manifest& manifest, int64_t shard_index) {
  return WriteProvenanceTo(writer, manifest, shard_index);
}

Result<ShardProvenance> ReadProvenance(const std::vector<std::pair<std::string, std::string>>& meta,
                                       std::string_view file) {
  const std::string* manifest = nullptr;
  const std::string* index = nullptr;
  for (const auto& [key, value] : meta) {
    if (key == kManifestKey) manifest = &value;
    if (key == kShardIndexKey) index = &value;
  }
  if (!manifest || !index) {
    return CorruptError(fmt::format("{}: provenance: shard_meta has no '{}': it does not say what it was made from",
                                    file, manifest ? kShardIndexKey : kManifestKey));
  }
  ShardProvenance p;
  auto [end, ec] = std::from_chars(index->data(), index->data() + index->size(), p.shard_index);
  if (ec != std::errc() || end != index->data() + index->size() || p.shard_index < 0) {
    return CorruptError(fmt::format("{}: provenance: shard_index '{}' is not a shard number", file,
                                    index->substr(0, 40)));
  }
  Result<Manifest> parsed = Manifest::Parse(*manifest, fmt::format("{}: provenance", file));
  if (!parsed.ok()) return CorruptError(parsed.status().message());
  p.manifest = std::move(parsed).value();
  return p;
}

Status CheckProvenance(const ShardProvenance& found, const Manifest& manifest, int64_t shard_index,
                       std::string_view file) {
  if (found.shard_index != shard_index) {
    return CorruptError(fmt::format("{}: provenance: shard_index {} in the shard, {} by its file name", file,
                                    found.shard_index, shard_index));
  }
  const std::string why = ManifestDifference(found.manifest, manifest, "in the shard", "in the manifest");
  if (!why.empty()) return CorruptError(fmt::format("{}: provenance: {}", file, why));
  return Status::Ok();
}

Result<ShardListing> ListShards(const fs::path& root) {
  DatasetPaths paths(root);
  ShardListing listing;
  auto scan = [&](const fs::path& dir, auto parse, std::vector<ShardFile>* out) -> Status {
    std::error_code ec;
    if (!fs::exists(dir, ec)) return Status::Ok();
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      const fs::path& p = it->path();
      // Temporaries and locks of writers (running, or killed) are never shards.
      if (files::IsTempPath(p) || files::IsLockPath(p)) continue;
      Result<int64_t> index = parse(p.filename().string());
      // A shard may be a symbolic link, but not one that leads out of the dataset.
      const bool escapes =
          it->is_symlink(ec) && !files::ResolveInside(root, p.lexically_relative(root).string()).ok();
      if (index.ok() && it->is_regular_file(ec) && !escapes) {
        out->push_back({*index, p});
      } else {
        listing.unexpected.push_back(p);
      }
    }
    if (ec) return IoError(fmt::format("{}: cannot list: {}", dir.string(), ec.message()));
    std::sort(out->begin(), out->end(), [](const ShardFile& a, const ShardFile& b) { return a.index < b.index; });
    return Status::Ok();
  };
  SOLID_RETURN_IF_ERROR(scan(paths.shards_dir(), ParseTargetShardFileName, &listing.targets));
  SOLID_RETURN_IF_ERROR(scan(paths.queries_dir(), ParseQueryShardFileName, &listing.queries));
  std::sort(listing.unexpected.begin(), listing.unexpected.end());
  return listing;
}

std::string AdoptReport::Summary(const fs::path& root) const {
  const Manifest& m = manifest;
  std::string line = fmt::format(
      "{}: no manifest.json; adopted the provenance of {} shard(s) and {} query shard(s), which agree: seed 0x{}, "
      "{} images in shards of {}, {}x{} {}, params_hash {}, catalog_hash {}, {} {}; manifest.json rebuilt",
      root.string(), target_shards, query_shards, Hex64(m.seed), m.images, m.shard_size, m.width, m.height,
      ImageFormatName(m.image_format), Hex64(m.ParamsHash()), Hex64(m.catalog_hash), m.generator_name,
      m.generator_version);
  for (const Status& s : unreadable) line += "\n  not adopted (RenderOptions::repair re-renders it): " + s.message();
  return line;
}

Result<AdoptReport> AdoptManifest(const fs::path& root) {
  DatasetPaths paths(root);
  std::error_code ec;
  if (fs::exists(paths.manifest(), ec)) {
    return AlreadyExistsError(paths.manifest().string() + ": exists; there is nothing to adopt");
  }
  SOLID_ASSIGN_OR_RETURN(ShardListing listing, ListShards(root));
  AdoptReport report;
  std::optional<std::string> first;  // the file whose manifest the others must equal
  auto adopt = [&](const ShardFile& file, Result<std::vector<std::pair<std::string, std::string>>> meta) -> Status {
    Result<ShardProvenance> found =
        meta.ok() ? ReadProvenance(*meta, file.path.string()) : Result<ShardProvenance>(meta.status());
    if (found.ok() && found->shard_index != file.index) {
      found = CorruptError(fmt::format("{}: provenance: shard_index {} in the shard, {} by its file name",
                                       file.path.string(), found->shard_index, file.index));
    }
    if (!found.ok()) {
      report.unreadable.push_back(found.status());
      return Status::Ok();
    }
    if (!first) {
      first = file.path.string();
      report.manifest = found->manifest;
      return Status::Ok();
    }
    const std::string why = ManifestDifference(found->manifest, report.manifest, "in " + file.path.string(),
                                               "in " + *first);
    if (!why.empty()) {
      return CorruptError(fmt::format("{}: the shards disagree on what they were made from ({}); adopt only "
                                      "shards of one dataset: move the others away",
                                      root.string(), why));
    }
    return Status::Ok();
  };
  for (const ShardFile& file : listing.targets) {
    Result<ShardReader> reader = ShardReader::Open(file.path);
    SOLID_RETURN_IF_ERROR(adopt(file, reader.ok() ? reader->Meta() : Result<std::vector<std::pair<std::string, std::string>>>(reader.status())));
  }
  const size_t targets_unreadable = report.unreadable.size();
  for (const ShardFile& file : listing.queries) {
    Result<QueryShardReader> reader = QueryShardReader::Open(file.path);
    SOLID_RETURN_IF_ERROR(adopt(file, reader.ok() ? reader->Meta() : Result<std::vector<std::pair<std::string, std::string>>>(reader.status())));
  }
  if (!first) {
    return NotFoundError(fmt::format("{}: no manifest.json and no shard that says what it was made from: nothing "
                                     "to adopt",
                                     root.string()));
  }
  report.target_shards = static_cast<int64_t>(listing.targets.size() - targets_unreadable);
  report.query_shards =
      static_cast<int64_t>(listing.queries.size() - (report.unreadable.size() - targets_unreadable));
  SOLID_RETURN_IF_ERROR(CreateDataset(root, report.manifest));
  return report;
}

// ---------------------------------------------------------------------------------------------

struct Dataset::Impl {
  explicit Impl(fs::path root) : paths(std::move(root)) {}
  DatasetPaths paths;
  Manifest manifest;
  ShardListing listing;
  std::map<int64_t, ShardReader> open_shards;
  std::optional<sqlite::Db> index;  // present only when it agrees with the shards on disk
};

Dataset::Dataset(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Dataset::Dataset(Dataset&&) noexcept = default;
Dataset& Dataset::operator=(Dataset&&) noexcept = default;
Dataset::~Dataset() = default;

namespace {
// The index is a cache: trust it only if it lists exactly the shard files present, with their sizes.
bool IndexListsExactly(sqlite::Db& db, std::string_view table, const std::vector<ShardFile>& files) {
  Result<sqlite::Stmt> stmt =
      sqlite::Stmt::Prepare(db, fmt::format("SELECT shard_index, bytes FROM {} ORDER BY shard_index", table));
  if (!stmt.ok()) return false;
  std::error_code ec;
  size_t i = 0;
  for (;; ++i) {
    Result<bool> row = stmt->Step();
    if (!row.ok()) return false;
    if (!*row) break;
    if (i >= files.size() || stmt->Int(0) != files[i].index) return false;
    uintmax_t size = fs::file_size(files[i].path, ec);
    if (ec || static_cast<int64_t>(size) != stmt->Int(1)) return false;
  }
  return i == files.size();
}

std::optional<sqlite::Db> OpenIndexIfCurrent(const DatasetPaths& paths, const ShardListing& listing) {
  std::error_code ec;
  if (!fs::exists(paths.index(), ec)) return std::nullopt;
  Result<sqlite::Db> db = sqlite::Db::Open(paths.index(), sqlite::OpenMode::kUntrustedRead);
  if (!db.ok() || !sqlite::CheckSchema(*db, "index.sql").ok()) return std::nullopt;
  if (!IndexListsExactly(*db, "shards", listing.targets) || !IndexListsExactly(*db, "query_shards", listing.queries)) {
    return std::nullopt;
  }
  return std::move(db).value();
}
}  // namespace

Result<Dataset> Dataset::Open(const fs::path& root) {
  auto impl = std::make_unique<Impl>(root);
  SOLID_ASSIGN_OR_RETURN(impl->manifest, ReadManifest(root));
  SOLID_ASSIGN_OR_RETURN(impl->listing, ListShards(root));
  impl->index = OpenIndexIfCurrent(impl->paths, impl->listing);
  return Dataset(std::move(impl));
}

const DatasetPaths& Dataset::paths() const { return impl_->paths; }
const Manifest& Dataset::manifest() const { return impl_->manifest; }
const ShardListing& Dataset::shards() const { return impl_->listing; }

Result<ShardReader*> Dataset::Shard(int64_t shard_index) {
  if (auto it = impl_->open_shards.find(shard_index); it != impl_->open_shards.end()) return &it->second;
  const auto& targets = impl_->listing.targets;
  auto it = std::find_if(targets.begin(), targets.end(), [&](const ShardFile& f) { return f.index == shard_index; });
  if (it == targets.end()) {
    return NotFoundError(fmt::format("{}: shard {} is not present", impl_->paths.root.string(), shard_index));
  }
  SOLID_ASSIGN_OR_RETURN(ShardReader reader, ShardReader::Open(it->path));
  return &impl_->open_shards.emplace(shard_index, std::move(reader)).first->second;
}

Result<ImageRecord> Dataset::ReadImage(int64_t image_id) {
  SOLID_ASSIGN_OR_RETURN(ShardReader * shard, Shard(ShardOfImage(image_id)));
  return shard->ReadImage(image_id);
}

Result<std::vector<InstanceRecord>> Dataset::Instances(int64_t image_id) {
  SOLID_ASSIGN_OR_RETURN(ShardReader * shard, Shard(ShardOfImage(image_id)));
  return shard->InstancesOfImage(image_id);
}

Status Dataset::ForEachImage(
    const std::function<Status(const ImageRecord&, const std::vector<InstanceRecord>&)>& fn) {
  for (const ShardFile& file : impl_->listing.targets) {
    SOLID_ASSIGN_OR_RETURN(ShardReader * shard, Shard(file.index));
    SOLID_ASSIGN_OR_RETURN(std::vector<int64_t> ids, shard->ImageIds());
    for (int64_t id : ids) {
      SOLID_ASSIGN_OR_RETURN(ImageRecord image, shard->ReadImage(id));
      SOLID_ASSIGN_OR_RETURN(std::vector<InstanceRecord> instances, shard->InstancesOfImage(id));
      SOLID_RETURN_IF_ERROR(fn(image, instances));
    }
  }
  return Status::Ok();
}

Result<std::vector<Dataset::Occurrence>> Dataset::OccurrencesOfModel(std::string_view model_key) {
  std::vector<Occurrence> out;
  if (impl_->index) {
    SOLID_ASSIGN_OR_RETURN(sqlite::Stmt stmt,
                           sqlite::Stmt::Prepare(*impl_->index, "SELECT shard_index, image_id, instances FROM "
                                                                "occurrences WHERE model_key = ? ORDER BY image_id"));
    stmt.Bind(1, model_key);
    for (;;) {
      SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
      if (!row) return out;
      out.push_back({stmt.Int(0), stmt.Int(1), stmt.Int(2)});
    }
  }
  for (const ShardFile& file : impl_->listing.targets) {
    SOLID_ASSIGN_OR_RETURN(ShardReader * shard, Shard(file.index));
    SOLID_ASSIGN_OR_RETURN(std::vector<InstanceRecord> instances,
                           shard->InstancesOfModel(model_key, ChecksumPolicy::kSkip));
    for (const InstanceRecord& in : instances) {
      if (!out.empty() && out.back().image_id == in.image_id) {
        ++out.back().instances;
      } else {
        out.push_back({file.index, in.image_id, 1});
      }
    }
  }
  return out;
}

Result<std::vector<InstanceRecord>> Dataset::InstancesOfModel(std::string_view model_key) {
  SOLID_ASSIGN_OR_RETURN(std::vector<Occurrence> occurrences, OccurrencesOfModel(model_key));
  std::vector<InstanceRecord> out;
  int64_t last_shard = -1;
  for (const Occurrence& o : occurrences) {
    if (o.shard_index == last_shard) continue;
    last_shard = o.shard_index;
    SOLID_ASSIGN_OR_RETURN(ShardReader * shard, Shard(o.shard_index));
    SOLID_ASSIGN_OR_RETURN(std::vector<InstanceRecord> found, shard->InstancesOfModel(model_key));
    out.insert(out.end(), std::make_move_iterator(found.begin()), std::make_move_iterator(found.end()));
  }
  return out;
}

Result<std::vector<QueryViewRecord>> Dataset::QueryViews(std::string_view model_key) {
  if (impl_->index) {
    SOLID_ASSIGN_OR_RETURN(sqlite::Stmt stmt, sqlite::Stmt::Prepare(*impl_->index, "SELECT query_shard_index FROM "
                                                                                   "models WHERE model_key = ?"));
    stmt.Bind(1, model_key);
    SOLID_ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row || stmt.ColumnType(0) != SQLITE_INTEGER) return std::vector<QueryViewRecord>();
    SOLID_ASSIGN_OR_RETURN(QueryShardReader reader, QueryShardReader::Open(paths().query_shard(stmt.Int(0))));
    return reader.ViewsOfModel(model_key);
  }
  for (const ShardFile& file : impl_->listing.queries) {
    SOLID_ASSIGN_OR_RETURN(QueryShardReader reader, QueryShardReader::Open(file.path));
    SOLID_ASSIGN_OR_RETURN(std::vector<QueryViewRecord> views, reader.ViewsOfModel(model_key));
    if (!views.empty()) return views;
  }
  return std::vector<QueryViewRecord>();
}

}  // namespace solid
