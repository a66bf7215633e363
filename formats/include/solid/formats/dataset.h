// A dataset directory:
//
//   manifest.json                  what was generated, from what (schemas/manifest.schema.json)
//   shards/shard-NNNNNN.sqlite     target images and instances; shard K holds image ids
//                                  [K * shard_size, (K + 1) * shard_size)
//   queries/queries-NNNNNN.sqlite  query views, each model in exactly one query shard
//   index.sqlite                   derived: shard list, model occurrences, metrics (BuildIndex)
//
// Files ending in ".tmp-<host>-<pid>-<n>" are unpublished work of a writer and are never read.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/records.h"
#include "solid/formats/shard.h"
#include "solid/formats/status.h"

namespace solid {

// Of the manifest, and the user_version of every shard, query shard and index.
inline constexpr int kDatasetFormatVersion = 2;

struct Manifest {
  int format_version = kDatasetFormatVersion;
  std::string generator_name = "solid";
  std::string generator_version;  // defaults to this library's version when written empty
  std::string git_sha;            // optional
  uint64_t seed = 0;
  int64_t images = 0;
  int64_t shard_size = 256;
  uint32_t width = 640, height = 480;
  // The resolution COCO's scale classes are counted at (params render.scale_classes_at,
  // solid-method.md 4.2); 0 x 0: width x height. Stored instances' scale_class and every
  // metric of the dataset use it.
  uint32_t scale_width = 0, scale_height = 0;
  ImageFormat image_format = ImageFormat::kPng;
  nlohmann::json params = nlohmann::json::object();  // resolved generation parameters
  uint64_t catalog_hash = 0;

  // XXH64 of the canonical dump of params (keys sorted, no spaces).
  uint64_t ParamsHash() const;
  std::pair<uint32_t, uint32_t> ScaleClassResolution() const;
  // How many times more pixels the scale-class resolution has than the images: the
  // area_scale of ScaleClassOfArea and MetricsAccumulator for this dataset's masks.
  double ScaleClassAreaScale() const;
  int64_t ShardCount() const { return shard_size > 0 ? (images + shard_size - 1) / shard_size : 0; }

  nlohmann::json ToJson() const;
  // Validates against schemas/manifest.schema.json; errors name the file and the key.
  // kUnsupportedVersion for another format_version.
  static Result<Manifest> Parse(std::string_view text, std::string_view name);
};

// Why two manifests describe different datasets (seed, params, sizes...), or empty when
// they describe the same one: "seed 0x.. vs 0x..; params_hash .. vs .. (first difference
// at /layout/objects/attempts)", or with labels "seed 0x.. in the shard, 0x.. in the
// manifest". Generator versions are compared: mixing versions in one dataset would break
// its determinism.
std::string ManifestDifference(const Manifest& a, const Manifest& b);
std::string ManifestDifference(const Manifest& a, const Manifest& b, std::string_view a_label,
                               std::string_view b_label);

struct DatasetPaths {
  explicit DatasetPaths(std::filesystem::path root) : root(std::move(root)) {}
  std::filesystem::path root;
  std::filesystem::path manifest() const { return root / "manifest.json"; }
  std::filesystem::path shards_dir() const { return root / "shards"; }
  std::filesystem::path queries_dir() const { return root / "queries"; }
  std::filesystem::path index() const { return root / "index.sqlite"; }
  std::filesystem::path shard(int64_t k) const { return shards_dir() / TargetShardFileName(k); }
  std::filesystem::path query_shard(int64_t k) const { return queries_dir() / QueryShardFileName(k); }
};

// Creates the directory tree and writes manifest.json atomically.
Status CreateDataset(const std::filesystem::path& root, const Manifest& manifest);
Result<Manifest> ReadManifest(const std::filesystem::path& root);

struct ShardFile {
  int64_t index = 0;
  std::filesystem::path path;
};
struct ShardListing {
  std::vector<ShardFile> targets, queries;  // sorted by index
  // Files that are neither ours nor temporaries, and shard names that are symbolic links
  // leading out of the dataset directory (never opened).
  std::vector<std::filesystem::path> unexpected;
};
Result<ShardListing> ListShards(const std::filesystem::path& root);

// Provenance: every target and query shard records, in its checksummed shard_meta, the
// manifest of the dataset it was rendered for ("manifest", its canonical JSON: format
// version, generator, seed, sizes, render settings, params and their hash, catalog hash)
// and its own number ("shard_index"). A shard belongs to a dataset when both agree with
// the dataset's manifest and its file name.
struct ShardProvenance {
  Manifest manifest;
  int64_t shard_index = -1;
};
Status WriteProvenance(ShardWriter& writer, const Manifest& manifest, int64_t shard_index);
Status WriteProvenance(QueryShardWriter& writer, const Manifest& manifest, int64_t shard_index);
// From a shard's Meta(); kCorrupt naming `file` when a key is missing or malformed.
Result<ShardProvenance> ReadProvenance(const std::vector<std::pair<std::string, std::string>>& meta,
                                       std::string_view file);
// kCorrupt "<file>: provenance: <field> <value> in the shard, <value> in the manifest"
// when the shard is not shard `shard_index` of the dataset `manifest` describes.
Status CheckProvenance(const ShardProvenance& found, const Manifest& manifest, int64_t shard_index,
                       std::string_view file);

// Rebuilds manifest.json of a dataset that lost it from the provenance of its shards,
// which must all agree (and each be named after its own shard_index). Shards whose
// provenance cannot be read are listed, not used: `solid render --repair` re-renders them.
struct AdoptReport {
  Manifest manifest;
  int64_t target_shards = 0, query_shards = 0;  // that agree, and were used
  std::vector<Status> unreadable;                // shards whose provenance could not be read
  // One line saying what was found (and one per shard left out), for the user.
  std::string Summary(const std::filesystem::path& root) const;
};
// kAlreadyExists when manifest.json exists, kNotFound when no shard has a readable
// provenance, kCorrupt naming two shards and the field when they disagree.
Result<AdoptReport> AdoptManifest(const std::filesystem::path& root);

// Read access to a dataset. Uses index.sqlite for lookups by model when it is present
// and agrees with the shards; scans the shards otherwise. Not thread-safe.
class Dataset {
 public:
  static Result<Dataset> Open(const std::filesystem::path& root);
  Dataset(Dataset&&) noexcept;
  Dataset& operator=(Dataset&&) noexcept;
  ~Dataset();

  const DatasetPaths& paths() const;
  const Manifest& manifest() const;
  const ShardListing& shards() const;

  int64_t ShardOfImage(int64_t image_id) const { return image_id / manifest().shard_size; }
  // kNotFound for a shard that is not (yet) present.
  Result<ShardReader*> Shard(int64_t shard_index);

  Result<ImageRecord> ReadImage(int64_t image_id);
  Result<std::vector<InstanceRecord>> Instances(int64_t image_id);
  // Every present image in id order, with its instances.
  Status ForEachImage(const std::function<Status(const ImageRecord&, const std::vector<InstanceRecord>&)>& fn);

  struct Occurrence {
    int64_t shard_index = 0, image_id = 0, instances = 0;
  };
  Result<std::vector<Occurrence>> OccurrencesOfModel(std::string_view model_key);
  // Every instance of a model across the dataset (for query sampling).
  Result<std::vector<InstanceRecord>> InstancesOfModel(std::string_view model_key);
  Result<std::vector<QueryViewRecord>> QueryViews(std::string_view model_key);

 private:
  struct Impl;
  explicit Dataset(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace solid
