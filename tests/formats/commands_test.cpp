// The calls behind inspect, validate and index (one options struct in, one report out), and
// the streaming atomic writer: what the CLI used to decide is the library's now.
#include <gtest/gtest.h>

#include <fstream>

#include "fixtures/layered_dataset.h"
#include "formats/test_util.h"
#include "solid/formats/dataset.h"
#include "solid/formats/files.h"
#include "solid/formats/index.h"
#include "solid/formats/inspect.h"
#include "solid/formats/validate.h"

namespace solid {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

TEST(Calls, OptionErrorsNameTheirField) {
  EXPECT_EQ(Inspect({}).status().option(), "path");
  EXPECT_EQ(Validate({}).status().option(), "path");
  EXPECT_EQ(Index({}).status().option(), "dataset");
  TempDir dir;
  ValidateOptions v;
  v.path = dir.path();
  v.max_problems = 0;
  const Status refused = Validate(v).status();
  EXPECT_EQ(refused.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(refused.option(), "max_problems");
  EXPECT_TRUE(refused.message().starts_with("max_problems: 0 is not in [1, 1048576]")) << refused.message();
}

TEST(Calls, ValidateTellsAShardFileFromADatasetAndAMissingPath) {
  TempDir dir;
  fixtures::LayeredDatasetOptions layered;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path() / "d", layered));
  ValidateOptions o;
  o.path = dir.path() / "missing";
  const Status missing = Validate(o).status();
  EXPECT_EQ(missing.code(), StatusCode::kNotFound);
  EXPECT_NE(missing.message().find("no such dataset directory or shard file"), std::string::npos);

  o.path = dir.path() / "d";
  Result<ValidationReport> whole = Validate(o);
  ASSERT_OK(whole.status());
  EXPECT_TRUE(whole->ok()) << whole->ToText();
  EXPECT_EQ(whole->images, layered.images);

  o.path = DatasetPaths(dir.path() / "d").shard(0);
  Result<ValidationReport> shard = Validate(o);
  ASSERT_OK(shard.status());
  EXPECT_TRUE(shard->ok()) << shard->ToText();
  EXPECT_EQ(shard->shards, 1);
  EXPECT_LT(shard->images, whole->images);
  EXPECT_NE(shard->ToText().find("OK: 1 shards"), std::string::npos) << shard->ToText();
}

TEST(Calls, IndexAdoptsAManifestOnlyWhenAsked) {
  TempDir dir;
  fixtures::LayeredDatasetOptions layered;
  const fs::path root = dir.path() / "d";
  ASSERT_OK(fixtures::WriteLayeredDataset(root, layered));
  fs::remove(DatasetPaths(root).manifest());
  IndexOptions o;
  o.dataset = root;
  const Status refused = Index(o).status();
  EXPECT_EQ(refused.code(), StatusCode::kNotFound);
  EXPECT_NE(refused.message().find("adopting the shards (AdoptManifest)"), std::string::npos) << refused.message();

  o.adopt = true;
  Result<IndexReport> adopted = Index(o);
  ASSERT_OK(adopted.status());
  EXPECT_NE(adopted->adopted.find("adopted the provenance of"), std::string::npos) << adopted->adopted;
  EXPECT_TRUE(adopted->ok());
  EXPECT_EQ(adopted->ToJson()["images"], layered.images);
  EXPECT_TRUE(fs::exists(DatasetPaths(root).manifest()));

  // With a manifest, adopt changes nothing.
  Result<IndexReport> again = Index(o);
  ASSERT_OK(again.status());
  EXPECT_EQ(again->adopted, "");
  EXPECT_FALSE(again->ToJson().contains("adopted"));
}

TEST(Calls, IndexReportsMissingShards) {
  TempDir dir;
  fixtures::LayeredDatasetOptions layered;
  const fs::path root = dir.path() / "d";
  ASSERT_OK(fixtures::WriteLayeredDataset(root, layered));
  fs::remove(DatasetPaths(root).shard(1));
  Result<IndexReport> report = Index({.dataset = root});
  ASSERT_OK(report.status());
  EXPECT_TRUE(report->ok());
  ASSERT_EQ(report->missing_shards.size(), 1u);
  EXPECT_EQ(report->missing_shards[0], std::make_pair(int64_t{1}, int64_t{1}));
  EXPECT_EQ(report->ToJson()["missing_shards"], nlohmann::json::parse("[[1, 1]]"));
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

bool HasTemporary(const fs::path& dir) {
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (files::IsTempPath(entry.path())) return true;
  }
  return false;
}

TEST(AtomicFileWriter, PublishesOnCommitOnlyAndLeavesNoTemporary) {
  TempDir dir;
  const fs::path path = dir.path() / "out.json";
  { std::ofstream(path) << "old"; }
  {
    Result<files::AtomicFileWriter> w = files::AtomicFileWriter::Create(path);
    ASSERT_OK(w.status());
    ASSERT_OK(w->Write("half"));
    EXPECT_TRUE(HasTemporary(dir.path()));
  }  // dropped uncommitted
  EXPECT_EQ(ReadText(path), "old");
  EXPECT_FALSE(HasTemporary(dir.path()));

  Result<files::AtomicFileWriter> w = files::AtomicFileWriter::Create(path);
  ASSERT_OK(w.status());
  const std::string big((1 << 20) + 7, 'x');  // past the buffer: written through
  ASSERT_OK(w->Write("a"));
  ASSERT_OK(w->Write(big));
  ASSERT_OK(w->Write("b"));
  EXPECT_EQ(ReadText(path), "old");
  ASSERT_OK(w->Commit());
  EXPECT_EQ(ReadText(path), "a" + big + "b");
  EXPECT_FALSE(HasTemporary(dir.path()));
  EXPECT_EQ(w->Write("more").code(), StatusCode::kInternal) << "a committed writer writes nothing more";
}

TEST(AtomicFileWriter, AMissingDirectoryNamesTheFinalPath) {
  TempDir dir;
  const fs::path path = dir.path() / "gone" / "out.json";
  const Status s = files::AtomicFileWriter::Create(path).status();
  EXPECT_EQ(s.code(), StatusCode::kIoError);
  EXPECT_NE(s.message().find(path.string() + ": create a temporary sibling"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace solid
