// Shards: one SQLite file of target images and instances (shards/shard-NNNNNN.sqlite)
// or of query views (queries/queries-NNNNNN.sqlite). Layout: schemas/shard.sql and
// schemas/queries.sql.
//
// Writers publish atomically: everything goes into "<file>.tmp-<host>-<pid>-<n>" in
// one transaction; Commit() syncs and renames it into place. Until then the
// shard is absent; a writer destroyed or killed before Commit() leaves nothing
// a reader or the next writer trusts (stale temporaries of dead writers are
// removed by the next writer of the same shard).
//
// Readers treat the file as untrusted: read-only, SQLite's defensive mode, the
// schema compared with the embedded DDL, and every value checked (types,
// ranges, checksums) before it is returned. Every row read is checked against
// its row_xxh64 (all of its values), whatever the ChecksumPolicy, which only
// decides whether blob bytes are hashed too. Objects are not thread-safe; use
// one per thread.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "solid/formats/records.h"
#include "solid/formats/status.h"

namespace solid {

// "shard-000017.sqlite", "queries-000003.sqlite"
std::string TargetShardFileName(int64_t shard_index);
std::string QueryShardFileName(int64_t shard_index);
// Inverse of the above: the index, or kInvalidArgument for any other name.
Result<int64_t> ParseTargetShardFileName(std::string_view file_name);
Result<int64_t> ParseQueryShardFileName(std::string_view file_name);

struct ShardWriteOptions {
  bool replace_existing = false;  // otherwise Create and Commit fail with kAlreadyExists
};

class ShardWriter {
 public:
  static Result<ShardWriter> Create(const std::filesystem::path& path, const ShardWriteOptions& options = {});
  ShardWriter(ShardWriter&&) noexcept;
  ShardWriter& operator=(ShardWriter&&) noexcept;
  ~ShardWriter();  // abandons an uncommitted shard: removes the temporary file

  // Provenance (formats/dataset.h WriteProvenance) and bookkeeping (stage timings...).
  // "content_xxh64" is the writer's own: Commit() sets it over every row.
  Status SetMeta(std::string_view key, std::string_view value);
  // Checksums are computed here. Instances must reference an image added before.
  Status AddImage(const ImageRecord& image);
  Status AddInstance(const InstanceRecord& instance);
  // Publishes the shard. After an error the shard is absent and the writer spent.
  Status Commit();

  const std::filesystem::path& path() const;

 private:
  struct Impl;
  explicit ShardWriter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

class QueryShardWriter {
 public:
  static Result<QueryShardWriter> Create(const std::filesystem::path& path, const ShardWriteOptions& options = {});
  QueryShardWriter(QueryShardWriter&&) noexcept;
  QueryShardWriter& operator=(QueryShardWriter&&) noexcept;
  ~QueryShardWriter();

  Status SetMeta(std::string_view key, std::string_view value);
  // A model's row first, then its views (view_count must equal the views added).
  Status AddModel(const QueryModelRecord& model);
  Status AddView(const QueryViewRecord& view);
  Status Commit();

  const std::filesystem::path& path() const;

 private:
  struct Impl;
  explicit QueryShardWriter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

struct ShardCounts {
  int64_t images = 0;
  int64_t instances = 0;
  int64_t first_image_id = -1, last_image_id = -1;  // -1 when empty
};

struct ShardSummary {
  ShardCounts counts;
  int64_t image_bytes = 0, depth_images = 0, depth_bytes = 0, rle_bytes = 0;
  int64_t visible_instances = 0, distinct_models = 0;
};

class MetricsAccumulator;

// What readers do with blob checksums. kVerify costs one XXH64 pass (GB/s).
enum class ChecksumPolicy { kVerify, kSkip };

class ShardReader {
 public:
  static Result<ShardReader> Open(const std::filesystem::path& path);
  ShardReader(ShardReader&&) noexcept;
  ShardReader& operator=(ShardReader&&) noexcept;
  ~ShardReader();

  const std::filesystem::path& path() const;
  Result<std::vector<std::pair<std::string, std::string>>> Meta();
  // Walks every row of every table: its row_xxh64, with kVerify its blob checksums, and
  // content_xxh64 over all rows (so a row added or removed is found too). kCorrupt naming
  // the first row that disagrees.
  Status VerifyContent(ChecksumPolicy policy = ChecksumPolicy::kVerify);
  Result<ShardCounts> Counts();

  // Sizes and counts from aggregate queries (no blob is read).
  Result<ShardSummary> Summarize();

  // Adds the shard's rows to `metrics`: every image (in id order) and each of its visible
  // instances, from the stored areas. No blob is read. Every reader of a dataset's metrics
  // (inspect, index, report, DatasetMetrics) adds its shards so, in shard order, to one
  // accumulator of the manifest's area scale: they agree to the last bit, with each other
  // and with the optimizer's evaluation of the same layouts. On error some rows may have
  // been added: a caller that skips a damaged shard adds it to a copy first.
  Status AddToMetrics(MetricsAccumulator& metrics);

  // Image ids in ascending order.
  Result<std::vector<int64_t>> ImageIds();
  Result<ImageRecord> ReadImage(int64_t image_id, ChecksumPolicy policy = ChecksumPolicy::kVerify);
  Result<std::vector<InstanceRecord>> InstancesOfImage(int64_t image_id,
                                                       ChecksumPolicy policy = ChecksumPolicy::kVerify);
  Result<std::vector<InstanceRecord>> InstancesOfModel(std::string_view model_key,
                                                       ChecksumPolicy policy = ChecksumPolicy::kVerify);
  // Streams every instance in (image_id, ordinal) order; the callback may stop
  // the walk by returning a non-OK Status, which is returned.
  Status ForEachInstance(const std::function<Status(const InstanceRecord&)>& fn,
                         ChecksumPolicy policy = ChecksumPolicy::kVerify);

 private:
  struct Impl;
  explicit ShardReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

class QueryShardReader {
 public:
  static Result<QueryShardReader> Open(const std::filesystem::path& path);
  QueryShardReader(QueryShardReader&&) noexcept;
  QueryShardReader& operator=(QueryShardReader&&) noexcept;
  ~QueryShardReader();

  const std::filesystem::path& path() const;
  Result<std::vector<std::pair<std::string, std::string>>> Meta();
  // As ShardReader::VerifyContent.
  Status VerifyContent(ChecksumPolicy policy = ChecksumPolicy::kVerify);
  Result<std::vector<QueryModelRecord>> Models();
  Result<std::vector<QueryViewRecord>> ViewsOfModel(std::string_view model_key,
                                                    ChecksumPolicy policy = ChecksumPolicy::kVerify);
  Status ForEachView(const std::function<Status(const QueryViewRecord&)>& fn,
                     ChecksumPolicy policy = ChecksumPolicy::kVerify);

 private:
  struct Impl;
  explicit QueryShardReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace solid
