#include "signals.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <string_view>
#include <vector>

#include "exit_codes.h"

namespace solid::cli {
namespace {

CancelFlag stop_requested{false};
std::atomic<int> stop_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "set from a signal handler");
std::vector<std::string> command_line;

void OnStopSignal(int signo) {
  // Only async-signal-safe work here: lock-free atomic stores and write(2).
  int expected = 0;
  stop_signal.compare_exchange_strong(expected, signo);
  stop_requested.store(true);
  constexpr std::string_view kMessage =
      "\nsolid: stopping at the next clean point (signal again to stop at once, leaving what a kill leaves)\n";
  [[maybe_unused]] const ssize_t written = ::write(STDERR_FILENO, kMessage.data(), kMessage.size());
}

std::string ShellWord(const std::string& word) {
  const bool plain = !word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                                             "0123456789-_=+./:,@%") == std::string::npos;
  if (plain) return word;
  std::string quoted = "'";
  for (char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace

void SetCommandLine(int argc, char** argv) { command_line.assign(argv, argv + argc); }

std::string CommandLine() {
  std::string out;
  for (const std::string& a : command_line) {
    if (!out.empty()) out += ' ';
    out += ShellWord(a);
  }
  return out;
}

const CancelFlag* InstallStopHandlers() {
  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  sigemptyset(&action.sa_mask);
  // SA_RESETHAND: the second signal gets the default action (the process ends at once).
  // SA_RESTART: system calls under way go on; the work stops where the flag is polled.
  action.sa_flags = SA_RESETHAND | SA_RESTART;
  for (int signo : {SIGINT, SIGTERM}) {
    struct sigaction previous {};
    sigaction(signo, nullptr, &previous);
    // A shell starts background jobs with SIGINT ignored; that choice stands.
    if (previous.sa_handler == SIG_IGN) continue;
    sigaction(signo, &action, nullptr);
  }
  return &stop_requested;
}

int StopSignal() { return stop_signal.load(); }

std::string StopSignalName() {
  switch (StopSignal()) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    default: return "a signal";
  }
}

int StopExitCode() { return StopSignal() == SIGTERM ? kExitSigterm : kExitSigint; }

}  // namespace solid::cli
