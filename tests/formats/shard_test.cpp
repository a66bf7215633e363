#include "solid/formats/shard.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <fstream>

#include "fixtures/layered_dataset.h"
#include "formats/test_util.h"
#include "solid/formats/dataset.h"

namespace solid {
namespace {

namespace fs = std::filesystem;
using fixtures::LayeredDatasetOptions;
using testing::TempDir;

void ExpectSameImage(const ImageRecord& a, const ImageRecord& b) {
  EXPECT_EQ(a.image_id, b.image_id);
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.format, b.format);
  EXPECT_EQ(a.image, b.image);
  EXPECT_EQ(a.camera.fx, b.camera.fx);
  EXPECT_EQ(a.camera.cy, b.camera.cy);
  EXPECT_EQ(a.camera.world_from_camera, b.camera.world_from_camera);
  EXPECT_EQ(a.depth_exr, b.depth_exr);
  EXPECT_EQ(a.room_key, b.room_key);
}

void ExpectSameInstance(const InstanceRecord& a, const InstanceRecord& b) {
  EXPECT_EQ(a.image_id, b.image_id);
  EXPECT_EQ(a.ordinal, b.ordinal);
  EXPECT_EQ(a.model_key, b.model_key);
  EXPECT_EQ(a.visible_rle, b.visible_rle);
  EXPECT_EQ(a.full_rle, b.full_rle);
  EXPECT_EQ(a.visible_box, b.visible_box);
  EXPECT_EQ(a.full_box, b.full_box);
  EXPECT_EQ(a.visible_area, b.visible_area);
  EXPECT_EQ(a.full_area, b.full_area);
  EXPECT_EQ(a.occlusion, b.occlusion);
  EXPECT_EQ(a.truncation, b.truncation);
  EXPECT_EQ(a.scale_class, b.scale_class);
  EXPECT_EQ(a.world_from_object, b.world_from_object);
  EXPECT_EQ(a.object_scale, b.object_scale);
  EXPECT_EQ(a.camera_distance, b.camera_distance);
  EXPECT_EQ(a.view_azimuth, b.view_azimuth);
  EXPECT_EQ(a.view_elevation, b.view_elevation);
}

TEST(ShardWriter, RoundTripsEveryField) {
  TempDir dir;
  LayeredDatasetOptions options;
  options.depth = true;
  fs::path path = dir.path() / "shard-000000.sqlite";
  std::vector<fixtures::LayeredImage> written;
  {
    auto writer = ShardWriter::Create(path);
    ASSERT_OK(writer.status());
    ASSERT_OK(writer->SetMeta("params_hash", "abc"));
    for (int64_t id = 0; id < 4; ++id) {
      auto image = fixtures::MakeLayeredImage(options, id);
      ASSERT_OK(image.status());
      image->image.room_key = id % 2 ? std::optional<std::string>("rooms/kitchen") : std::nullopt;
      ASSERT_OK(writer->AddImage(image->image));
      for (const auto& in : image->instances) ASSERT_OK(writer->AddInstance(in));
      written.push_back(std::move(image).value());
    }
    EXPECT_FALSE(fs::exists(path)) << "a shard must not be visible before Commit";
    ASSERT_OK(writer->Commit());
  }
  auto reader = ShardReader::Open(path);
  ASSERT_OK(reader.status());
  auto ids = reader->ImageIds();
  ASSERT_OK(ids.status());
  EXPECT_EQ(*ids, (std::vector<int64_t>{0, 1, 2, 3}));
  for (const auto& w : written) {
    auto image = reader->ReadImage(w.image.image_id);
    ASSERT_OK(image.status());
    ExpectSameImage(*image, w.image);
    auto instances = reader->InstancesOfImage(w.image.image_id);
    ASSERT_OK(instances.status());
    ASSERT_EQ(instances->size(), w.instances.size());
    for (size_t i = 0; i < w.instances.size(); ++i) ExpectSameInstance((*instances)[i], w.instances[i]);
  }
  auto meta = reader->Meta();
  ASSERT_OK(meta.status());
  EXPECT_EQ(*meta, (std::vector<std::pair<std::string, std::string>>{{"params_hash", "abc"}}));
  auto of_model = reader->InstancesOfModel("fixture/model-00");
  ASSERT_OK(of_model.status());
  size_t expected = 0;
  for (const auto& w : written) {
    for (const auto& in : w.instances) expected += in.model_key == "fixture/model-00";
  }
  EXPECT_EQ(of_model->size(), expected);
}

TEST(ShardWriter, AbandonedWriterLeavesNothing) {
  TempDir dir;
  fs::path path = dir.path() / "shard-000000.sqlite";
  {
    auto writer = ShardWriter::Create(path);
    ASSERT_OK(writer.status());
    auto image = fixtures::MakeLayeredImage({}, 0);
    ASSERT_OK(image.status());
    ASSERT_OK(writer->AddImage(image->image));
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(ShardWriter, RefusesToOverwriteACompleteShard) {
  TempDir dir;
  fs::path path = dir.path() / "shard-000000.sqlite";
  ASSERT_OK(ShardWriter::Create(path)->Commit());
  auto again = ShardWriter::Create(path);
  EXPECT_EQ(again.status().code(), StatusCode::kAlreadyExists);
  ShardWriteOptions replace;
  replace.replace_existing = true;
  auto replacing = ShardWriter::Create(path, replace);
  ASSERT_OK(replacing.status());
  ASSERT_OK(replacing->Commit());
}

TEST(ShardWriter, SecondWriterOfTheSameShardLosesAtCommit) {
  TempDir dir;
  fs::path path = dir.path() / "shard-000000.sqlite";
  auto first = ShardWriter::Create(path);
  auto second = ShardWriter::Create(path);
  ASSERT_OK(first.status());
  ASSERT_OK(second.status());
  ASSERT_OK(first->Commit());
  EXPECT_EQ(second->Commit().code(), StatusCode::kAlreadyExists);
}

TEST(ShardWriter, RejectsInstancesOfUnknownImagesAndNonFiniteValues) {
  TempDir dir;
  auto writer = ShardWriter::Create(dir.path() / "shard-000000.sqlite");
  ASSERT_OK(writer.status());
  auto image = fixtures::MakeLayeredImage({}, 0);
  ASSERT_OK(image.status());
  InstanceRecord orphan = image->instances[0];
  orphan.image_id = 99;
  EXPECT_FALSE(writer->AddInstance(orphan).ok());
  ASSERT_OK(writer->AddImage(image->image));
  InstanceRecord nan = image->instances[0];
  nan.camera_distance = std::nan("");
  Status s = writer->AddInstance(nan);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("image 0 instance 0"), std::string::npos) << s.message();
}

// The writer dies by SIGKILL half-way through a shard: no partial shard may be
// visible, and the next writer of the same shard succeeds and cleans up.
TEST(ShardWriter, KilledWriterLeavesNoPartialShard) {
  for (int kill_after : {0, 1, 2, 3}) {
    TempDir dir;
    LayeredDatasetOptions options;
    ASSERT_OK(CreateDataset(dir.path(), fixtures::LayeredManifest(options)));
    pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      Status s = fixtures::WriteLayeredShard(dir.path(), options, 0, [&](int64_t id) {
        if (id == kill_after) raise(SIGKILL);
      });
      _exit(s.ok() ? 0 : 1);
    }
    int wstatus = 0;
    ASSERT_EQ(waitpid(pid, &wstatus, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(wstatus) && WTERMSIG(wstatus) == SIGKILL);
    DatasetPaths paths(dir.path());
    EXPECT_FALSE(fs::exists(paths.shard(0))) << "kill after image " << kill_after;
    auto listing = ListShards(dir.path());
    ASSERT_OK(listing.status());
    EXPECT_TRUE(listing->targets.empty());
    EXPECT_TRUE(listing->unexpected.empty());
    // The dead writer's temporary is still there, and the next writer removes it.
    size_t temps = 0;
    for (const auto& e : fs::directory_iterator(paths.shards_dir())) temps += e.path().string().find(".tmp-") != std::string::npos;
    EXPECT_EQ(temps, 1u);
    ASSERT_OK(fixtures::WriteLayeredShard(dir.path(), options, 0));
    temps = 0;
    for (const auto& e : fs::directory_iterator(paths.shards_dir())) temps += e.path().string().find(".tmp-") != std::string::npos;
    EXPECT_EQ(temps, 0u);
    auto reader = ShardReader::Open(paths.shard(0));
    ASSERT_OK(reader.status());
    auto counts = reader->Counts();
    ASSERT_OK(counts.status());
    EXPECT_EQ(counts->images, options.shard_size);
  }
}

TEST(QueryShardWriter, RoundTripsAndChecksViewCounts) {
  TempDir dir;
  fs::path path = dir.path() / "queries-000000.sqlite";
  QueryViewRecord view;
  view.model_key = "a/b";
  view.view_index = 3;
  view.azimuth = 0.75;
  view.width = 4;
  view.height = 2;
  view.image = {1, 2, 3};
  view.box = {0, 0, 4, 2};
  {
    auto writer = QueryShardWriter::Create(path);
    ASSERT_OK(writer.status());
    ASSERT_OK(writer->AddModel({"a/b", 2, std::nullopt}));
    ASSERT_OK(writer->AddView(view));
    Status s = writer->Commit();
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << "view_count 2 with 1 view must not commit";
  }
  EXPECT_FALSE(fs::exists(path));
  {
    auto writer = QueryShardWriter::Create(path);
    ASSERT_OK(writer.status());
    ASSERT_OK(writer->AddModel({"a/b", 1, std::nullopt}));
    ASSERT_OK(writer->AddModel({"c/d", 0, std::string("empty mask in view 0")}));
    ASSERT_OK(writer->AddView(view));
    ASSERT_OK(writer->Commit());
  }
  auto reader = QueryShardReader::Open(path);
  ASSERT_OK(reader.status());
  auto models = reader->Models();
  ASSERT_OK(models.status());
  ASSERT_EQ(models->size(), 2u);
  EXPECT_EQ((*models)[1].failure, std::optional<std::string>("empty mask in view 0"));
  auto views = reader->ViewsOfModel("a/b");
  ASSERT_OK(views.status());
  ASSERT_EQ(views->size(), 1u);
  EXPECT_EQ((*views)[0].image, view.image);
  EXPECT_EQ((*views)[0].azimuth, 0.75);
  EXPECT_EQ((*views)[0].box, view.box);
}

TEST(ShardReader, RefusesForeignFiles) {
  TempDir dir;
  fs::path not_sqlite = dir.path() / "shard-000000.sqlite";
  { std::ofstream(not_sqlite) << "hello, not a database\n"; }
  EXPECT_FALSE(ShardReader::Open(not_sqlite).ok());
  // A query shard is not a target shard.
  fs::path queries = dir.path() / "queries-000000.sqlite";
  ASSERT_OK(QueryShardWriter::Create(queries)->Commit());
  auto wrong_kind = ShardReader::Open(queries);
  EXPECT_EQ(wrong_kind.status().code(), StatusCode::kCorrupt);
  EXPECT_NE(wrong_kind.status().message().find("application_id"), std::string::npos);
  EXPECT_EQ(ShardReader::Open(dir.path() / "missing.sqlite").status().code(), StatusCode::kNotFound);
}

TEST(ShardFileNames, RoundTrip) {
  EXPECT_EQ(TargetShardFileName(17), "shard-000017.sqlite");
  EXPECT_EQ(QueryShardFileName(3), "queries-000003.sqlite");
  EXPECT_EQ(*ParseTargetShardFileName("shard-000017.sqlite"), 17);
  EXPECT_EQ(*ParseTargetShardFileName("shard-1234567.sqlite"), 1234567);
  EXPECT_FALSE(ParseTargetShardFileName("shard-17.sqlite").ok());
  EXPECT_FALSE(ParseTargetShardFileName("shard-00001x.sqlite").ok());
  EXPECT_FALSE(ParseTargetShardFileName("shard-+00001.sqlite").ok());
  EXPECT_FALSE(ParseQueryShardFileName("shard-000001.sqlite").ok());
}

}  // namespace
}  // namespace solid
