#include "solid/formats/file_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include <fmt/format.h>

namespace solid::files {

std::filesystem::path LockPathFor(const std::filesystem::path& guarded) { return guarded.string() + ".lock"; }

bool IsLockPath(const std::filesystem::path& path) { return path.extension() == ".lock"; }

Result<FileLock> FileLock::TryAcquire(const std::filesystem::path& guarded) {
  const std::filesystem::path path = LockPathFor(guarded);
  // A holder removes the file before it unlocks, so a lock won on a file that is no longer
  // the one at `path` guards nothing: open the current one and try again.
  for (;;) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) return IoError(fmt::format("{}: cannot create the lock file: {}", path.string(), std::strerror(errno)));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      ::close(fd);
      if (err == EWOULDBLOCK) return FileLock(path, State::kHeldByOther, -1);
      if (err == EINTR) continue;
      // ENOLCK, ENOSYS, EOPNOTSUPP, EINVAL: file systems without (or with disabled) flock.
      ::unlink(path.c_str());
      FileLock none(path, State::kUnsupported, -1);
      none.reason_ = fmt::format("{}: flock: {}", path.string(), std::strerror(err));
      return none;
    }
    struct stat held {}, current {};
    if (::fstat(fd, &held) == 0 && ::stat(path.c_str(), &current) == 0 && held.st_dev == current.st_dev &&
        held.st_ino == current.st_ino) {
      return FileLock(path, State::kHeld, fd);
    }
    ::close(fd);
  }
}

FileLock::FileLock(FileLock&& o) noexcept
    : path_(std::move(o.path_)), state_(o.state_), fd_(std::exchange(o.fd_, -1)), reason_(std::move(o.reason_)) {}

FileLock& FileLock::operator=(FileLock&& o) noexcept {
  if (this != &o) {
    Release();
    path_ = std::move(o.path_);
    state_ = o.state_;
    fd_ = std::exchange(o.fd_, -1);
    reason_ = std::move(o.reason_);
  }
  return *this;
}

FileLock::~FileLock() { Release(); }

void FileLock::Release() {
  if (fd_ < 0) return;
  ::unlink(path_.c_str());
  ::close(fd_);
  fd_ = -1;
}

}  // namespace solid::files
