// Test harness: a real single-node Slurm cluster (Debian's slurm-wlm and munge) started by
// hand for the farm tests: munged, slurmctld and slurmd on loopback, with a generated
// slurm.conf (this machine's CPUs and memory, one partition, no accounting, no cgroups) and
// every state, spool, pid and log file under one directory. See
// shared/docs/slurm-single-node.md for what this machine kind needs.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "fixtures/run_command.h"
#include "solid/formats/status.h"

namespace solid::farm {

// What `scontrol show job` says of one job or array task.
struct JobInfo {
  std::string state;      // JobState, e.g. PENDING, RUNNING, COMPLETED, FAILED
  std::string reason;     // Reason, e.g. Dependency, BeginTime, None
  std::string exit_code;  // ExitCode, "status:signal"
  int restarts = 0;       // Restarts: how often Slurm requeued it
};

class SlurmCluster {
 public:
  // Starts the three daemons under `dir` (created; short enough for a Unix socket path,
  // its parents searchable by everyone, as munged requires) and waits until the node is idle. Fails naming why (not root, a program
  // missing, a daemon that did not come up, with the daemons' log tails); whatever was
  // started is stopped again first.
  static Result<std::unique_ptr<SlurmCluster>> Start(const std::filesystem::path& dir);
  ~SlurmCluster();  // Stop(), printing its failure on stderr
  SlurmCluster(const SlurmCluster&) = delete;
  SlurmCluster& operator=(const SlurmCluster&) = delete;

  // Cancels every job and waits (at most 20 s) until none is left.
  Status CancelAll() const;

  // Cancels every job, waits for them to end, stops slurmd, slurmctld and munged by the
  // PIDs of their pid files (SIGTERM, then SIGKILL after 10 s). Fails when a daemon, or a
  // process of a job, is still there afterwards. Idempotent.
  Status Stop();

  // `command` through /bin/sh, with SLURM_CONF naming this cluster (sbatch hands it on to
  // the jobs, so they see it too).
  fixtures::CommandRun Run(const std::string& command) const;
  // The shell prefix that Run() adds: SLURM_CONF='...'.
  std::string Environment() const;

  // scontrol show job ID (a job, an array, or ARRAY_TASK).
  Result<JobInfo> Job(const std::string& id) const;

  int cpus() const { return cpus_; }
  const std::string& partition() const { return partition_; }
  // The last lines of the three daemons' logs, for failure messages.
  std::string LogTails() const;

 private:
  explicit SlurmCluster(std::filesystem::path dir) : dir_(std::move(dir)) {}
  Status Launch();

  std::filesystem::path dir_;
  std::string partition_ = "solid";
  int cpus_ = 1;
  std::vector<std::pair<std::string, pid_t>> daemons_;  // started so far, in start order
  bool stopped_ = false;
};

}  // namespace solid::farm
