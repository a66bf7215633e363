// Full consistency check of a dataset or of one shard file. Never stops at the
// first problem and never crashes on damaged files: every problem is reported
// with its location (file, table, row id, field).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/dataset.h"
#include "solid/formats/progress.h"

namespace solid {

struct ValidationProblem {
  std::string location;  // "shards/shard-000001.sqlite: instances row 17 (image 42 #3): visible_w"
  std::string message;
};

struct ValidationReport {
  std::vector<ValidationProblem> problems;
  int64_t problems_not_listed = 0;  // beyond ValidateOptions::max_problems
  int64_t shards = 0, query_shards = 0, images = 0, instances = 0, query_views = 0;

  bool ok() const { return problems.empty() && problems_not_listed == 0; }
  nlohmann::json ToJson() const;
  // One line per problem, then "OK: ..." or "FAILED: ..." with the counts checked.
  std::string ToText() const;
};

struct ValidateOptions {
  // For Validate: a dataset directory or a target or query shard file. (ValidateDataset
  // and the shard-level calls below take theirs as an argument and ignore this.)
  std::filesystem::path path;
  bool decode_images = true;  // decode every PNG/JPEG/WebP/EXR and compare its size
  size_t max_problems = 1000;  // 1 to kMaxListedProblems
  ProgressCallback progress;  // in shard files
};
inline constexpr size_t kMaxListedProblems = size_t{1} << 20;

// `solid validate`: ValidateShardFile when options.path is a regular file, ValidateDataset
// otherwise. kNotFound when nothing is at the path; kInvalidArgument for `path` (empty) or
// `max_problems` (out of range). Problems found are the report's, not an error.
Result<ValidationReport> Validate(const ValidateOptions& options);

// Checks: the manifest against its schema; every shard's schema version, SQLite
// integrity, blob and row checksums (every stored value), content checksum (every row)
// and value ranges; that each shard's provenance is the manifest's and names its file's
// shard; that image ids belong to their shard;
// that every RLE decodes with runs summing to h*w; that stored boxes, areas,
// occlusion and scale class equal those of the masks; that the full mask contains the
// visible one; that images decode to their stored size; query view counts; that
// every instanced model has query views once query shards exist; and that
// index.sqlite agrees with the shards.
ValidationReport ValidateDataset(const std::filesystem::path& root, const ValidateOptions& options = {});

// The same checks for a single target or query shard file, without dataset context: its
// rows against its own provenance (and the shard number its file name gives).
ValidationReport ValidateShardFile(const std::filesystem::path& path, const ValidateOptions& options = {});

// What ValidateDataset checks of target (or, with `query`, query) shard `shard_index` at
// `path`: ValidateShardFile's checks, and that its provenance is the manifest's.
ValidationReport ValidateShardOfDataset(const std::filesystem::path& path, const Manifest& manifest, bool query,
                                        int64_t shard_index, const ValidateOptions& options = {});

}  // namespace solid
