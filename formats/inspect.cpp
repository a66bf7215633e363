#include "solid/formats/inspect.h"

#include <fmt/format.h>

#include <system_error>

#include "solid/formats/catalog.h"
#include "solid/formats/checksum.h"
#include "solid/formats/dataset.h"
#include "solid/formats/metrics.h"
#include "solid/formats/shard.h"

namespace solid {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

int64_t FileSize(const fs::path& p) {
  std::error_code ec;
  auto size = fs::file_size(p, ec);
  return ec ? 0 : static_cast<int64_t>(size);
}

// A shard read alone is classed as the manifest in its provenance counts (1 without one).
double ShardAreaScale(const fs::path& path) {
  Result<ShardReader> reader = ShardReader::Open(path);
  if (!reader.ok()) return 1;
  Result<std::vector<std::pair<std::string, std::string>>> meta = reader->Meta();
  if (!meta.ok()) return 1;
  const Result<ShardProvenance> provenance = ReadProvenance(*meta, path.string());
  return provenance.ok() ? provenance->manifest.ScaleClassAreaScale() : 1.0;
}

// The shard's rows are added to `metrics` only once the shard has been read whole.
Result<json> TargetShardSummary(const fs::path& path, MetricsAccumulator* metrics) {
  SOLID_ASSIGN_OR_RETURN(ShardReader reader, ShardReader::Open(path));
  SOLID_ASSIGN_OR_RETURN(ShardSummary s, reader.Summarize());
  MetricsAccumulator with_shard = *metrics;
  SOLID_RETURN_IF_ERROR(reader.AddToMetrics(with_shard));
  SOLID_ASSIGN_OR_RETURN(auto meta, reader.Meta());
  json meta_json = json::object();
  for (const auto& [k, v] : meta) meta_json[k] = v;
  *metrics = with_shard;
  return json{{"file", path.string()},
              {"bytes", FileSize(path)},
              {"images", s.counts.images},
              {"instances", s.counts.instances},
              {"visible_instances", s.visible_instances},
              {"models", s.distinct_models},
              {"first_image_id", s.counts.first_image_id},
              {"last_image_id", s.counts.last_image_id},
              {"image_bytes", s.image_bytes},
              {"depth_images", s.depth_images},
              {"depth_bytes", s.depth_bytes},
              {"rle_bytes", s.rle_bytes},
              {"meta", meta_json}};
}

Result<json> QueryShardSummary(const fs::path& path) {
  SOLID_ASSIGN_OR_RETURN(QueryShardReader reader, QueryShardReader::Open(path));
  SOLID_ASSIGN_OR_RETURN(std::vector<QueryModelRecord> models, reader.Models());
  int64_t views = 0, failed = 0;
  for (const QueryModelRecord& m : models) {
    views += m.view_count;
    if (m.failure) ++failed;
  }
  return json{{"file", path.string()},
              {"bytes", FileSize(path)},
              {"models", models.size()},
              {"views", views},
              {"models_with_failures", failed}};
}

std::string Bytes(int64_t n) {
  if (n >= (int64_t{1} << 30)) return fmt::format("{:.2f} GiB", static_cast<double>(n) / (1 << 30));
  if (n >= (1 << 20)) return fmt::format("{:.2f} MiB", static_cast<double>(n) / (1 << 20));
  if (n >= (1 << 10)) return fmt::format("{:.1f} KiB", static_cast<double>(n) / (1 << 10));
  return fmt::format("{} B", n);
}

std::string Est(const json& e, double scale, std::string_view unit) {
  return fmt::format("{:.3g}{} ± {:.2g}{}", e["mean"].get<double>() * scale, unit, e["ci95"].get<double>() * scale,
                     unit);
}

Result<json> InspectAssets(const fs::path& root) {
  SOLID_ASSIGN_OR_RETURN(Catalog catalog, Catalog::OpenReadOnly(root / "catalog.sqlite"));
  SOLID_ASSIGN_OR_RETURN(std::vector<CatalogEntry> entries, catalog.All());
  SOLID_ASSIGN_OR_RETURN(uint64_t content_hash, catalog.ContentHash());
  json by_source = json::object(), failure_codes = json::object(), warning_codes = json::object();
  json failures = json::array();
  int64_t bytes_in = 0, bytes_out = 0, triangles = 0, models = 0, rooms = 0;
  for (const CatalogEntry& e : entries) {
    json& src = by_source[e.source];
    if (src.is_null()) src = json::object();
    std::string status(AssetStatusName(e.status));
    src[status] = src.value(status, 0) + 1;
    (e.kind == "room" ? rooms : models) += 1;
    for (const json& w : e.warnings) {
      if (w.is_object() && w.contains("code") && w["code"].is_string()) {
        std::string code = w["code"].get<std::string>();
        warning_codes[code] = warning_codes.value(code, 0) + 1;
      }
    }
    if (e.status == AssetStatus::kFailed) {
      std::string code = e.error_code.value_or("unknown");
      failure_codes[code] = failure_codes.value(code, 0) + 1;
      failures.push_back({{"key", e.key}, {"code", code}, {"error", e.error.value_or("")}});
      continue;
    }
    bytes_in += e.bytes_in;
    bytes_out += e.bytes_out;
    triangles += e.triangles;
  }
  return json{{"kind", "assets"},
              {"path", root.string()},
              {"assets", entries.size()},
              {"models", models},
              {"rooms", rooms},
              {"by_source", by_source},
              {"failure_codes", failure_codes},
              {"warning_codes", warning_codes},
              {"failures", failures},
              {"bytes_in", bytes_in},
              {"bytes_out", bytes_out},
              {"triangles", triangles},
              {"compression_ratio", bytes_out > 0 ? static_cast<double>(bytes_in) / static_cast<double>(bytes_out) : 0.0},
              {"catalog_hash", Hex64(content_hash)}};
}

Result<json> InspectPath(const fs::path& path) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) {
    if (ParseQueryShardFileName(path.filename().string()).ok()) {
      SOLID_ASSIGN_OR_RETURN(json q, QueryShardSummary(path));
      q["kind"] = "query_shard";
      return q;
    }
    MetricsAccumulator metrics(ShardAreaScale(path));
    SOLID_ASSIGN_OR_RETURN(json t, TargetShardSummary(path, &metrics));
    t["kind"] = "target_shard";
    t["metrics"] = metrics.Finish().ToJson();
    return t;
  }
  if (!fs::is_directory(path, ec)) return NotFoundError(path.string() + ": no such dataset, assets directory or shard");
  if (fs::exists(path / "catalog.sqlite", ec) && !fs::exists(DatasetPaths(path).manifest(), ec)) {
    return InspectAssets(path);
  }
  SOLID_ASSIGN_OR_RETURN(Manifest manifest, ReadManifest(path));
  SOLID_ASSIGN_OR_RETURN(ShardListing listing, ListShards(path));
  MetricsAccumulator metrics(manifest.ScaleClassAreaScale());
  json shards = json::array(), queries = json::array(), unreadable = json::array();
  json totals = {{"images", 0}, {"instances", 0}, {"visible_instances", 0}, {"image_bytes", 0},
                 {"depth_images", 0}, {"rle_bytes", 0}, {"shard_bytes", 0}};
  for (const ShardFile& f : listing.targets) {
    Result<json> s = TargetShardSummary(f.path, &metrics);
    if (!s.ok()) {
      unreadable.push_back({{"file", f.path.string()}, {"error", s.status().message()}});
      continue;
    }
    for (const char* k : {"images", "instances", "visible_instances", "image_bytes", "depth_images", "rle_bytes"}) {
      totals[k] = totals[k].get<int64_t>() + (*s)[k].get<int64_t>();
    }
    totals["shard_bytes"] = totals["shard_bytes"].get<int64_t>() + (*s)["bytes"].get<int64_t>();
    shards.push_back(*s);
  }
  json query_totals = {{"models", 0}, {"views", 0}, {"models_with_failures", 0}, {"bytes", 0}};
  for (const ShardFile& f : listing.queries) {
    Result<json> q = QueryShardSummary(f.path);
    if (!q.ok()) {
      unreadable.push_back({{"file", f.path.string()}, {"error", q.status().message()}});
      continue;
    }
    for (const char* k : {"models", "views", "models_with_failures", "bytes"}) {
      query_totals[k] = query_totals[k].get<int64_t>() + (*q)[k].get<int64_t>();
    }
    queries.push_back(*q);
  }
  DatasetPaths paths(path);
  json unexpected = json::array();
  for (const fs::path& p : listing.unexpected) unexpected.push_back(p.string());
  return json{{"kind", "dataset"},
              {"path", path.string()},
              {"manifest", manifest.ToJson()},
              {"shards_present", shards.size()},
              {"shards_planned", manifest.ShardCount()},
              {"totals", totals},
              {"queries", query_totals},
              {"index_present", fs::exists(paths.index(), ec)},
              {"index_bytes", FileSize(paths.index())},
              {"metrics", metrics.Finish().ToJson()},
              {"shards", shards},
              {"query_shards", queries},
              {"unreadable", unreadable},
              {"unexpected_files", unexpected}};
}

}  // namespace

Result<InspectReport> Inspect(const InspectOptions& options) {
  if (options.path.empty()) return OptionError("path", "no dataset, assets directory or shard given");
  SOLID_ASSIGN_OR_RETURN(json summary, InspectPath(options.path));
  return InspectReport{std::move(summary)};
}

std::string InspectReport::ToText() const {
  const json& j = summary;
  std::string out;
  auto line = [&](std::string_view label, const std::string& value) {
    out += fmt::format("  {:<22} {}\n", label, value);
  };
  auto metrics_block = [&](const json& m) {
    out += "proxy metrics (95% CI)\n";
    line("objects per image", Est(m["objects_per_image"], 1, ""));
    line("mean occlusion", Est(m["occlusion"], 100, "%"));
    line("small / medium / large", fmt::format("{} / {} / {}", Est(m["scale"]["small"], 100, "%"),
                                               Est(m["scale"]["medium"], 100, "%"), Est(m["scale"]["large"], 100, "%")));
  };
  std::string kind = j.value("kind", "");
  if (kind == "assets") {
    out += fmt::format("assets {}\n", j["path"].get<std::string>());
    line("assets", fmt::format("{} ({} models, {} rooms)", j["assets"].get<int64_t>(), j["models"].get<int64_t>(),
                               j["rooms"].get<int64_t>()));
    for (const auto& [source, counts] : j["by_source"].items()) {
      std::string text;
      for (const auto& [status, n] : counts.items()) text += fmt::format("{}{} {}", text.empty() ? "" : ", ", n.get<int64_t>(), status);
      line(source, text);
    }
    line("triangles", std::to_string(j["triangles"].get<int64_t>()));
    line("size", fmt::format("{} in, {} out (ratio {:.1f})", Bytes(j["bytes_in"].get<int64_t>()),
                             Bytes(j["bytes_out"].get<int64_t>()), j["compression_ratio"].get<double>()));
    line("catalog hash", j["catalog_hash"].get<std::string>());
    for (const auto& [code, n] : j["warning_codes"].items()) line("warning " + code, std::to_string(n.get<int64_t>()));
    for (const auto& [code, n] : j["failure_codes"].items()) line("failed " + code, std::to_string(n.get<int64_t>()));
    size_t shown = 0;
    for (const json& f : j["failures"]) {
      if (++shown > 20) {
        out += fmt::format("  ... {} more failures (InspectReport::ToJson lists them all)\n",
                           j["failures"].size() - 20);
        break;
      }
      out += fmt::format("  FAILED {} [{}]: {}\n", f["key"].get<std::string>(), f["code"].get<std::string>(),
                         f["error"].get<std::string>());
    }
    return out;
  }
  if (kind == "query_shard") {
    out += fmt::format("query shard {}\n", j["file"].get<std::string>());
    line("size", Bytes(j["bytes"].get<int64_t>()));
    line("models", std::to_string(j["models"].get<int64_t>()));
    line("views", std::to_string(j["views"].get<int64_t>()));
    line("models with failures", std::to_string(j["models_with_failures"].get<int64_t>()));
    return out;
  }
  if (kind == "target_shard") {
    out += fmt::format("target shard {}\n", j["file"].get<std::string>());
    line("size", Bytes(j["bytes"].get<int64_t>()));
    line("images", fmt::format("{} (ids {}..{})", j["images"].get<int64_t>(), j["first_image_id"].get<int64_t>(),
                               j["last_image_id"].get<int64_t>()));
    line("instances", fmt::format("{} ({} visible) of {} models", j["instances"].get<int64_t>(),
                                  j["visible_instances"].get<int64_t>(), j["models"].get<int64_t>()));
    line("image bytes", Bytes(j["image_bytes"].get<int64_t>()));
    line("mask bytes (RLE)", Bytes(j["rle_bytes"].get<int64_t>()));
    for (const auto& [k, v] : j["meta"].items()) line("meta " + k, v.get<std::string>());
    metrics_block(j["metrics"]);
    return out;
  }
  const json& m = j["manifest"];
  const json& t = j["totals"];
  out += fmt::format("dataset {}\n", j["path"].get<std::string>());
  line("generator", fmt::format("{} {}", m["generator"]["name"].get<std::string>(),
                                m["generator"]["version"].get<std::string>()));
  line("seed", m["seed"].get<std::string>());
  line("params hash", m["params_hash"].get<std::string>());
  line("resolution", fmt::format("{}x{} {}", m["width"].get<int64_t>(), m["height"].get<int64_t>(),
                                 m["image_format"].get<std::string>()));
  line("scale classes", fmt::format("counted at {}x{}", m["scale_classes_at"][0].get<int64_t>(),
                                    m["scale_classes_at"][1].get<int64_t>()));
  line("shards", fmt::format("{} of {} present ({} images each)", j["shards_present"].get<int64_t>(),
                             j["shards_planned"].get<int64_t>(), m["shard_size"].get<int64_t>()));
  line("images", fmt::format("{} of {} planned", t["images"].get<int64_t>(), m["images"].get<int64_t>()));
  line("instances", fmt::format("{} ({} visible)", t["instances"].get<int64_t>(), t["visible_instances"].get<int64_t>()));
  const json& q = j["queries"];
  line("query views", fmt::format("{} of {} models ({} with failures)", q["views"].get<int64_t>(),
                                  q["models"].get<int64_t>(), q["models_with_failures"].get<int64_t>()));
  int64_t images = t["images"].get<int64_t>();
  line("size", fmt::format("{} shards, {} queries, {} index", Bytes(t["shard_bytes"].get<int64_t>()),
                           Bytes(q["bytes"].get<int64_t>()), Bytes(j["index_bytes"].get<int64_t>())));
  if (images > 0) {
    line("per image", fmt::format("{} image, {} masks", Bytes(t["image_bytes"].get<int64_t>() / images),
                                  Bytes(t["rle_bytes"].get<int64_t>() / images)));
  }
  line("index", j["index_present"].get<bool>() ? "present" : "absent (BuildIndex builds it)");
  metrics_block(j["metrics"]);
  for (const json& u : j["unreadable"]) {
    out += fmt::format("unreadable: {}: {}\n", u["file"].get<std::string>(), u["error"].get<std::string>());
  }
  for (const json& u : j["unexpected_files"]) out += fmt::format("unexpected file: {}\n", u.get<std::string>());
  return out;
}

}  // namespace solid
