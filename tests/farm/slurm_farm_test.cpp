// The farm recipe (docs/farm/slurm-render.sbatch and slurm-index.sbatch, run unchanged) on a
// real single-node Slurm cluster: an array with a dependent index job equals one `solid
// render` process image by image; a task preempted with requeue, a task SIGKILLed mid-shard
// and tasks racing on one query shard all end with that same dataset; `solid index` during
// the farm indexes what is there and names the rest. docs/farm/slurm-pretrain.sbatch trains
// two CPU ranks on that dataset and resumes.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/inotify.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "farm/slurm_cluster.h"
#include "fixtures/background_process.h"
#include "fixtures/run_command.h"
#include "formats/test_util.h"
#include "render/dataset_digest.h"
#include "solid/formats/dataset.h"
#include "solid/formats/file_lock.h"
#include "solid/formats/files.h"
#include "solid/formats/validate.h"

namespace solid::farm {
namespace {

namespace fs = std::filesystem;
using fixtures::BackgroundProcess;
using fixtures::RunCommand;
using fixtures::ShellQuote;
using Clock = std::chrono::steady_clock;

// The dataset of every test: 12 images at 64 x 48 in 4 shards of 3, one sample per pixel,
// 32-pixel query views of 4 procedural models (one query shard), seed 1 (the recipe's).
constexpr int kShards = 4;
const std::vector<std::string> kExtraRenderFlags = {"--spp", "1", "--query-size", "32"};

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

bool Contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

size_t Count(const std::string& text, const std::string& part) {
  size_t n = 0;
  for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
  return n;
}

bool WaitFor(const std::function<bool()>& ready, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    if (ready()) return true;
    if (Clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

// Files created in one directory, seen through inotify: the tests must stop a writer in the
// few milliseconds between creating its temporary file and publishing it, which polling
// could miss.
class DirectoryWatch {
 public:
  explicit DirectoryWatch(const fs::path& dir) : fd_(inotify_init1(IN_CLOEXEC)) {
    if (fd_ >= 0) inotify_add_watch(fd_, dir.c_str(), IN_CREATE);
  }
  ~DirectoryWatch() {
    if (fd_ >= 0) ::close(fd_);
  }
  DirectoryWatch(const DirectoryWatch&) = delete;
  DirectoryWatch& operator=(const DirectoryWatch&) = delete;

  // The name of the first file created since the watch began whose name starts with `prefix`.
  std::optional<std::string> WaitForCreated(const std::string& prefix, std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    alignas(inotify_event) char buffer[16384];
    while (fd_ >= 0 && Clock::now() < deadline) {
      pollfd p{fd_, POLLIN, 0};
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
      if (::poll(&p, 1, static_cast<int>(std::max<int64_t>(1, left.count()))) <= 0) continue;
      const ssize_t n = ::read(fd_, buffer, sizeof buffer);
      for (ssize_t at = 0; at < n;) {
        const auto* event = reinterpret_cast<const inotify_event*>(buffer + at);
        at += static_cast<ssize_t>(sizeof(inotify_event) + event->len);
        if (event->len > 0 && std::string_view(event->name).starts_with(prefix)) return std::string(event->name);
      }
    }
    return std::nullopt;
  }

 private:
  int fd_;
};

// The writer of a temporary file: files::TempPathFor names it `<file>.tmp-<host>-<pid>-<n>`.
pid_t WriterOf(const std::string& temp_name) {
  const size_t last = temp_name.rfind('-');
  const size_t before = temp_name.rfind('-', last - 1);
  return static_cast<pid_t>(std::atoll(temp_name.substr(before + 1, last - before - 1).c_str()));
}

// True once the main thread of `pid` sleeps on a futex. In a `solid render` that has just
// created a shard's temporary file, that is the shard writer waiting for its first image:
// past the point where the shard's clock starts, which the rate it judges SIGTERM by counts
// from, and before any image is written.
bool WaitsForItsFirstImage(pid_t pid) {
  const std::string stat = ReadText(fmt::format("/proc/{}/stat", pid));
  const size_t paren = stat.rfind(')');
  if (paren == std::string::npos || paren + 2 >= stat.size() || stat[paren + 2] != 'S') return false;
  return Contains(ReadText(fmt::format("/proc/{}/wchan", pid)), "futex");
}

// The array task a process belongs to, from the environment Slurm gave it.
std::string ArrayTaskOf(pid_t pid) {
  std::string environ = ReadText(fmt::format("/proc/{}/environ", pid));
  std::replace(environ.begin(), environ.end(), '\0', '\n');
  const std::string key = "\nSLURM_ARRAY_TASK_ID=";
  const size_t at = ("\n" + environ).find(key);
  if (at == std::string::npos) return "";
  return environ.substr(at + key.size() - 1, environ.find('\n', at + key.size() - 1) - (at + key.size() - 1));
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

// The shard numbers of "shards 2, 5-7 are not there yet".
std::set<int> MissingShards(const std::string& index_output) {
  std::set<int> out;
  const size_t end = index_output.find(" are not there yet");
  const size_t begin = index_output.rfind("shards ", end);
  if (end == std::string::npos || begin == std::string::npos) return out;
  std::istringstream ranges(index_output.substr(begin + 7, end - begin - 7));
  for (std::string range; std::getline(ranges, range, ',');) {
    int a = 0, b = 0;
    const int n = std::sscanf(range.c_str(), " %d-%d", &a, &b);
    for (int k = a; n >= 1 && k <= (n == 2 ? b : a); ++k) out.insert(k);
  }
  return out;
}

// A job submitted with sbatch --wait: the process ends when the job does, with the job's
// exit code (for an array, the highest of its tasks').
struct Submission {
  std::unique_ptr<BackgroundProcess> sbatch;
  std::string job;  // the job id, printed by --parsable at once
};

class SlurmFarm : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    char pattern[] = "/tmp/solid-farm-XXXXXX";
    if (::mkdtemp(pattern) == nullptr) {
      setup_error_ = "mkdtemp failed";
      return;
    }
    root_ = pattern;
    // munged serves its socket only from directories everyone may search.
    fs::permissions(root_, fs::perms(0755));
    auto cluster = SlurmCluster::Start(root_ / "cluster");
    if (!cluster.ok()) {
      skip_reason_ = "no Slurm cluster: " + cluster.status().message();
      return;
    }
    cluster_ = std::move(cluster).value();
    const auto assets = RunCommand(fmt::format("{} convert procedural {} --models 4 --rooms 1",
                                               ShellQuote(SOLID_CLI_BINARY), ShellQuote((root_ / "assets").string())));
    if (assets.exit_status != 0) {
      setup_error_ = "solid convert procedural: " + assets.output;
      return;
    }
    // The reference: one plain `solid render` process with the flags the recipe passes.
    std::string command = fmt::format(
        "{} render --preset more-objects --resolution 64x48 --assets {} --rooms {} --out {} --images 12 "
        "--shard-size 3 --seed 1 --jobs {}",
        ShellQuote(SOLID_CLI_BINARY), ShellQuote((root_ / "assets").string()),
        ShellQuote((root_ / "assets").string()), ShellQuote((root_ / "reference").string()), cluster_->cpus());
    for (const std::string& f : kExtraRenderFlags) command += " " + f;
    const auto reference = RunCommand(command);
    if (reference.exit_status != 0) {
      setup_error_ = "the reference render: " + reference.output;
      return;
    }
    auto digest = render::testing::DigestDataset(root_ / "reference");
    if (!digest.ok()) {
      setup_error_ = "the reference digest: " + digest.status().ToString();
      return;
    }
    reference_ = std::move(digest).value();
  }

  static void TearDownTestSuite() {
    if (cluster_) {
      const Status stopped = cluster_->Stop();
      EXPECT_TRUE(stopped.ok()) << stopped.ToString();
      cluster_.reset();
    }
    std::error_code ec;
    if (!root_.empty()) fs::remove_all(root_, ec);
  }

  void SetUp() override {
    if (!skip_reason_.empty()) GTEST_SKIP() << skip_reason_;
    ASSERT_TRUE(setup_error_.empty()) << setup_error_;
    work_ = root_ / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    out_ = work_ / "dataset";
    // The recipe writes its logs to logs/ of the submitting directory; the dataset's folders
    // exist already so that a test can watch them from the start.
    for (const fs::path& d : {work_ / "logs", out_ / "shards", out_ / "queries"}) fs::create_directories(d);
  }

  // Whatever a failed test left running, so that the next one starts on an idle node.
  void TearDown() override {
    if (!cluster_) return;
    const Status cancelled = cluster_->CancelAll();
    EXPECT_TRUE(cancelled.ok()) << cancelled.ToString();
  }

  // The recipe's variables for this test's dataset.
  std::string RecipeEnvironment() const {
    return fmt::format("SOLID={} ASSETS={} ROOMS={} DATASET={} IMAGES=12 SHARD_SIZE=3 RESOLUTION=64x48",
                       ShellQuote(SOLID_CLI_BINARY), ShellQuote((root_ / "assets").string()),
                       ShellQuote((root_ / "assets").string()), ShellQuote(out_.string()));
  }

  // sbatch --parsable --wait from the test's directory. The sbatch options override the
  // script's #SBATCH lines that a 2-core test node cannot meet (8 CPUs, 8 GiB per task).
  // `environment` adds to (and overrides) the render recipe's variables.
  Submission Submit(const std::string& options, const std::string& script, const std::string& arguments = "",
                    const std::string& environment = "") {
    static int n = 0;
    const std::string command = fmt::format(
        "export {}; cd {} && exec env {} {} sbatch --parsable --wait --cpus-per-task=1 --mem=1G {} {} {}",
        cluster_->Environment(), ShellQuote(work_.string()), RecipeEnvironment(), environment, options,
        ShellQuote(std::string(SOLID_SOURCE_DIR) + "/docs/farm/" + script), arguments);
    Submission s;
    s.sbatch = std::make_unique<BackgroundProcess>(std::vector<std::string>{"/bin/sh", "-c", command},
                                                   work_ / fmt::format("sbatch-{}.log", n++));
    s.sbatch->WaitUntil([&] { return Contains(s.sbatch->Output(), "\n"); }, std::chrono::seconds(30));
    const std::string printed = s.sbatch->Output();
    if (!printed.empty() && printed.find_first_not_of("0123456789\n") == std::string::npos) {
      s.job = printed.substr(0, printed.find('\n'));
    }
    return s;
  }

  Submission SubmitRender(const std::string& array) {
    std::string arguments;
    for (const std::string& f : kExtraRenderFlags) arguments += " " + f;
    return Submit("--array=" + array, "slurm-render.sbatch", arguments);
  }

  std::string TaskLog(const std::string& job, int task) const {
    return ReadText(work_ / "logs" / fmt::format("solid-render-{}_{}.log", job, task));
  }

  std::string AllTaskLogs(const std::string& job) const {
    std::string out;
    for (int k = 0; k < kShards; ++k) out += fmt::format("--- task {}\n{}", k, TaskLog(job, k));
    return out;
  }

  fixtures::CommandRun Solid(const std::string& arguments) const {
    return RunCommand(ShellQuote(SOLID_CLI_BINARY) + " " + arguments);
  }

  // The dataset validates, has nothing left over, and holds the reference's data.
  void ExpectTheReferenceDataset() const {
    EXPECT_TRUE(Leftovers(out_).empty()) << Leftovers(out_).front();
    const auto validate = Solid("validate " + ShellQuote(out_.string()));
    EXPECT_EQ(validate.exit_status, 0) << validate.output;
    const auto digest = render::testing::DigestDataset(out_);
    ASSERT_TRUE(digest.ok()) << digest.status().ToString();
    EXPECT_EQ(digest->images.size(), 12u);
    EXPECT_EQ(digest->query_models.size(), 4u);
    EXPECT_TRUE(*digest == reference_) << "the farm's dataset differs from one process's";
  }

  static double SecondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

  static inline fs::path root_;
  static inline std::unique_ptr<SlurmCluster> cluster_;
  static inline std::string skip_reason_, setup_error_;
  static inline render::testing::DatasetDigest reference_;
  fs::path work_, out_;
};

TEST_F(SlurmFarm, TheArrayThenADependentIndexJobEqualsOneProcess) {
  const auto start = Clock::now();
  Submission array = SubmitRender(fmt::format("0-{}%2", kShards - 1));
  ASSERT_FALSE(array.job.empty()) << array.sbatch->Output();
  Submission index = Submit("--dependency=afterok:" + array.job, "slurm-index.sbatch");
  ASSERT_FALSE(index.job.empty()) << index.sbatch->Output();
  // Held back by its dependency while the array runs.
  std::string reason;
  WaitFor(
      [&] {
        const auto job = cluster_->Job(index.job);
        reason = job.ok() ? job->state + "/" + job->reason : job.status().ToString();
        return reason == "PENDING/Dependency";
      },
      std::chrono::seconds(10));
  EXPECT_EQ(reason, "PENDING/Dependency");
  EXPECT_TRUE(array.sbatch->Running()) << "the array ended before the index job could be seen waiting for it";

  ASSERT_EQ(array.sbatch->Wait(), 0) << array.sbatch->Output() << AllTaskLogs(array.job);
  const double array_seconds = SecondsSince(start);
  ASSERT_EQ(index.sbatch->Wait(), 0) << index.sbatch->Output();
  const std::string index_log = ReadText(work_ / "logs" / fmt::format("solid-index-{}.log", index.job));
  EXPECT_TRUE(Contains(index_log, "indexed 4 shards (12 images")) << index_log;
  EXPECT_FALSE(Contains(index_log, "not there yet")) << index_log;
  for (int k = 0; k < kShards; ++k) {
    const std::string log = TaskLog(array.job, k);
    EXPECT_TRUE(Contains(log, fmt::format("solid: shards {0}-{0} (from SLURM_ARRAY_TASK_ID)", k))) << log;
    EXPECT_TRUE(Contains(log, "shards             1 requested: 1 rendered")) << log;
  }
  ExpectTheReferenceDataset();
  fmt::print("farm: array of {} tasks (2 at a time, 1 CPU each) for {} shards of 3 images: {:.1f} s; with the "
             "index job and validation {:.1f} s\n",
             kShards, kShards, array_seconds, SecondsSince(start));
}

// `scontrol requeue` of a running task is what preemption with PreemptMode=REQUEUE does:
// SIGCONT and SIGTERM at once, SIGKILL KillWait (30 s) later, the task back in the queue.
// The task is frozen for 6 s first, as it waits for the first image of its shard (a stalled
// node): at the rate it has had, the rest of the shard would take over 10 s, so it abandons
// the shard, and the requeued run renders it.
TEST_F(SlurmFarm, APreemptedTaskAbandonsItsShardAndItsRequeuedRunRendersIt) {
  const auto start = Clock::now();
  const DatasetPaths paths(out_);
  DirectoryWatch watch(paths.shards_dir());
  Submission array = SubmitRender(fmt::format("0-{}%2", kShards - 1));
  ASSERT_FALSE(array.job.empty()) << array.sbatch->Output();
  const std::string task = array.job + "_1";
  const auto temp = watch.WaitForCreated(paths.shard(1).filename().string() + ".tmp-", std::chrono::seconds(120));
  ASSERT_TRUE(temp.has_value()) << AllTaskLogs(array.job);
  const pid_t writer = WriterOf(*temp);
  const auto deadline = Clock::now() + std::chrono::seconds(30);
  bool waiting = false;
  while (!(waiting = WaitsForItsFirstImage(writer)) && Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  ASSERT_TRUE(waiting) << "the writer of " << *temp << " never waited for an image";
  ASSERT_EQ(::kill(writer, SIGSTOP), 0) << *temp;
  ASSERT_FALSE(fs::exists(paths.shard(1)));
  std::this_thread::sleep_for(std::chrono::seconds(6));
  const auto requeue = cluster_->Run("scontrol requeue " + task);
  ASSERT_EQ(requeue.exit_status, 0) << requeue.output;

  // Requeued: its first run has ended and it waits in the queue.
  ASSERT_TRUE(WaitFor(
      [&] {
        const auto job = cluster_->Job(task);
        return job.ok() && job->restarts == 1 && job->state == "PENDING";
      },
      std::chrono::seconds(60)))
      << TaskLog(array.job, 1);
  const std::string first_run = TaskLog(array.job, 1);
  EXPECT_TRUE(Contains(first_run, "DUE TO JOB REQUEUE")) << first_run;
  EXPECT_TRUE(Contains(first_run, "solid: stopped by SIGTERM: 0 of 1 requested shards complete (0 rendered by this "
                                  "run), shard 1 abandoned (its temporary file removed, nothing published)"))
      << first_run;
  EXPECT_FALSE(fs::exists(paths.shard(1)));
  EXPECT_TRUE(Leftovers(paths.shards_dir()).empty()) << Leftovers(paths.shards_dir()).front();

  // The requeued task starts again once its first run's credential has expired (the test
  // cluster's cred_expire: starting it sooner, slurmd refuses the revoked credential and the
  // task fails).
  ASSERT_EQ(array.sbatch->Wait(), 0) << array.sbatch->Output() << AllTaskLogs(array.job) << cluster_->LogTails();
  const std::string rerun = TaskLog(array.job, 1).substr(first_run.size());
  EXPECT_TRUE(Contains(rerun, "shards             1 requested: 1 rendered")) << rerun;
  ExpectTheReferenceDataset();
  fmt::print("farm: task 1 frozen 6 s as it began its shard, then preempted (SIGTERM, requeued): shard "
             "abandoned, nothing published; the requeued run rendered it; {:.1f} s\n",
             SecondsSince(start));
}

TEST_F(SlurmFarm, AKilledTaskLeavesNoPartialShardAndASecondArrayRendersOnlyThatShard) {
  const auto start = Clock::now();
  const DatasetPaths paths(out_);
  DirectoryWatch watch(paths.shards_dir());
  Submission first = SubmitRender(fmt::format("0-{}%2", kShards - 1));
  ASSERT_FALSE(first.job.empty()) << first.sbatch->Output();
  const auto temp = watch.WaitForCreated(paths.shard(2).filename().string() + ".tmp-", std::chrono::seconds(120));
  ASSERT_TRUE(temp.has_value()) << AllTaskLogs(first.job);
  // What the kernel's OOM killer or a dying node does; Slurm's own `scancel --signal=KILL`
  // sends SIGTERM first and SIGKILL KillWait later, like any cancel.
  ASSERT_EQ(::kill(WriterOf(*temp), SIGKILL), 0) << *temp;
  EXPECT_NE(first.sbatch->Wait(), 0) << "the array succeeded though task 2 was killed\n" << AllTaskLogs(first.job);
  const auto task = cluster_->Job(first.job + "_2");
  if (task.ok()) {
    EXPECT_EQ(task->exit_code, "0:9") << task->state;
  }

  // Killed mid-shard: its partial file is still there, under its temporary name only.
  EXPECT_TRUE(fs::exists(paths.shards_dir() / *temp)) << *temp;
  EXPECT_FALSE(fs::exists(paths.shard(2)));
  const auto listing = ListShards(out_);
  ASSERT_TRUE(listing.ok()) << listing.status().ToString();
  std::vector<int64_t> present;
  for (const ShardFile& f : listing->targets) {
    present.push_back(f.index);
    const ValidationReport v = ValidateShardFile(f.path);
    EXPECT_TRUE(v.ok()) << v.ToJson().dump(2);
  }
  EXPECT_EQ(present, (std::vector<int64_t>{0, 1, 3}));

  Submission second = SubmitRender(fmt::format("0-{}%2", kShards - 1));
  ASSERT_FALSE(second.job.empty()) << second.sbatch->Output();
  ASSERT_EQ(second.sbatch->Wait(), 0) << second.sbatch->Output() << AllTaskLogs(second.job);
  for (int k = 0; k < kShards; ++k) {
    const std::string log = TaskLog(second.job, k);
    EXPECT_TRUE(Contains(log, k == 2 ? "shards             1 requested: 1 rendered"
                                     : "shards             1 requested: 0 rendered (0 repaired), 1 already present"))
        << log;
    EXPECT_TRUE(Contains(log, "query shards       0 rendered")) << log;
  }
  ExpectTheReferenceDataset();
  fmt::print("farm: task 2 SIGKILLed mid-shard: shards 0, 1, 3 present, no shard 2; a second array rendered shard 2 "
             "only; {:.1f} s\n",
             SecondsSince(start));
}

// Query shards have no lock: two tasks that need one both render it and the first rename
// wins. One task is stopped right after creating its temporary query shard; another task
// publishes the shard meanwhile, and `solid index` runs while both that task and a held one
// are still in the farm.
TEST_F(SlurmFarm, TasksRacingOnOneQueryShardAndAnIndexDuringTheFarm) {
  const auto start = Clock::now();
  // A query shard of four 32-pixel views is written within milliseconds of its temporary
  // file's creation, so the stop can come too late; such an attempt shows nothing, and the
  // farm is run again on a new dataset.
  constexpr int kAttempts = 4;
  Submission array;
  pid_t writer = 0;
  std::string stopped_task, held;
  for (int attempt = 1;; ++attempt) {
    out_ = work_ / fmt::format("dataset-{}", attempt);
    for (const fs::path& d : {out_ / "shards", out_ / "queries"}) fs::create_directories(d);
    const DatasetPaths paths(out_);
    DirectoryWatch watch(paths.queries_dir());
    array = SubmitRender(fmt::format("0-{}%2", kShards - 1));
    ASSERT_FALSE(array.job.empty()) << array.sbatch->Output();
    held = fmt::format("{}_{}", array.job, kShards - 1);
    const auto hold = cluster_->Run("scontrol hold " + held);
    ASSERT_EQ(hold.exit_status, 0) << hold.output;

    const auto temp =
        watch.WaitForCreated(paths.query_shard(0).filename().string() + ".tmp-", std::chrono::seconds(120));
    ASSERT_TRUE(temp.has_value()) << AllTaskLogs(array.job);
    writer = WriterOf(*temp);
    ASSERT_EQ(::kill(writer, SIGSTOP), 0) << *temp;
    stopped_task = ArrayTaskOf(writer);
    if (!fs::exists(paths.query_shard(0))) break;
    ASSERT_LT(attempt, kAttempts) << "in each of " << kAttempts << " farms, the task that created query shard 0's "
                                  << "temporary file published it before it could be stopped";
    ::kill(writer, SIGCONT);
    const Status cancelled = cluster_->CancelAll();
    ASSERT_TRUE(cancelled.ok()) << cancelled.ToString();
    array.sbatch->Wait();
  }
  const DatasetPaths paths(out_);
  ASSERT_TRUE(WaitFor([&] { return fs::exists(paths.query_shard(0)); }, std::chrono::seconds(120)))
      << "no other task published the query shard\n"
      << AllTaskLogs(array.job);

  const auto during = Solid("index " + ShellQuote(out_.string()));
  EXPECT_EQ(during.exit_status, 0) << during.output;
  EXPECT_TRUE(MissingShards(during.output).contains(kShards - 1)) << during.output;

  ASSERT_EQ(::kill(writer, SIGCONT), 0);
  const auto release = cluster_->Run("scontrol release " + held);
  ASSERT_EQ(release.exit_status, 0) << release.output;
  ASSERT_EQ(array.sbatch->Wait(), 0) << array.sbatch->Output() << AllTaskLogs(array.job);

  const std::string loser = TaskLog(array.job, std::atoi(stopped_task.c_str()));
  EXPECT_TRUE(Contains(loser, "query shards       0 rendered")) << loser;
  EXPECT_TRUE(Contains(loser, "1 already present")) << loser;
  EXPECT_EQ(Count(AllTaskLogs(array.job), "query shards       1 rendered"), 1u) << AllTaskLogs(array.job);
  const auto after = Solid("index " + ShellQuote(out_.string()));
  EXPECT_EQ(after.exit_status, 0) << after.output;
  EXPECT_TRUE(Contains(after.output, "indexed 4 shards (12 images")) << after.output;
  EXPECT_FALSE(Contains(after.output, "not there yet")) << after.output;
  ExpectTheReferenceDataset();
  const size_t said = during.output.rfind('\n', during.output.find("not there yet")) + 1;
  fmt::print("farm: task {} lost the race for query shard 0 to another task; `solid index` during the farm said: "
             "{}; {:.1f} s\n",
             stopped_task, during.output.substr(said, during.output.find('\n', said) - said), SecondsSince(start));
}

// docs/farm/slurm-pretrain.sbatch, unchanged, on the reference dataset: two CPU ranks under
// one node's torchrun (srun), and a resubmission that resumes the run.
TEST_F(SlurmFarm, ThePretrainingRecipeTrainsTwoRanksAndResumes) {
  if (RunCommand("/usr/bin/python3 -c 'import torch, torchvision'").exit_status != 0) {
    GTEST_SKIP() << "Debian's python3-torch and python3-torchvision are not installed";
  }
  const fs::path run = work_ / "run";
  const std::string environment = fmt::format(
      "PYTHONPATH={} DATASET={} RUN={} CONFIG=small RANKS_PER_NODE=2 PORT=29711",
      ShellQuote(std::string(SOLID_SOURCE_DIR) + "/python"), ShellQuote((root_ / "reference").string()),
      ShellQuote(run.string()));
  // The paper's resources replaced by what the test node has; a config for 64 x 48 images.
  const std::string options = "--gpus-per-node=0 --cpus-per-task=2 --time=10";
  const std::string tiny =
      "--set min_size=48 --set max_size=64 --set query_size=32 --set queries_per_batch=4 --set targets_per_batch=2 "
      "--set num_workers=0 --set checkpoint_period=2 --log-every 1";
  const auto logs = [&] {
    std::string out;
    for (const auto& entry : fs::directory_iterator(work_ / "logs")) out += ReadText(entry.path());
    return out;
  };
  Submission first = Submit(options, "slurm-pretrain.sbatch", tiny + " --set iterations=4 --set stop_at=2", environment);
  ASSERT_FALSE(first.job.empty()) << first.sbatch->Output();
  ASSERT_EQ(first.sbatch->Wait(), 0) << first.sbatch->Output() << logs();
  Submission second = Submit(options, "slurm-pretrain.sbatch", tiny + " --set iterations=4", environment);
  ASSERT_FALSE(second.job.empty()) << second.sbatch->Output();
  ASSERT_EQ(second.sbatch->Wait(), 0) << second.sbatch->Output() << logs();

  const std::string log = logs();
  EXPECT_TRUE(Contains(log, "pretrain: done: iterations 0-2")) << log;
  EXPECT_TRUE(Contains(log, "pretrain: done: iterations 2-4")) << log;
  EXPECT_EQ(Count(ReadText(run / "log.jsonl"), "\n"), 4u) << ReadText(run / "log.jsonl");
  EXPECT_TRUE(Contains(ReadText(run / "run.json"), "\"world_size\": 2")) << ReadText(run / "run.json");
  EXPECT_TRUE(fs::exists(run / "detector.pth"));
}

}  // namespace
}  // namespace solid::farm
