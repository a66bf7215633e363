// `solid render` as processes: killed or stopped by SIGTERM/SIGINT at random points and
// rerun, run as a farm of one process per shard, or twice on one shard, it ends with the
// same data as one uninterrupted run; `solid index` during a render indexes what is complete.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>

#include "fixtures/background_process.h"
#include "fixtures/run_command.h"
#include "formats/test_util.h"
#include "render/dataset_digest.h"
#include "render/test_assets.h"
#include "solid/formats/dataset.h"
#include "solid/formats/file_lock.h"
#include "solid/formats/files.h"
#include "solid/formats/index.h"
#include "solid/formats/random.h"
#include "solid/formats/validate.h"

namespace solid::render {
namespace {

namespace fs = std::filesystem;
using fixtures::RunCommand;
using fixtures::ShellQuote;
using solid::testing::TempDir;

// 18 images in shards of 3 at 96 x 72, one sample per pixel, 48-pixel query views.
std::vector<std::string> RenderArguments(const fs::path& out, int jobs) {
  const std::string assets = testing::ProceduralAssetsDir().string();
  return {SOLID_CLI_BINARY, "render", "--preset", "random-placement", "--resolution", "96x72", "--assets", assets,
          "--out", out.string(), "--images", "18", "--shard-size", "3", "--spp", "1", "--query-size", "48",
          "--seed", "9", "--jobs", std::to_string(jobs)};
}

std::string Shell(const std::vector<std::string>& arguments) {
  std::string command;
  for (const std::string& a : arguments) command += (command.empty() ? "" : " ") + ShellQuote(a);
  return command;
}

// Starts the render, lets it run for `delay`, then SIGKILLs it. True when it had already
// finished by then.
bool RunAndKill(const std::vector<std::string>& arguments, std::chrono::milliseconds delay) {
  const pid_t child = fork();
  if (child == 0) {
    std::vector<char*> argv;
    for (const std::string& a : arguments) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const int null = ::open("/dev/null", O_WRONLY);
    dup2(null, 1);
    dup2(null, 2);
    execv(argv[0], argv.data());
    _exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + delay;
  int status = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    if (waitpid(child, &status, WNOHANG) == child) return WIFEXITED(status) && WEXITSTATUS(status) == 0;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  kill(child, SIGKILL);
  waitpid(child, &status, 0);
  return false;
}

TEST(RenderCli, KilledRunsResumeToTheSameDataset) {
  TempDir dir;
  const fs::path reference = dir.path() / "reference", killed = dir.path() / "killed";
  const auto whole = RunCommand(Shell(RenderArguments(reference, 2)));
  ASSERT_EQ(whole.exit_status, 0) << whole.output;

  // Kill points from a fixed stream, short enough that most runs die mid-shard.
  Rng rng(0x5eed, 1);
  int kills = 0;
  for (int attempt = 0; attempt < 40; ++attempt) {
    const auto delay = std::chrono::milliseconds(50 + rng.Int(0, 400));
    if (RunAndKill(RenderArguments(killed, 1 + attempt % 2), delay)) break;
    ++kills;
  }
  EXPECT_GE(kills, 3) << "the runs were too short to be interrupted";
  const auto finish = RunCommand(Shell(RenderArguments(killed, 2)));
  ASSERT_EQ(finish.exit_status, 0) << finish.output;
  EXPECT_TRUE(ValidateDataset(killed).ok());
  EXPECT_EQ(testing::DigestDataset(killed).value(), testing::DigestDataset(reference).value());
}

TEST(RenderCli, AFarmOfShardProcessesEqualsOneProcess) {
  TempDir dir;
  const fs::path reference = dir.path() / "reference", farm = dir.path() / "farm";
  const auto whole = RunCommand(Shell(RenderArguments(reference, 2)));
  ASSERT_EQ(whole.exit_status, 0) << whole.output;

  // Six shards, six processes at once: half told by --shard, half by the variables
  // Slurm job arrays and Kubernetes Indexed Jobs set.
  std::vector<std::thread> processes;
  std::vector<fixtures::CommandRun> runs(6);
  for (int k = 0; k < 6; ++k) {
    processes.emplace_back([&, k] {
      std::string command = Shell(RenderArguments(farm, 1));
      if (k % 3 == 0) command += " --shard " + std::to_string(k);
      if (k % 3 == 1) command = "SLURM_ARRAY_TASK_ID=" + std::to_string(k) + " " + command;
      if (k % 3 == 2) command = "JOB_COMPLETION_INDEX=" + std::to_string(k) + " " + command;
      runs[k] = RunCommand(command);
    });
  }
  for (std::thread& p : processes) p.join();
  for (int k = 0; k < 6; ++k) EXPECT_EQ(runs[k].exit_status, 0) << "shard " << k << ":\n" << runs[k].output;
  const Result<IndexReport> index = Index({.dataset = farm});
  ASSERT_OK(index.status());
  EXPECT_TRUE(index->ok());
  const ValidationReport validation = ValidateDataset(farm);
  EXPECT_TRUE(validation.ok()) << validation.ToJson().dump(2);
  EXPECT_EQ(testing::DigestDataset(farm).value(), testing::DigestDataset(reference).value());
}

// 18 images in shards of 3 at 64 x 48, one sample per pixel, no query views.
std::vector<std::string> TinyRenderArguments(const fs::path& out, int jobs) {
  const std::string assets = testing::ProceduralAssetsDir().string();
  return {SOLID_CLI_BINARY, "render", "--preset", "random-placement", "--resolution", "64x48", "--assets", assets,
          "--out", out.string(), "--images", "18", "--shard-size", "3", "--spp", "1", "--no-queries",
          "--seed", "9", "--jobs", std::to_string(jobs)};
}

// Temporary and lock files anywhere under root.
std::vector<fs::path> Leftovers(const fs::path& root) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::recursive_directory_iterator(root, ec)) {
    if (files::IsTempPath(e.path()) || files::IsLockPath(e.path())) out.push_back(e.path());
  }
  return out;
}

bool AnyTempIn(const fs::path& dir) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (files::IsTempPath(e.path())) return true;
  }
  return false;
}

// SIGTERM and SIGINT at random points (once the handlers are in place): each stopped run
// exits 130 or 143, says how to resume, leaves only complete shards, and the rerun gives
// the data of an undisturbed run.
TEST(RenderCli, StopSignalsLeaveCompleteShardsAndTheRerunResumes) {
  TempDir dir;
  const fs::path reference = dir.path() / "reference", stopped = dir.path() / "stopped";
  const auto whole = RunCommand(Shell(TinyRenderArguments(reference, 2)));
  ASSERT_EQ(whole.exit_status, 0) << whole.output;

  Rng rng(0x516, 1);
  int stops = 0;
  for (int attempt = 0; attempt < 6; ++attempt) {
    const int signo = attempt % 2 == 0 ? SIGTERM : SIGINT;
    fixtures::BackgroundProcess render(TinyRenderArguments(stopped, 1 + attempt % 2), dir.path() / "log");
    ASSERT_TRUE(render.WaitUntil([&] { return render.Catches(signo); }, std::chrono::seconds(60))) << render.Output();
    std::this_thread::sleep_for(std::chrono::milliseconds(rng.Int(0, 150)));
    render.Signal(signo);
    const int exit = render.Wait();
    const std::string output = render.Output();
    if (exit == 0) break;  // it had finished
    ++stops;
    ASSERT_EQ(exit, signo == SIGTERM ? 143 : 130) << output;
    EXPECT_NE(output.find(signo == SIGTERM ? "stopped by SIGTERM" : "stopped by SIGINT"), std::string::npos) << output;
    EXPECT_NE(output.find("to resume, run the same command again"), std::string::npos) << output;
    EXPECT_TRUE(Leftovers(stopped).empty()) << output;
    const ShardListing listing = ListShards(stopped).value();
    for (const ShardFile& f : listing.targets) {
      const ValidationReport v = ValidateShardFile(f.path);
      EXPECT_TRUE(v.ok()) << v.ToJson().dump(2);
    }
  }
  EXPECT_GE(stops, 3) << "the runs were too short to be stopped";
  const auto finish = RunCommand(Shell(TinyRenderArguments(stopped, 2)));
  ASSERT_EQ(finish.exit_status, 0) << finish.output;
  const ValidationReport validation = ValidateDataset(stopped);
  EXPECT_TRUE(validation.ok()) << validation.ToJson().dump(2);
  EXPECT_EQ(testing::DigestDataset(stopped).value(), testing::DigestDataset(reference).value());
}

TEST(RenderCli, ASecondSignalEndsTheProcessAtOnce) {
  TempDir dir;
  fixtures::BackgroundProcess render(TinyRenderArguments(dir.path() / "d", 1), dir.path() / "log");
  ASSERT_TRUE(render.WaitUntil([&] { return render.Catches(SIGINT); }, std::chrono::seconds(60))) << render.Output();
  render.Signal(SIGINT);
  // The first signal resets the handler: once it has run, SIGINT is no longer caught.
  ASSERT_TRUE(render.WaitUntil([&] { return !render.Catches(SIGINT); }, std::chrono::seconds(60)));
  render.Signal(SIGINT);
  const int exit = render.Wait();
  // Ended by the signal, unless the first stop was complete before the second arrived.
  EXPECT_TRUE(exit == -SIGINT || exit == 130) << exit << render.Output();
}

// Two processes on one shard at once: the second finds the lock, waits, and finds the
// shard published; exactly one renders it, and the dataset equals a single process's.
TEST(RenderCli, TwoProcessesGivenOneShardRenderItOnce) {
  TempDir dir;
  const fs::path reference = dir.path() / "reference", shared = dir.path() / "shared";
  auto arguments = [](const fs::path& out) {
    std::vector<std::string> a = TinyRenderArguments(out, 1);
    for (const char* extra : {"--shard", "2", "--json"}) a.push_back(extra);
    return a;
  };
  const auto one = RunCommand(Shell(arguments(reference)));
  ASSERT_EQ(one.exit_status, 0) << one.output;

  fixtures::BackgroundProcess first(arguments(shared), dir.path() / "first.log");
  // The first is frozen while it writes shard 2 (holding its lock), until the second has
  // found the lock: however fast either is, they overlap.
  ASSERT_TRUE(first.WaitUntil([&] { return AnyTempIn(shared / "shards"); }, std::chrono::seconds(60)))
      << first.Output();
  first.Signal(SIGSTOP);
  fixtures::BackgroundProcess second(arguments(shared), dir.path() / "second.log");
  const bool found_lock = second.WaitUntil(
      [&] { return second.Output().find("shard 2: another process is rendering it") != std::string::npos; },
      std::chrono::seconds(60));
  first.Signal(SIGCONT);
  ASSERT_TRUE(found_lock) << second.Output();
  ASSERT_EQ(first.Wait(), 0) << first.Output();
  ASSERT_EQ(second.Wait(), 0) << second.Output();
  auto report = [](const std::string& output) { return nlohmann::json::parse(output.substr(output.find("\n{") + 1)); };
  const nlohmann::json a = report(first.Output()), b = report(second.Output());
  EXPECT_EQ(a["shards_rendered"], 1) << first.Output();
  EXPECT_EQ(b["shards_rendered"], 0) << second.Output();
  EXPECT_EQ(b["shards_by_others"], 1) << second.Output();
  EXPECT_NE(second.Output().find("shard 2: published by the other process"), std::string::npos) << second.Output();
  EXPECT_TRUE(Leftovers(shared).empty());
  EXPECT_TRUE(ValidateShardFile(DatasetPaths(shared).shard(2)).ok());
  EXPECT_EQ(testing::DigestDataset(shared).value(), testing::DigestDataset(reference).value());
}

// `solid index` while a render runs: the render is held before its last shard by a lock
// this test owns, a writer's temporary file lies next to it, and the index covers the
// complete shards only and names the missing one. Released, the render completes, and a
// later index covers everything.
TEST(RenderCli, IndexDuringARenderCoversCompleteShardsOnly) {
  TempDir dir;
  const fs::path out = dir.path() / "d";
  const DatasetPaths paths(out);
  fs::create_directories(paths.shards_dir());
  std::optional<files::FileLock> held(files::FileLock::TryAcquire(paths.shard(5)).value());
  ASSERT_TRUE(held->held());
  fixtures::BackgroundProcess render(TinyRenderArguments(out, 2), dir.path() / "log");
  ASSERT_TRUE(render.WaitUntil([&] { return render.Output().find("waiting for") != std::string::npos; },
                               std::chrono::seconds(120)))
      << render.Output();
  // What a killed or running writer of shard 5 leaves: never a shard to the index.
  const fs::path temp = files::TempPathFor(paths.shard(5));
  { std::ofstream(temp) << "half a shard"; }

  const Result<IndexReport> mid = Index({.dataset = out});
  ASSERT_OK(mid.status());
  EXPECT_TRUE(mid->ok()) << mid->ToJson().dump();
  EXPECT_EQ(mid->shards, 5);
  EXPECT_EQ(mid->images, 15);
  EXPECT_EQ(mid->missing_shards, (std::vector<std::pair<int64_t, int64_t>>{{5, 5}}));
  fs::remove(temp);

  held.reset();
  ASSERT_EQ(render.Wait(), 0) << render.Output();
  const Result<IndexReport> last = Index({.dataset = out});
  ASSERT_OK(last.status());
  EXPECT_TRUE(last->ok());
  EXPECT_EQ(last->shards, 6);
  EXPECT_EQ(last->images, 18);
  EXPECT_TRUE(last->missing_shards.empty());
  const ValidationReport validation = ValidateDataset(out);
  EXPECT_TRUE(validation.ok()) << validation.ToJson().dump(2);
}

// `solid index` killed at random points: the index is there whole or not at all, and a
// rerun leaves no temporary and an index that agrees with the shards.
TEST(RenderCli, KilledIndexRunsLeaveNoPartialIndex) {
  TempDir dir;
  const fs::path out = dir.path() / "d";
  const auto render = RunCommand(Shell(TinyRenderArguments(out, 2)));
  ASSERT_EQ(render.exit_status, 0) << render.output;
  const std::vector<std::string> index = {SOLID_CLI_BINARY, "index", out.string()};
  Rng rng(0x1d8, 1);
  int kills = 0;
  for (int attempt = 0; attempt < 20; ++attempt) {
    fs::remove(DatasetPaths(out).index());
    fixtures::BackgroundProcess run(index, dir.path() / "log");
    std::this_thread::sleep_for(std::chrono::microseconds(rng.Int(500, 30000)));
    if (!run.Running()) continue;
    run.Signal(SIGKILL);
    run.Wait();
    ++kills;
    if (fs::exists(DatasetPaths(out).index())) {
      const auto diffs = CompareIndex(out);
      ASSERT_TRUE(diffs.ok()) << diffs.status().ToString();
      EXPECT_TRUE(diffs->empty()) << diffs->front();
    }
  }
  EXPECT_GE(kills, 3);
  const auto rerun = RunCommand(Shell(index));
  ASSERT_EQ(rerun.exit_status, 0) << rerun.output;
  EXPECT_TRUE(Leftovers(out).empty());
  const ValidationReport validation = ValidateDataset(out);
  EXPECT_TRUE(validation.ok()) << validation.ToJson().dump(2);
}

TEST(RenderCli, SampleStopsOnSigint) {
  TempDir dir;
  const std::string assets = testing::ProceduralAssetsDir().string();
  fixtures::BackgroundProcess sample({SOLID_CLI_BINARY, "sample", "--preset", "random-placement", "--resolution",
                                      "64x48", "--assets", assets, "--layouts", "100000", "--jobs", "1"},
                                     dir.path() / "log");
  ASSERT_TRUE(sample.WaitUntil([&] { return sample.Catches(SIGINT); }, std::chrono::seconds(60))) << sample.Output();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  sample.Signal(SIGINT);
  EXPECT_EQ(sample.Wait(), 130) << sample.Output();
  EXPECT_NE(sample.Output().find("of 100000 layouts (SIGINT)"), std::string::npos) << sample.Output();
}

TEST(RenderCli, ABadShardIndexFromTheSchedulerIsAUsageError) {
  TempDir dir;
  const auto run = RunCommand("SLURM_ARRAY_TASK_ID=x " + Shell(RenderArguments(dir.path() / "d", 1)));
  EXPECT_EQ(run.exit_status, 2) << run.output;
  EXPECT_NE(run.output.find("SLURM_ARRAY_TASK_ID"), std::string::npos) << run.output;
}

}  // namespace
}  // namespace solid::render
