// Stopping `solid render` and `solid sample` through their cancellation flag, and the
// shard locks that keep two renders of one shard apart, as library calls.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "formats/test_util.h"
#include "render/dataset_digest.h"
#include "render/test_assets.h"
#include "solid/formats/dataset.h"
#include "solid/formats/file_lock.h"
#include "solid/formats/files.h"
#include "solid/formats/validate.h"
#include "solid/render/render_dataset.h"
#include "solid/render/sample.h"

namespace solid::render {
namespace {

namespace fs = std::filesystem;
using solid::testing::TempDir;

std::unique_ptr<LayoutSampler> TinySampler() {
  LayoutParams params = LoadPreset("random-placement").value();
  params.width = 64;
  params.height = 48;
  return LayoutSampler::Create(params, testing::ProceduralLibrary()).value();
}

// 12 images in shards of 3 at 64 x 48, one sample per pixel, no query views.
RenderOptions TinyRender(const fs::path& out) {
  RenderOptions o;
  o.out = out;
  o.seed = 5;
  o.images = 12;
  o.shard_size = 3;
  o.jobs = 2;
  o.shading.samples_per_pixel = 1;
  o.queries = false;
  return o;
}

// Files that are neither published shards nor anything else we keep.
std::vector<fs::path> Leftovers(const fs::path& root) {
  std::vector<fs::path> out;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (files::IsTempPath(e.path()) || files::IsLockPath(e.path())) out.push_back(e.path());
  }
  return out;
}

TEST(RenderCancel, AFlagSetBeforehandRendersNothing) {
  TempDir dir;
  const auto sampler = TinySampler();
  CancelFlag cancel{true};
  RenderOptions options = TinyRender(dir.path());
  options.cancel = &cancel;
  const auto report = RenderDataset(*sampler, options);
  ASSERT_OK(report.status());
  EXPECT_TRUE(report->cancelled);
  EXPECT_EQ(report->shards_rendered, 0);
  EXPECT_EQ(report->shards_missing, (std::vector<int64_t>{0, 1, 2, 3}));
  EXPECT_FALSE(report->index_built);
  EXPECT_TRUE(Leftovers(dir.path()).empty());
}

// The flag is set when the 5th image is done (in shard 1, images 3-5): with no time to
// finish, shard 1 is abandoned; with time, it is finished. Either way the rest resumes
// to the data of an undisturbed run.
TEST(RenderCancel, TheShardInFlightIsAbandonedOrFinishedAndARerunCompletesIt) {
  TempDir dir;
  const auto sampler = TinySampler();
  ASSERT_OK(RenderDataset(*sampler, TinyRender(dir.path() / "reference")).status());
  for (const double finish_seconds : {0.0, 1e9}) {
    SCOPED_TRACE(finish_seconds);
    const fs::path out = dir.path() / fmt::format("stopped-{}", finish_seconds);
    CancelFlag cancel{false};
    RenderOptions options = TinyRender(out);
    options.cancel = &cancel;
    options.finish_shard_seconds = finish_seconds;
    options.progress = [&](int64_t done, int64_t) {
      if (done == 5) cancel = true;
    };
    const auto report = RenderDataset(*sampler, options);
    ASSERT_OK(report.status());
    EXPECT_TRUE(report->cancelled);
    const bool abandoned = finish_seconds == 0;
    EXPECT_EQ(report->abandoned_shard, abandoned ? 1 : -1);
    EXPECT_EQ(report->shards_rendered, abandoned ? 1 : 2);
    EXPECT_EQ(report->images + report->failed_images, abandoned ? 3 : 6);
    EXPECT_EQ(report->shards_missing, abandoned ? (std::vector<int64_t>{1, 2, 3}) : (std::vector<int64_t>{2, 3}));
    EXPECT_TRUE(Leftovers(out).empty());
    const ShardListing listing = ListShards(out).value();
    for (const ShardFile& f : listing.targets) {
      const ValidationReport v = ValidateShardFile(f.path);
      EXPECT_TRUE(v.ok()) << v.ToJson().dump(2);
    }

    const auto rerun = RenderDataset(*sampler, TinyRender(out));
    ASSERT_OK(rerun.status());
    EXPECT_FALSE(rerun->cancelled);
    EXPECT_EQ(rerun->shards_rendered, abandoned ? 3 : 2);
    EXPECT_TRUE(rerun->index_built);
    EXPECT_TRUE(ValidateDataset(out).ok());
    EXPECT_EQ(testing::DigestDataset(out).value(), testing::DigestDataset(dir.path() / "reference").value());
  }
}

// Seen on a Slurm farm (tests/farm): SIGTERM during a task's last shard, with time to finish
// it, used to go on to the index and exit 0. The shard is finished; the index is not started.
TEST(RenderCancel, AStopDuringTheLastShardFinishesItAndStartsNoIndex) {
  TempDir dir;
  const auto sampler = TinySampler();
  CancelFlag cancel{false};
  RenderOptions options = TinyRender(dir.path());
  options.cancel = &cancel;
  options.finish_shard_seconds = 1e9;
  options.progress = [&](int64_t done, int64_t) {
    if (done == 10) cancel = true;
  };
  const auto report = RenderDataset(*sampler, options);
  ASSERT_OK(report.status());
  EXPECT_TRUE(report->cancelled);
  EXPECT_EQ(report->abandoned_shard, -1);
  EXPECT_EQ(report->shards_rendered, 4);
  EXPECT_TRUE(report->shards_missing.empty());
  EXPECT_FALSE(report->index_built);
  EXPECT_FALSE(fs::exists(DatasetPaths(dir.path()).index()));
  EXPECT_TRUE(Leftovers(dir.path()).empty());
}

// A lock held elsewhere: the render does the other shards first, waits, and renders the
// shard itself once the holder lets go without publishing it (a holder that died).
TEST(RenderCancel, AShardLockedElsewhereIsRenderedLastOnceItsHolderLetsGo) {
  TempDir dir;
  const auto sampler = TinySampler();
  const DatasetPaths paths(dir.path());
  fs::create_directories(paths.shards_dir());
  std::optional<files::FileLock> held(files::FileLock::TryAcquire(paths.shard(0)).value());
  ASSERT_TRUE(held->held());

  std::atomic<bool> waiting{false};
  std::vector<std::string> notes;
  RenderOptions options = TinyRender(dir.path());
  options.on_note = [&](const std::string& line) {
    notes.push_back(line);
    if (line.starts_with("waiting for")) waiting = true;
  };
  Result<RenderReport> report = InternalError("not run");
  std::atomic<bool> returned{false};
  std::thread render([&] {
    report = RenderDataset(*sampler, options);
    returned = true;
  });
  while (!waiting && !returned) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(waiting) << report.status().ToString();
  // Shards 1-3 are done by now, shard 0 is not.
  EXPECT_FALSE(fs::exists(paths.shard(0)));
  for (int k = 1; k < 4; ++k) EXPECT_TRUE(fs::exists(paths.shard(k))) << k;
  held.reset();
  render.join();
  ASSERT_OK(report.status());
  EXPECT_EQ(report->shards_rendered, 4);
  EXPECT_EQ(report->shards_by_others, 0);
  EXPECT_TRUE(report->index_built);
  ASSERT_GE(notes.size(), 2u);
  EXPECT_NE(notes[0].find("shard 0: another process is rendering it"), std::string::npos) << notes[0];
  EXPECT_TRUE(ValidateDataset(dir.path()).ok());
  EXPECT_TRUE(Leftovers(dir.path()).empty());
}

TEST(SampleCancel, StopsWithCancelled) {
  const auto sampler = TinySampler();
  CancelFlag cancel{false};
  SampleOptions options;
  options.layouts = 1000;
  options.jobs = 2;
  options.cancel = &cancel;
  options.progress = [&](int64_t done, int64_t) {
    if (done > 0) cancel = true;
  };
  const auto report = RunSample(*sampler, options);
  EXPECT_EQ(report.status().code(), StatusCode::kCancelled) << report.status().ToString();
  EXPECT_NE(report.status().message().find("of 1000 layouts"), std::string::npos) << report.status().message();
}

}  // namespace
}  // namespace solid::render
