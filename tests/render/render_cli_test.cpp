// `solid render` as processes: killed at random points and rerun, or run as a farm of
// one process per shard, it ends with the same data as one uninterrupted run.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "fixtures/run_command.h"
#include "formats/test_util.h"
#include "render/dataset_digest.h"
#include "render/test_assets.h"
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
  std::vector<int> exits(6, -1);
  for (int k = 0; k < 6; ++k) {
    processes.emplace_back([&, k] {
      std::string command = Shell(RenderArguments(farm, 1));
      if (k % 3 == 0) command += " --shard " + std::to_string(k);
      if (k % 3 == 1) command = "SLURM_ARRAY_TASK_ID=" + std::to_string(k) + " " + command;
      if (k % 3 == 2) command = "JOB_COMPLETION_INDEX=" + std::to_string(k) + " " + command;
      exits[k] = RunCommand(command).exit_status;
    });
  }
  for (std::thread& p : processes) p.join();
  for (int k = 0; k < 6; ++k) EXPECT_EQ(exits[k], 0) << "shard " << k;
  const auto index = RunCommand(ShellQuote(SOLID_CLI_BINARY) + " index " + ShellQuote(farm.string()));
  ASSERT_EQ(index.exit_status, 0) << index.output;
  const ValidationReport validation = ValidateDataset(farm);
  EXPECT_TRUE(validation.ok()) << validation.ToJson().dump(2);
  EXPECT_EQ(testing::DigestDataset(farm).value(), testing::DigestDataset(reference).value());
}

TEST(RenderCli, ABadShardIndexFromTheSchedulerIsAUsageError) {
  TempDir dir;
  const auto run = RunCommand("SLURM_ARRAY_TASK_ID=x " + Shell(RenderArguments(dir.path() / "d", 1)));
  EXPECT_EQ(run.exit_status, 2) << run.output;
  EXPECT_NE(run.output.find("SLURM_ARRAY_TASK_ID"), std::string::npos) << run.output;
}

}  // namespace
}  // namespace solid::render
