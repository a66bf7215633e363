#include "solid/formats/validate.h"

#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <set>

#include "solid/formats/dataset.h"
#include "solid/formats/image_codec.h"
#include "solid/formats/index.h"
#include "solid/formats/rle.h"
#include "solid/formats/shard.h"
#include "sqlite_util.h"

namespace solid {
namespace fs = std::filesystem;

namespace {

class Checker {
 public:
  Checker(const ValidateOptions& options, ValidationReport* report) : options_(options), report_(report) {}

  void Problem(std::string location, std::string message) {
    if (report_->problems.size() >= options_.max_problems) {
      ++report_->problems_not_listed;
      return;
    }
    report_->problems.push_back({std::move(location), std::move(message)});
  }
  void Problem(const Status& s) { Problem("", s.message()); }

  // SQLite's own page-level check: catches damage that no row read touches.
  void CheckIntegrity(const fs::path& path) {
    Result<sqlite::Db> db = sqlite::Db::Open(path, sqlite::OpenMode::kUntrustedRead);
    if (!db.ok()) return Problem(db.status());
    Result<sqlite::Stmt> stmt = sqlite::Stmt::Prepare(*db, "PRAGMA quick_check(20)");
    if (!stmt.ok()) return Problem(stmt.status());
    for (;;) {
      Result<bool> row = stmt->Step();
      if (!row.ok()) return Problem(row.status());
      if (!*row) return;
      std::string_view text = stmt->Text(0);
      if (text != "ok") Problem(path.string() + ": sqlite quick_check", std::string(text));
    }
  }

  // Returns the decoded mask when the string is a valid RLE of the image's size.
  std::optional<rle::Rle> CheckRle(const std::string& where, std::string_view field, const std::string& counts,
                                   uint32_t height, uint32_t width) {
    Result<rle::Rle> r = rle::FromString(counts, height, width);
    if (!r.ok()) {
      Problem(fmt::format("{}: {}", where, field), r.status().message());
      return std::nullopt;
    }
    return std::move(r).value();
  }

  // `area_scale`: the dataset's Manifest::ScaleClassAreaScale.
  void CheckInstance(const std::string& where, const InstanceRecord& in, uint32_t height, uint32_t width,
                     double area_scale) {
    std::optional<rle::Rle> visible = CheckRle(where, "visible_rle", in.visible_rle, height, width);
    std::optional<rle::Rle> full = CheckRle(where, "full_rle", in.full_rle, height, width);
    auto expect_box = [&](std::string_view field, const rle::Box& stored, const rle::Box& actual) {
      if (stored != actual) {
        Problem(fmt::format("{}: {}_box", where, field),
                fmt::format("stored [{}, {}, {}, {}], the mask gives [{}, {}, {}, {}]", stored.x, stored.y, stored.w,
                            stored.h, actual.x, actual.y, actual.w, actual.h));
      }
    };
    auto expect_area = [&](std::string_view field, uint64_t stored, uint64_t actual) {
      if (stored != actual) {
        Problem(fmt::format("{}: {}", where, field), fmt::format("stored {}, the mask has {} pixels", stored, actual));
      }
    };
    if (visible) {
      expect_box("visible", in.visible_box, rle::ToBbox(*visible));
      expect_area("visible_area", in.visible_area, rle::Area(*visible));
    }
    if (full) {
      expect_box("full", in.full_box, rle::ToBbox(*full));
      expect_area("full_area", in.full_area, rle::Area(*full));
    }
    if (visible && full && !rle::Contains(*full, *visible)) {
      Problem(where + ": full_rle", "the full mask does not contain the visible mask");
    }
    if (in.full_area == 0) {
      if (in.occlusion) Problem(where + ": occlusion", "set although full_area is 0");
    } else {
      double expected = static_cast<double>(in.full_area - std::min(in.full_area, in.visible_area)) /
                        static_cast<double>(in.full_area);
      if (!in.occlusion) {
        Problem(where + ": occlusion", "missing although full_area > 0");
      } else if (std::fabs(*in.occlusion - expected) > 1e-9) {
        Problem(where + ": occlusion", fmt::format("stored {}, (full - visible) / full = {}", *in.occlusion, expected));
      }
    }
    if (in.visible_area == 0) {
      if (in.scale_class) Problem(where + ": scale_class", "set although visible_area is 0");
    } else if (!in.scale_class || *in.scale_class != ScaleClassOfArea(in.visible_area, area_scale)) {
      Problem(where + ": scale_class",
              fmt::format("stored {}, visible_area {} is {}{}", in.scale_class ? ScaleClassName(*in.scale_class) : "NULL",
                          in.visible_area, ScaleClassName(ScaleClassOfArea(in.visible_area, area_scale)),
                          area_scale == 1 ? "" : fmt::format(" counted as {:g} pixels", in.visible_area * area_scale)));
    }
  }

  void CheckDecodesTo(const std::string& where, std::span<const uint8_t> bytes, ImageFormat format, uint32_t width,
                      uint32_t height) {
    Result<Image8> decoded = DecodeImage(bytes, format);
    if (!decoded.ok()) {
      Problem(where + ": image", decoded.status().message());
    } else if (decoded->width != width || decoded->height != height) {
      Problem(where + ": image",
              fmt::format("decodes to {}x{}, stored size {}x{}", decoded->width, decoded->height, width, height));
    }
  }

  void CheckImageBytes(const std::string& where, const ImageRecord& im) {
    if (!options_.decode_images) return;
    CheckDecodesTo(where, im.image, im.format, im.width, im.height);
    if (im.depth_exr) {
      Result<DepthImage> depth = DecodeDepthExr(*im.depth_exr);
      if (!depth.ok()) {
        Problem(where + ": depth", depth.status().message());
      } else if (depth->width != im.width || depth->height != im.height) {
        Problem(where + ": depth", fmt::format("decodes to {}x{}, image is {}x{}", depth->width, depth->height,
                                               im.width, im.height));
      }
    }
  }

  // What the shard says it was made from, compared with the dataset's manifest when there
  // is one and with its file name. Returns the manifest its rows are checked against: the
  // dataset's, else the shard's own.
  template <typename Reader>
  std::optional<Manifest> CheckProvenanceOf(Reader& reader, const fs::path& path, const Manifest* manifest,
                                            std::optional<int64_t> shard_index) {
    Status content = reader.VerifyContent(ChecksumPolicy::kSkip);  // the blobs are hashed as they are read
    if (!content.ok()) Problem(content);
    Result<std::vector<std::pair<std::string, std::string>>> meta = reader.Meta();
    if (!meta.ok()) {
      Problem(meta.status());
      return manifest ? std::optional<Manifest>(*manifest) : std::nullopt;
    }
    Result<ShardProvenance> found = ReadProvenance(*meta, path.string());
    if (!found.ok()) {
      Problem(found.status());
      return manifest ? std::optional<Manifest>(*manifest) : std::nullopt;
    }
    if (manifest && shard_index) {
      Status belongs = CheckProvenance(*found, *manifest, *shard_index, path.string());
      if (!belongs.ok()) Problem(belongs);
      return *manifest;
    }
    if (shard_index && found->shard_index != *shard_index) {
      Problem(path.string() + ": provenance", fmt::format("shard_index {} in the shard, {} by its file name",
                                                          found->shard_index, *shard_index));
    }
    return found->manifest;
  }

  // Returns the model keys the shard's instances use.
  std::set<std::string> CheckTargetShard(const fs::path& path, const Manifest* dataset_manifest,
                                         std::optional<int64_t> shard_index) {
    std::set<std::string> models;
    ++report_->shards;
    CheckIntegrity(path);
    Result<ShardReader> reader = ShardReader::Open(path);
    if (!reader.ok()) {
      Problem(reader.status());
      return models;
    }
    const std::optional<Manifest> own = CheckProvenanceOf(*reader, path, dataset_manifest, shard_index);
    const Manifest* manifest = own ? &*own : nullptr;
    // Scale classes as the manifest counts them (the shard's own, for a shard read alone).
    const double area_scale = manifest ? manifest->ScaleClassAreaScale() : 1.0;
    Result<std::vector<int64_t>> ids = reader->ImageIds();
    if (!ids.ok()) {
      Problem(ids.status());
      return models;
    }
    int64_t walked = 0;
    for (int64_t id : *ids) {
      std::string where = fmt::format("{}: images row {}", path.string(), id);
      ++report_->images;
      if (manifest && shard_index) {
        int64_t first = *shard_index * manifest->shard_size;
        if (id < first || id >= first + manifest->shard_size || id >= manifest->images) {
          Problem(where + ": image_id", fmt::format("outside shard {}'s range [{}, {}) of {} images", *shard_index,
                                                    first, first + manifest->shard_size, manifest->images));
        }
      }
      Result<ImageRecord> im = reader->ReadImage(id);
      if (!im.ok()) {
        Problem(im.status());
        continue;
      }
      if (manifest && (im->width != manifest->width || im->height != manifest->height)) {
        Problem(where + ": width, height", fmt::format("{}x{}, the manifest says {}x{}", im->width, im->height,
                                                       manifest->width, manifest->height));
      }
      CheckImageBytes(where, *im);
      Result<std::vector<InstanceRecord>> instances = reader->InstancesOfImage(id);
      if (!instances.ok()) {
        Problem(instances.status());
        continue;
      }
      walked += static_cast<int64_t>(instances->size());
      for (const InstanceRecord& in : *instances) {
        ++report_->instances;
        models.insert(in.model_key);
        CheckInstance(fmt::format("{}: instances (image {} #{})", path.string(), id, in.ordinal), in, im->height,
                      im->width, area_scale);
      }
    }
    // Instances whose image row is missing escape the per-image walk above.
    Result<ShardCounts> counts = reader->Counts();
    if (!counts.ok()) {
      Problem(counts.status());
    } else if (counts->instances != walked) {
      Problem(path.string() + ": instances",
              fmt::format("{} rows, but {} were read through their images", counts->instances, walked));
    }
    return models;
  }

  // Returns the models with at least one view.
  std::set<std::string> CheckQueryShard(const fs::path& path, const Manifest* manifest,
                                        std::optional<int64_t> shard_index) {
    std::set<std::string> with_views;
    ++report_->query_shards;
    CheckIntegrity(path);
    Result<QueryShardReader> reader = QueryShardReader::Open(path);
    if (!reader.ok()) {
      Problem(reader.status());
      return with_views;
    }
    (void)CheckProvenanceOf(*reader, path, manifest, shard_index);
    Result<std::vector<QueryModelRecord>> models = reader->Models();
    if (!models.ok()) {
      Problem(models.status());
      return with_views;
    }
    for (const QueryModelRecord& m : *models) {
      std::string where = fmt::format("{}: query_models {}", path.string(), m.model_key);
      Result<std::vector<QueryViewRecord>> views = reader->ViewsOfModel(m.model_key);
      if (!views.ok()) {
        Problem(views.status());
        continue;
      }
      if (static_cast<int64_t>(views->size()) != m.view_count) {
        Problem(where + ": view_count", fmt::format("{}, but {} views are stored", m.view_count, views->size()));
      }
      if (!views->empty()) with_views.insert(m.model_key);
      for (const QueryViewRecord& v : *views) {
        ++report_->query_views;
        std::string vwhere = fmt::format("{}: query_views ({} view {})", path.string(), v.model_key, v.view_index);
        if (v.box.x + v.box.w > v.width || v.box.y + v.box.h > v.height) {
          Problem(vwhere + ": box", fmt::format("[{}, {}, {}, {}] exceeds the {}x{} crop", v.box.x, v.box.y, v.box.w,
                                                v.box.h, v.width, v.height));
        }
        if (options_.decode_images) CheckDecodesTo(vwhere, v.image, v.format, v.width, v.height);
      }
    }
    return with_views;
  }

 private:
  const ValidateOptions& options_;
  ValidationReport* report_;
};

}  // namespace

nlohmann::json ValidationReport::ToJson() const {
  nlohmann::json list = nlohmann::json::array();
  for (const ValidationProblem& p : problems) list.push_back({{"location", p.location}, {"message", p.message}});
  return {{"ok", ok()},
          {"checked",
           {{"shards", shards},
            {"query_shards", query_shards},
            {"images", images},
            {"instances", instances},
            {"query_views", query_views}}},
          {"problems", list},
          {"problems_not_listed", problems_not_listed}};
}

std::string ValidationReport::ToText() const {
  std::string out;
  for (const ValidationProblem& p : problems) {
    out += (p.location.empty() ? p.message : p.location + ": " + p.message) + "\n";
  }
  if (problems_not_listed > 0) out += fmt::format("{} more problems not listed\n", problems_not_listed);
  out += fmt::format("{}: {} shards, {} query shards, {} images, {} instances, {} query views checked; {} problems\n",
                     ok() ? "OK" : "FAILED", shards, query_shards, images, instances, query_views,
                     problems.size() + static_cast<size_t>(problems_not_listed));
  return out;
}

Result<ValidationReport> Validate(const ValidateOptions& options) {
  if (options.path.empty()) return OptionError("path", "no dataset directory or shard file given");
  if (options.max_problems < 1 || options.max_problems > kMaxListedProblems) {
    return OptionError("max_problems", fmt::format("{} is not in [1, {}]", options.max_problems, kMaxListedProblems));
  }
  std::error_code ec;
  if (!fs::exists(options.path, ec)) {
    return NotFoundError(options.path.string() + ": no such dataset directory or shard file");
  }
  return fs::is_regular_file(options.path, ec) ? ValidateShardFile(options.path, options)
                                               : ValidateDataset(options.path, options);
}

ValidationReport ValidateDataset(const fs::path& root, const ValidateOptions& options) {
  ValidationReport report;
  Checker check(options, &report);
  DatasetPaths paths(root);
  Result<Manifest> manifest = ReadManifest(root);
  if (!manifest.ok()) check.Problem(manifest.status());
  Result<ShardListing> listing = ListShards(root);
  if (!listing.ok()) {
    check.Problem(listing.status());
    return report;
  }
  for (const fs::path& p : listing->unexpected) {
    const std::string name = p.filename().string();
    const bool shard_name = ParseTargetShardFileName(name).ok() || ParseQueryShardFileName(name).ok();
    check.Problem(p.string(), shard_name ? "named as a shard, but not a regular file inside the dataset "
                                           "(RenderOptions::repair replaces it)"
                                         : "unexpected file in a shard directory");
  }

  int64_t total = static_cast<int64_t>(listing->targets.size() + listing->queries.size()), done = 0;
  std::set<std::string> instanced, with_views;
  for (const ShardFile& f : listing->targets) {
    if (options.progress) options.progress(done++, total);
    if (manifest.ok() && f.index >= manifest->ShardCount()) {
      check.Problem(f.path.string(), fmt::format("shard {} is beyond the manifest's {} shards", f.index,
                                                 manifest->ShardCount()));
    }
    std::set<std::string> models = check.CheckTargetShard(f.path, manifest.ok() ? &*manifest : nullptr, f.index);
    instanced.insert(models.begin(), models.end());
  }
  for (const ShardFile& f : listing->queries) {
    if (options.progress) options.progress(done++, total);
    std::set<std::string> models = check.CheckQueryShard(f.path, manifest.ok() ? &*manifest : nullptr, f.index);
    for (const std::string& m : models) {
      if (!with_views.insert(m).second) check.Problem(f.path.string(), "model " + m + " has views in two query shards");
    }
  }
  if (!listing->queries.empty()) {
    for (const std::string& m : instanced) {
      if (!with_views.count(m)) check.Problem(paths.queries_dir().string(), "model " + m + " has no query views");
    }
  }
  if (manifest.ok()) {
    Result<std::vector<std::string>> diffs = CompareIndex(root);
    if (!diffs.ok()) {
      check.Problem(diffs.status());
    } else {
      for (const std::string& d : *diffs) check.Problem(paths.index().string(), d);
    }
  }
  if (options.progress) options.progress(total, total);
  return report;
}

ValidationReport ValidateShardFile(const fs::path& path, const ValidateOptions& options) {
  ValidationReport report;
  Checker check(options, &report);
  const std::string name = path.filename().string();
  if (Result<int64_t> q = ParseQueryShardFileName(name); q.ok()) {
    check.CheckQueryShard(path, nullptr, *q);
  } else {
    Result<int64_t> k = ParseTargetShardFileName(name);
    check.CheckTargetShard(path, nullptr, k.ok() ? std::optional<int64_t>(*k) : std::nullopt);
  }
  return report;
}

ValidationReport ValidateShardOfDataset(const fs::path& path, const Manifest& manifest, bool query,
                                        int64_t shard_index, const ValidateOptions& options) {
  ValidationReport report;
  Checker check(options, &report);
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    check.Problem(path.string(), "not a regular file");
  } else if (query) {
    check.CheckQueryShard(path, &manifest, shard_index);
  } else {
    check.CheckTargetShard(path, &manifest, shard_index);
  }
  return report;
}

}  // namespace solid
