// index.sqlite (schemas/index.sql): derived from the shards present, so that
// lookups by model and dataset-wide metrics need no scan. It is only a cache:
// BuildIndex rewrites it whole, atomically, from whatever complete shards exist
// (unpublished temporaries of running writers are ignored).
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/metrics.h"
#include "solid/formats/progress.h"
#include "solid/formats/status.h"

namespace solid {

struct IndexReport {
  int64_t shards = 0, query_shards = 0, images = 0, instances = 0, models = 0, query_views = 0;
  ProxyMetrics metrics;
  // Shards not indexed, with the reason: unreadable, damaged (a checksum fails), not this
  // dataset's (provenance, image ids outside the shard's range), or not a regular file.
  std::vector<Status> skipped;
  // Target shards of the manifest with no published file (not rendered yet, or being
  // rendered), as inclusive ranges: an index made while renders run covers the complete
  // shards only.
  std::vector<std::pair<int64_t, int64_t>> missing_shards;
  // What IndexOptions::adopt found (AdoptReport::Summary), when it rebuilt the manifest.
  std::string adopted;

  // Every shard present was indexed.
  bool ok() const { return skipped.empty(); }
  nlohmann::json ToJson() const;
};

Result<IndexReport> BuildIndex(const std::filesystem::path& dataset_root, const ProgressCallback& progress = {});

struct IndexOptions {
  std::filesystem::path dataset;
  // When dataset has no manifest.json: rebuild it from the shards' provenance first
  // (AdoptManifest), if they all agree.
  bool adopt = false;
  ProgressCallback progress;  // in shard files
};

// `solid index`: the adoption, then BuildIndex. kInvalidArgument for `dataset` when empty;
// BuildIndex's and AdoptManifest's errors otherwise. Shards skipped are the report's.
Result<IndexReport> Index(const IndexOptions& options);

// Compares index.sqlite with what BuildIndex would write now. Returns one message per
// disagreement ("index.sqlite: shards row 3: bytes 1200 vs 1300 in the shard"), empty
// when they agree. kNotFound when there is no index.
Result<std::vector<std::string>> CompareIndex(const std::filesystem::path& dataset_root);

}  // namespace solid
