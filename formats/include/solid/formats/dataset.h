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

inline constexpr int kDatasetFormatVersion = 1;

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
  static Result<Manifest> Parse(std::string_view text, std::string_view name);
};

// Why two manifests describe different datasets (seed, params, sizes...), or empty when
// they describe the same one. Generator versions are compared: mixing versions in one
// dataset would break its determinism.
std::string ManifestDifference(const Manifest& a, const Manifest& b);

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

// The ScaleClassAreaScale of the dataset a target shard file lies in (its manifest two
// folders up), or 1 when it lies in none: what a shard read alone is classed with.
double ScaleClassAreaScaleOfShard(const std::filesystem::path& shard);

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
