// Issue 23, formats side: a dataset holds only its own data. Every shard says what it was
// made from (its provenance, under its checksums), validate and index compare that with
// the manifest, and every stored value is checksummed, so that the shard alone reveals a
// change of its data.
#include <gtest/gtest.h>

#include <sqlite3.h>

#include <fstream>
#include <optional>
#include <random>

#include "fixtures/layered_dataset.h"
#include "formats/test_util.h"
#include "solid/formats/dataset.h"
#include "solid/formats/index.h"
#include "solid/formats/shard.h"
#include "solid/formats/validate.h"

namespace solid {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

fixtures::LayeredDatasetOptions SixImages(uint64_t seed) {
  fixtures::LayeredDatasetOptions o;
  o.seed = seed;
  o.images = 6;
  o.shard_size = 3;
  o.width = 64;
  o.height = 48;
  return o;
}

bool Mentions(const ValidationReport& report, std::string_view a, std::string_view b) {
  for (const ValidationProblem& p : report.problems) {
    const std::string text = p.location + ": " + p.message;
    if (text.find(a) != std::string::npos && text.find(b) != std::string::npos) return true;
  }
  return false;
}

std::string Problems(const ValidationReport& report) { return report.ToJson().dump(2); }

bool Skipped(const IndexReport& report, std::string_view a, std::string_view b) {
  for (const Status& s : report.skipped) {
    if (s.message().find(a) != std::string::npos && s.message().find(b) != std::string::npos) return true;
  }
  return false;
}

void Sql(const fs::path& file, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  char* error = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error);
  const std::string message = error ? error : "";
  sqlite3_free(error);
  sqlite3_close(db);
  ASSERT_EQ(rc, SQLITE_OK) << message;
}

class Provenance : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_OK(fixtures::WriteLayeredDataset(ours_, SixImages(1)));
    ASSERT_OK(fixtures::WriteLayeredDataset(theirs_, SixImages(2)));
    ASSERT_TRUE(ValidateDataset(ours_).ok());
  }

  TempDir dir_;
  const fs::path ours_ = dir_.path() / "seed1", theirs_ = dir_.path() / "seed2";
};

// The F1: a seed-2 shard copied into a seed-1 dataset, then `solid index`, validated.
TEST_F(Provenance, F1_AShardOfAnotherDatasetIsNeitherIndexedNorValidated) {
  fs::copy_file(DatasetPaths(theirs_).shard(1), DatasetPaths(ours_).shard(1), fs::copy_options::overwrite_existing);
  const Result<IndexReport> index = BuildIndex(ours_);
  ASSERT_OK(index.status());
  EXPECT_EQ(index->shards, 1);
  EXPECT_TRUE(Skipped(*index, "shard-000001.sqlite: provenance: seed 0x0000000000000002 in the shard", "in the manifest"))
      << (index->skipped.empty() ? "nothing skipped" : index->skipped[0].message());
  const ValidationReport report = ValidateDataset(ours_);
  EXPECT_TRUE(Mentions(report, "shard-000001.sqlite: provenance", "seed 0x0000000000000002 in the shard, "
                                                                   "0x0000000000000001 in the manifest"))
      << Problems(report);
}

TEST_F(Provenance, F1_AdoptRebuildsALostManifestOnlyFromShardsThatAgree) {
  const Manifest original = ReadManifest(ours_).value();
  fs::remove(DatasetPaths(ours_).manifest());
  const Result<AdoptReport> adopted = AdoptManifest(ours_);
  ASSERT_OK(adopted.status());
  EXPECT_EQ(adopted->target_shards, 2);
  EXPECT_EQ(adopted->query_shards, 1);
  EXPECT_EQ(ManifestDifference(ReadManifest(ours_).value(), original), "");
  EXPECT_NE(adopted->Summary(ours_).find("seed 0x0000000000000001, 6 images in shards of 3"), std::string::npos)
      << adopted->Summary(ours_);
  EXPECT_TRUE(ValidateDataset(ours_).ok());
  EXPECT_EQ(AdoptManifest(ours_).status().code(), StatusCode::kAlreadyExists);

  fs::remove(DatasetPaths(ours_).manifest());
  fs::copy_file(DatasetPaths(theirs_).shard(1), DatasetPaths(ours_).shard(1), fs::copy_options::overwrite_existing);
  const Result<AdoptReport> mixed = AdoptManifest(ours_);
  EXPECT_EQ(mixed.status().code(), StatusCode::kCorrupt);
  EXPECT_NE(mixed.status().message().find("the shards disagree"), std::string::npos) << mixed.status().message();
  EXPECT_NE(mixed.status().message().find("seed 0x0000000000000002 in " + DatasetPaths(ours_).shard(1).string()),
            std::string::npos)
      << mixed.status().message();
  EXPECT_FALSE(fs::exists(DatasetPaths(ours_).manifest()));
}

// The F2: shard 1's file saved as shard 0. `solid index` failed on a UNIQUE
// constraint naming neither the shard nor the cause; it skips and names the shard now.
TEST_F(Provenance, F2_AShardHoldingAnotherShardsRowsIsSkippedAndNamed) {
  fs::copy_file(DatasetPaths(ours_).shard(1), DatasetPaths(ours_).shard(0), fs::copy_options::overwrite_existing);
  fs::remove(DatasetPaths(ours_).index());
  const Result<IndexReport> index = BuildIndex(ours_);
  ASSERT_OK(index.status());
  EXPECT_TRUE(Skipped(*index, "shard-000000.sqlite: provenance", "shard_index 1 in the shard, 0 by its file name"))
      << (index->skipped.empty() ? "nothing skipped" : index->skipped[0].message());
  const ValidationReport alone = ValidateShardFile(DatasetPaths(ours_).shard(0));
  EXPECT_TRUE(Mentions(alone, "shard-000000.sqlite: provenance", "shard_index 1 in the shard, 0 by its file name"))
      << Problems(alone);
  EXPECT_TRUE(Mentions(alone, "image_id", "outside shard 0's range [0, 3)")) << Problems(alone);
}

// Every value of the shard, as SQLite returns it, or nothing when SQLite cannot read it.
std::optional<std::string> Dump(const fs::path& file) {
  sqlite3* db = nullptr;
  std::string out;
  bool ok = sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK;
  for (const char* sql : {"PRAGMA application_id", "PRAGMA user_version", "SELECT type, name, sql FROM sqlite_schema",
                          "SELECT * FROM shard_meta", "SELECT * FROM images", "SELECT * FROM instances"}) {
    sqlite3_stmt* stmt = nullptr;
    ok = ok && sqlite3_prepare_v2(db, sql, -1, &stmt, nullptr) == SQLITE_OK;
    int rc = SQLITE_DONE;
    while (ok && (rc = sqlite3_step(stmt)) == SQLITE_ROW) {
      for (int c = 0; c < sqlite3_column_count(stmt); ++c) {
        const int type = sqlite3_column_type(stmt, c);
        out += std::to_string(type) + ":";
        if (type == SQLITE_FLOAT) {
          out += std::to_string(sqlite3_column_double(stmt, c));
        } else if (type != SQLITE_NULL) {
          const void* bytes = sqlite3_column_blob(stmt, c);
          out.append(static_cast<const char*>(bytes), static_cast<size_t>(sqlite3_column_bytes(stmt, c)));
        }
        out += '|';
      }
      out += '\n';
    }
    ok = ok && rc == SQLITE_DONE;
    sqlite3_finalize(stmt);
  }
  sqlite3_close(db);
  if (!ok) return std::nullopt;
  return out;
}

std::vector<char> ReadAll(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void WriteAll(const fs::path& p, const std::vector<char>& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// The F7: 26 of 180 flips passed a shard validated alone, two of which changed data.
// Now every flip that changes what SQLite returns, or keeps it from reading, is found by
// the shard's own checks.
TEST_F(Provenance, F7_EveryFlipThatChangesDataIsFoundByTheShardAlone) {
  const fs::path shard = DatasetPaths(ours_).shard(1);
  const std::vector<char> pristine = ReadAll(shard);
  const std::optional<std::string> before = Dump(shard);
  ASSERT_TRUE(before.has_value());
  std::mt19937_64 rng(23);
  ValidateOptions options;
  options.decode_images = false;  // the checksums alone must find them
  int changed = 0;
  for (int i = 0; i < 300; ++i) {
    std::vector<char> bytes = pristine;
    const size_t offset = rng() % bytes.size();
    bytes[offset] = static_cast<char>(bytes[offset] ^ static_cast<char>(1 << (rng() % 8)));
    WriteAll(shard, bytes);
    if (Dump(shard) == before) continue;
    ++changed;
    EXPECT_FALSE(ValidateShardFile(shard, options).ok()) << "a flip of bit at byte " << offset << " went unnoticed";
  }
  WriteAll(shard, pristine);
  EXPECT_GT(changed, 10);
}

// The F7 edits: a REAL column and a JSON meta value, changed well-formed, are found
// by the shard alone and by validate after `solid index` rebuilt the whole-file checksums.
TEST_F(Provenance, F7_EditedRealAndJsonValuesAreFoundEvenAfterReindexing) {
  const fs::path shard = DatasetPaths(ours_).shard(1);
  for (const std::string& edit :
       {std::string("UPDATE instances SET view_elevation = view_elevation + 0.5 WHERE instance_id = 1"),
        std::string("UPDATE shard_meta SET value = replace(value, '\"images\":6', '\"images\":7') WHERE key = "
                    "'manifest'"),
        std::string("UPDATE shard_meta SET value = substr(value, 1, 40) WHERE key = 'manifest'"),
        std::string("DELETE FROM instances WHERE instance_id = 2")}) {
    SCOPED_TRACE(edit);
    const std::vector<char> pristine = ReadAll(shard);
    Sql(shard, edit);
    const ValidationReport alone = ValidateShardFile(shard);
    EXPECT_FALSE(alone.ok());
    ASSERT_OK(BuildIndex(ours_).status());
    const ValidationReport dataset = ValidateDataset(ours_);
    EXPECT_TRUE(Mentions(dataset, "shard-000001.sqlite", "")) << Problems(dataset);
    EXPECT_FALSE(dataset.ok());
    WriteAll(shard, pristine);
  }
  ASSERT_OK(BuildIndex(ours_).status());
  EXPECT_TRUE(ValidateDataset(ours_).ok());
}

// The F8: an edited manifest seed was reported as coming "from the shards".
TEST_F(Provenance, F8_AnEditedManifestSeedIsSaidToComeFromTheManifest) {
  Manifest edited = ReadManifest(ours_).value();
  edited.seed = 2;
  ASSERT_OK(CreateDataset(ours_, edited));
  const ValidationReport report = ValidateDataset(ours_);
  EXPECT_TRUE(Mentions(report, "index_meta 'seed': value: 0x0000000000000001 in the index, 0x0000000000000002 from "
                               "the manifest",
                       ""))
      << Problems(report);
  EXPECT_TRUE(Mentions(report, "shard-000000.sqlite: provenance", "seed 0x0000000000000001 in the shard, "
                                                                   "0x0000000000000002 in the manifest"))
      << Problems(report);
  for (const ValidationProblem& p : report.problems) {
    if (p.location.find("index_meta") != std::string::npos) {
      EXPECT_EQ(p.message.find("from the shards"), std::string::npos);
    }
  }
}

// Readers refuse a shard of format version 1 (exit 3 at the CLI) rather than misread it.
TEST(ShardFormat, OtherSchemaVersionsAreRefused) {
  TempDir dir;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path(), SixImages(1)));
  const fs::path shard = DatasetPaths(dir.path()).shard(0);
  Sql(shard, "PRAGMA user_version = 1");
  const Result<ShardReader> reader = ShardReader::Open(shard);
  EXPECT_EQ(reader.status().code(), StatusCode::kUnsupportedVersion);
  EXPECT_NE(reader.status().message().find("schema version 1 (user_version), this build reads 2"), std::string::npos)
      << reader.status().message();
}

}  // namespace
}  // namespace solid
