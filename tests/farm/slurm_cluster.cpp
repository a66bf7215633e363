#include "farm/slurm_cluster.h"

#include <fmt/format.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <thread>

namespace solid::farm {
namespace {

namespace fs = std::filesystem;
using fixtures::ShellQuote;
using Clock = std::chrono::steady_clock;

bool WaitFor(const std::function<bool()>& ready, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    if (ready()) return true;
    if (Clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string Tail(const fs::path& path, size_t lines) {
  const std::string text = ReadText(path);
  size_t at = text.size();
  for (size_t n = 0; at > 0 && n <= lines; --at) {
    if (text[at - 1] == '\n') ++n;
  }
  return text.substr(at == 0 ? 0 : at + 1);
}

// Alive and not a zombie: daemons are reparented to PID 1, which may be slow to reap them.
bool Alive(pid_t pid) {
  if (::kill(pid, 0) != 0 && errno == ESRCH) return false;
  const std::string stat = ReadText(fmt::format("/proc/{}/stat", pid));
  const size_t paren = stat.rfind(')');
  return paren != std::string::npos && paren + 2 < stat.size() && stat[paren + 2] != 'Z';
}

// A loopback port nobody listens on now, so that two clusters (or a system Slurm) never meet.
Result<int> FreePort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return IoError(fmt::format("socket: {}", std::strerror(errno)));
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof address;
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0 &&
                  ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0;
  const int error = errno;
  ::close(fd);
  if (!ok) return IoError(fmt::format("bind 127.0.0.1:0: {}", std::strerror(error)));
  return static_cast<int>(ntohs(address.sin_port));
}

std::string ShortHostName() {
  char name[256] = {};
  ::gethostname(name, sizeof name - 1);
  std::string host = name;
  return host.substr(0, host.find('.'));
}

// MemTotal in MiB, less a tenth: slurmd drains a node that has less than its RealMemory.
int64_t RealMemoryMiB() {
  std::ifstream meminfo("/proc/meminfo");
  for (std::string key; meminfo >> key;) {
    int64_t kib = 0;
    meminfo >> kib;
    if (key == "MemTotal:") return kib / 1024 * 9 / 10;
  }
  return 1;
}

Status WriteFile(const fs::path& path, const std::string& text, fs::perms perms) {
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out.flush()) return IoError(path.string() + ": cannot write");
  }
  std::error_code ec;
  fs::permissions(path, perms, ec);
  if (ec) return IoError(fmt::format("{}: chmod: {}", path.string(), ec.message()));
  return Status::Ok();
}

Result<pid_t> WaitForPidFile(const fs::path& path, std::chrono::milliseconds timeout) {
  pid_t pid = 0;
  WaitFor(
      [&] {
        pid = static_cast<pid_t>(std::atoll(ReadText(path).c_str()));
        return pid > 0;
      },
      timeout);
  if (pid <= 0) return NotFoundError(fmt::format("{} did not appear within {} s", path.string(), timeout.count() / 1000));
  return pid;
}

// Processes of this cluster: its daemons name the directory on their command line, and
// slurmstepd and every job process inherit SLURM_CONF from slurmd or sbatch.
std::vector<pid_t> ProcessesOf(const fs::path& dir, const fs::path& conf) {
  std::vector<pid_t> found;
  const std::string conf_variable = "SLURM_CONF=" + conf.string();
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/proc", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    const pid_t pid = static_cast<pid_t>(std::atoll(name.c_str()));
    if (pid == ::getpid() || !Alive(pid)) continue;
    std::string cmdline = ReadText(entry.path() / "cmdline"), environ = ReadText(entry.path() / "environ");
    std::replace(environ.begin(), environ.end(), '\0', '\n');
    if (cmdline.find(dir.string()) != std::string::npos || ("\n" + environ).find("\n" + conf_variable + "\n") !=
                                                               std::string::npos) {
      found.push_back(pid);
    }
  }
  return found;
}

}  // namespace

Result<std::unique_ptr<SlurmCluster>> SlurmCluster::Start(const fs::path& dir) {
  if (::geteuid() != 0) {
    return InvalidArgumentError(fmt::format(
        "the Slurm cluster runs slurmd and munged as root (SlurmUser=root), and this test runs as uid {}",
        ::geteuid()));
  }
  for (const char* program : {"munged", "slurmctld", "slurmd", "sbatch", "squeue", "sinfo", "scontrol", "scancel"}) {
    const auto found = fixtures::RunCommand(fmt::format("PATH=\"$PATH:/usr/sbin:/sbin\" command -v {}", program));
    if (found.exit_status != 0) {
      return NotFoundError(fmt::format("{} is not installed (Debian packages slurm-wlm and munge; "
                                       "scripts/install-deps.sh installs them)",
                                       program));
    }
  }
  std::unique_ptr<SlurmCluster> cluster(new SlurmCluster(dir));
  const Status launched = cluster->Launch();
  if (!launched.ok()) {
    const std::string tails = cluster->LogTails();
    const Status stopped = cluster->Stop();
    return Status(launched.code(),
                  launched.message() + "\n" + tails + (stopped.ok() ? "" : "\nand stopping: " + stopped.ToString()));
  }
  return cluster;
}

Status SlurmCluster::Launch() {
  std::error_code ec;
  for (const char* sub : {"munge-key", "munge", "state", "spool", "log"}) fs::create_directories(dir_ / sub, ec);
  if (ec) return IoError(fmt::format("{}: cannot create: {}", dir_.string(), ec.message()));
  // munged wants its key private and the socket's directory searchable by everyone.
  fs::permissions(dir_, fs::perms(0755), ec);
  fs::permissions(dir_ / "munge", fs::perms(0755), ec);
  fs::permissions(dir_ / "munge-key", fs::perms(0700), ec);
  std::string key(1024, '\0');
  std::ifstream("/dev/urandom", std::ios::binary).read(key.data(), static_cast<std::streamsize>(key.size()));
  SOLID_RETURN_IF_ERROR(WriteFile(dir_ / "munge-key/munge.key", key, fs::perms(0400)));

  cpus_ = static_cast<int>(std::max(1L, ::sysconf(_SC_NPROCESSORS_ONLN)));
  SOLID_ASSIGN_OR_RETURN(const int controller_port, FreePort());
  SOLID_ASSIGN_OR_RETURN(const int node_port, FreePort());
  const std::string host = ShortHostName();
  const fs::path socket = dir_ / "munge/munge.socket";
  // MinJobAge 5 keeps sbatch --wait polling every 2 s (its interval grows towards 10 s
  // otherwise), and batch_sched_delay=0 starts the next array task as soon as one ends: an
  // array of four 1-s tasks, two at a time, took 10 s with Slurm's defaults and 4 s so.
  // cred_expire 10 (default 120) is also how long a requeued job waits before it may start
  // again: slurmd refuses the credential of a job it killed until that credential expires.
  const std::string conf = fmt::format(
      "ClusterName=solidfarm\n"
      "SlurmctldHost={host}(127.0.0.1)\n"
      "SlurmctldPort={controller_port}\n"
      "SlurmdPort={node_port}\n"
      "SlurmUser=root\n"
      "SlurmdUser=root\n"
      "AuthType=auth/munge\n"
      "CryptoType=crypto/munge\n"
      "AuthInfo=socket={socket},cred_expire=10\n"
      "StateSaveLocation={dir}/state\n"
      "SlurmdSpoolDir={dir}/spool\n"
      "SlurmctldPidFile={dir}/slurmctld.pid\n"
      "SlurmdPidFile={dir}/slurmd.pid\n"
      "SlurmctldLogFile={dir}/log/slurmctld.log\n"
      "SlurmdLogFile={dir}/log/slurmd.log\n"
      "ProctrackType=proctrack/linuxproc\n"
      "TaskPlugin=task/none\n"
      "JobAcctGatherType=jobacct_gather/none\n"
      "AccountingStorageType=accounting_storage/none\n"
      "JobCompType=jobcomp/none\n"
      "SelectType=select/cons_tres\n"
      "SelectTypeParameters=CR_Core\n"
      "MpiDefault=none\n"
      "ReturnToService=2\n"
      "KillWait=30\n"
      "MinJobAge=5\n"
      "SchedulerParameters=batch_sched_delay=0\n"
      "NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} RealMemory={memory} State=UNKNOWN\n"
      "PartitionName={partition} Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
      fmt::arg("host", host), fmt::arg("controller_port", controller_port), fmt::arg("node_port", node_port),
      fmt::arg("socket", socket.string()), fmt::arg("dir", dir_.string()), fmt::arg("cpus", cpus_),
      fmt::arg("memory", RealMemoryMiB()), fmt::arg("partition", partition_));
  SOLID_RETURN_IF_ERROR(WriteFile(dir_ / "slurm.conf", conf, fs::perms(0644)));

  // The daemons' own output goes to a file: a daemon keeping the pipe open would hang RunCommand.
  auto start = [&](const std::string& name, const std::string& arguments) -> Status {
    const fs::path output = dir_ / "log" / (name + ".start");
    const auto run = Run(fmt::format("PATH=\"$PATH:/usr/sbin:/sbin\" {} {} </dev/null >{} 2>&1", name, arguments,
                                     ShellQuote(output.string())));
    if (run.exit_status != 0) {
      return InternalError(fmt::format("{} did not start (exit {}): {}{}", name, run.exit_status, run.output,
                                       ReadText(output)));
    }
    return Status::Ok();
  };
  SOLID_RETURN_IF_ERROR(start(
      "munged", fmt::format("--key-file={} --socket={} --pid-file={} --log-file={} --seed-file={}",
                            ShellQuote((dir_ / "munge-key/munge.key").string()), ShellQuote(socket.string()),
                            ShellQuote((dir_ / "munge/munged.pid").string()),
                            ShellQuote((dir_ / "log/munged.log").string()),
                            ShellQuote((dir_ / "munge-key/munged.seed").string()))));
  SOLID_ASSIGN_OR_RETURN(const pid_t munged_pid, WaitForPidFile(dir_ / "munge/munged.pid", std::chrono::seconds(10)));
  daemons_.emplace_back("munged", munged_pid);

  for (const std::string daemon : {"slurmctld", "slurmd"}) {
    SOLID_RETURN_IF_ERROR(start(daemon, "-f " + ShellQuote((dir_ / "slurm.conf").string())));
    // slurmd writes its pid file once it has registered with slurmctld.
    SOLID_ASSIGN_OR_RETURN(const pid_t pid, WaitForPidFile(dir_ / (daemon + ".pid"), std::chrono::seconds(30)));
    daemons_.emplace_back(daemon, pid);
  }
  std::string state;
  const bool idle = WaitFor(
      [&] {
        state = Run("sinfo -h -N -o %T").output;
        return state == "idle\n";
      },
      std::chrono::seconds(30));
  if (!idle) return InternalError("the node did not become idle within 30 s; sinfo says: " + state);
  return Status::Ok();
}

SlurmCluster::~SlurmCluster() {
  if (const Status stopped = Stop(); !stopped.ok()) fmt::print(stderr, "slurm cluster: {}\n", stopped.ToString());
}

Status SlurmCluster::CancelAll() const {
  auto queue_empty = [&] {
    const auto queue = Run("squeue -h -o %i");
    return queue.exit_status == 0 && queue.output.empty();
  };
  if (queue_empty()) return Status::Ok();
  // scancel sends SIGTERM, then SIGKILL after KillWait; do not wait that long here.
  Run("scancel -p " + partition_);
  if (WaitFor(queue_empty, std::chrono::seconds(5))) return Status::Ok();
  Run("scancel -p " + partition_ + " --full --signal=KILL");
  if (WaitFor(queue_empty, std::chrono::seconds(15))) return Status::Ok();
  return InternalError("jobs still queued 20 s after scancel: " + Run("squeue").output);
}

Status SlurmCluster::Stop() {
  if (stopped_) return Status::Ok();
  stopped_ = true;
  const bool controller_up = std::any_of(daemons_.begin(), daemons_.end(), [](const auto& d) {
    return d.first == "slurmctld" && Alive(d.second);
  });
  Status status = controller_up ? CancelAll() : Status::Ok();
  for (auto it = daemons_.rbegin(); it != daemons_.rend(); ++it) {
    const pid_t pid = it->second;
    ::kill(pid, SIGTERM);
    if (!WaitFor([&] { return !Alive(pid); }, std::chrono::seconds(10))) {
      ::kill(pid, SIGKILL);
      WaitFor([&] { return !Alive(pid); }, std::chrono::seconds(2));
    }
  }
  const std::vector<pid_t> left = ProcessesOf(dir_, dir_ / "slurm.conf");
  if (left.empty()) return status;
  std::string names;
  for (const pid_t pid : left) {
    std::string cmdline = ReadText(fmt::format("/proc/{}/cmdline", pid));
    std::replace(cmdline.begin(), cmdline.end(), '\0', ' ');
    names += fmt::format("\n  {}: {}", pid, cmdline);
    ::kill(pid, SIGKILL);
  }
  return InternalError(fmt::format("{} process(es) of the cluster outlived it (now SIGKILLed):{}", left.size(), names));
}

std::string SlurmCluster::Environment() const {
  return "SLURM_CONF=" + ShellQuote((dir_ / "slurm.conf").string());
}

fixtures::CommandRun SlurmCluster::Run(const std::string& command) const {
  return fixtures::RunCommand("export " + Environment() + "; " + command);
}

Result<JobInfo> SlurmCluster::Job(const std::string& id) const {
  const auto run = Run("scontrol show job -o " + ShellQuote(id));
  if (run.exit_status != 0) return NotFoundError(fmt::format("scontrol show job {}: {}", id, run.output));
  JobInfo info;
  std::istringstream fields(run.output);
  for (std::string field; fields >> field;) {
    const size_t eq = field.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = field.substr(0, eq), value = field.substr(eq + 1);
    if (key == "JobState") info.state = value;
    if (key == "Reason") info.reason = value;
    if (key == "ExitCode") info.exit_code = value;
    if (key == "Restarts") info.restarts = std::atoi(value.c_str());
  }
  if (info.state.empty()) return ParseError(fmt::format("scontrol show job {}: no JobState in: {}", id, run.output));
  return info;
}

std::string SlurmCluster::LogTails() const {
  std::string out;
  for (const char* daemon : {"munged", "slurmctld", "slurmd"}) {
    const fs::path log = dir_ / "log" / (std::string(daemon) + ".log"), start = dir_ / "log" / (std::string(daemon) + ".start");
    out += fmt::format("--- {} (last lines)\n{}", log.string(),
                       fs::exists(log) ? Tail(log, 12) : std::string("(not written)\n"));
    if (const std::string printed = ReadText(start); !printed.empty()) {
      out += fmt::format("--- {} printed on starting\n{}", daemon, printed);
    }
  }
  return out;
}

}  // namespace solid::farm
