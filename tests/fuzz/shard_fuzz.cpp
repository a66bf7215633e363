// libFuzzer target for target shards (shards/shard-NNNNNN.sqlite) and query shards
// (queries/queries-NNNNNN.sqlite): the mutated bytes are written to a file of this process
// and read through our readers the way `solid validate`, `solid index`, `solid inspect` and
// the exporters do: ValidateShardFile (schema, integrity, every record with its checksum,
// every RLE decoded and compared with the stored boxes and areas, every image and depth
// map decoded), plus the reader calls validation does not make. Built twice: shard_fuzz
// and, with SOLID_FUZZ_QUERY_SHARD, query_shard_fuzz (each with its own seed corpus).
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "fuzz/fuzz_util.h"
#include "solid/formats/metrics.h"
#include "solid/formats/shard.h"
#include "solid/formats/validate.h"

using solid::fuzz::Fail;

namespace {

#ifdef SOLID_FUZZ_QUERY_SHARD
constexpr bool kQueryShard = true;
#else
constexpr bool kQueryShard = false;
#endif

void ReadTargetShard(const std::filesystem::path& path) {
  solid::Result<solid::ShardReader> reader = solid::ShardReader::Open(path);
  if (!reader.ok()) return;
  (void)reader->Meta();
  (void)reader->Summarize();
  solid::MetricsAccumulator metrics;
  if (reader->AddToMetrics(metrics).ok()) (void)metrics.Finish();
  std::vector<std::string> models;
  (void)reader->ForEachInstance(
      [&](const solid::InstanceRecord& in) {
        models.push_back(in.model_key);
        return solid::Status::Ok();
      },
      solid::ChecksumPolicy::kSkip);
  for (const std::string& key : models) {
    solid::Result<std::vector<solid::InstanceRecord>> instances = reader->InstancesOfModel(key);
    if (instances.ok()) {
      for (const solid::InstanceRecord& in : *instances) {
        if (in.model_key != key) Fail("InstancesOfModel returned another model's instance");
      }
    }
  }
}

void ReadQueryShard(const std::filesystem::path& path) {
  solid::Result<solid::QueryShardReader> reader = solid::QueryShardReader::Open(path);
  if (!reader.ok()) return;
  (void)reader->Meta();
  (void)reader->ForEachView([](const solid::QueryViewRecord&) { return solid::Status::Ok(); },
                            solid::ChecksumPolicy::kSkip);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::filesystem::path path =
      solid::fuzz::ScratchDir() / (kQueryShard ? solid::QueryShardFileName(0) : solid::TargetShardFileName(0));
  solid::fuzz::RemoveSqliteFiles(path);
  solid::fuzz::WriteFileOrDie(path, std::span<const uint8_t>(data, size));
  const solid::ValidationReport report = solid::ValidateShardFile(path);
  if (report.problems.size() > solid::ValidateOptions{}.max_problems) Fail("validation listed too many problems");
  if (kQueryShard) {
    ReadQueryShard(path);
  } else {
    ReadTargetShard(path);
  }
  solid::fuzz::RemoveSqliteFiles(path);
  return 0;
}
