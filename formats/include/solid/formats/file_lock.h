// Exclusive advisory locks between processes (two `solid render` on one shard): flock(2)
// on "<file>.lock" next to the file it guards. The kernel drops a flock when its holder
// exits, however it exits, so a killed process never leaves a lock that blocks anyone; the
// lock file itself is removed on release, and a leftover one (its holder was killed) is
// simply locked again by the next process. Needs a file system with working flock: local
// ones, NFSv4, CephFS, Lustre mounted with -o flock.
#pragma once

#include <filesystem>
#include <string>

#include "solid/formats/status.h"

namespace solid::files {

// "<guarded>.lock"
std::filesystem::path LockPathFor(const std::filesystem::path& guarded);
bool IsLockPath(const std::filesystem::path& path);

class FileLock {
 public:
  enum class State {
    kHeld,          // this object holds the lock
    kHeldByOther,   // another process (or another FileLock of this one) holds it
    kUnsupported,   // the file system refuses flock: nobody can lock, callers go on unlocked
  };
  // Tries once, never waits. Errors: the lock file cannot be created.
  static Result<FileLock> TryAcquire(const std::filesystem::path& guarded);

  State state() const { return state_; }
  bool held() const { return state_ == State::kHeld; }
  const std::filesystem::path& path() const { return path_; }
  const std::string& unsupported_reason() const { return reason_; }

  FileLock(FileLock&& o) noexcept;
  FileLock& operator=(FileLock&& o) noexcept;
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;
  ~FileLock();  // releases a held lock: removes the lock file, then unlocks

 private:
  FileLock(std::filesystem::path path, State state, int fd) : path_(std::move(path)), state_(state), fd_(fd) {}
  void Release();
  std::filesystem::path path_;
  State state_ = State::kHeldByOther;
  int fd_ = -1;
  std::string reason_;
};

}  // namespace solid::files
