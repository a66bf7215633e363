#include "solid/formats/files.h"

#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#include <atomic>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <memory>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include <fmt/format.h>

namespace solid::files {
namespace {

std::string HostName() {
  char buf[256] = {};
  if (gethostname(buf, sizeof buf - 1) != 0) return "host";
  std::string host(buf);
  for (char& c : host) {
    if (c == '/' || c == '-' || c == ' ') c = '_';
  }
  return host.empty() ? "host" : host;
}

Status ErrnoStatus(std::string_view what, const std::filesystem::path& path, int err) {
  StatusCode code = err == ENOENT ? StatusCode::kNotFound : err == EEXIST ? StatusCode::kAlreadyExists
                                                                           : StatusCode::kIoError;
  return Status(code, fmt::format("{}: {}: {}", path.string(), what, std::strerror(err)));
}

// A failed write is the output's fault, never the input's: a vanished output directory
// (ENOENT) is an I/O error like a full disk.
Status WriteErrnoStatus(std::string_view what, const std::filesystem::path& path, int err) {
  return Status(err == EEXIST ? StatusCode::kAlreadyExists : StatusCode::kIoError,
                fmt::format("{}: {}: {}", path.string(), what, std::strerror(err)));
}

class Fd {
 public:
  explicit Fd(int fd) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  int release() { return std::exchange(fd_, -1); }

 private:
  int fd_;
};

// Writes bytes to a new synced temporary sibling of path; on error nothing is left behind.
// The messages name the final path, which is what the user asked for: the temporary is gone
// by the time they read them.
Result<std::filesystem::path> WriteTemporary(const std::filesystem::path& path, std::span<const uint8_t> bytes) {
  std::filesystem::path temp = TempPathFor(path);
  Fd fd(::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  if (fd.get() < 0) return WriteErrnoStatus("create a temporary sibling", path, errno);
  Status s = WriteAll(fd.get(), bytes, path);
  if (s.ok() && ::fsync(fd.get()) != 0) s = WriteErrnoStatus("fsync", path, errno);
  if (!s.ok()) {
    ::unlink(temp.c_str());
    return s;
  }
  return temp;
}

}  // namespace

Status WriteAll(int fd, std::span<const uint8_t> bytes, const std::filesystem::path& path) {
  size_t done = 0;
  while (done < bytes.size()) {
    ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    // write() returns 0 only for a zero count, which the loop never asks for.
    if (n <= 0) return WriteErrnoStatus("write", path, n < 0 ? errno : EIO);
    done += static_cast<size_t>(n);
  }
  return Status::Ok();
}

Status WritePlainFile(const std::filesystem::path& path, std::span<const uint8_t> bytes) {
  Status s = [&]() -> Status {
    Fd fd(::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
    if (fd.get() < 0) return WriteErrnoStatus("create", path, errno);
    SOLID_RETURN_IF_ERROR(WriteAll(fd.get(), bytes, path));
    if (::close(fd.release()) != 0) return WriteErrnoStatus("close", path, errno);
    return Status::Ok();
  }();
  if (!s.ok()) ::unlink(path.c_str());
  return s;
}

std::filesystem::path TempPathFor(const std::filesystem::path& final_path) {
  // The sequence number keeps two writers of one file in the same process apart.
  static std::atomic<uint64_t> sequence{0};
  return final_path.string() + fmt::format(".tmp-{}-{}-{}", HostName(), ::getpid(), sequence++);
}

bool IsTempPath(const std::filesystem::path& path) {
  return path.filename().string().find(".tmp-") != std::string::npos;
}

void RemoveStaleTemps(const std::filesystem::path& final_path) {
  const std::string prefix = final_path.filename().string() + ".tmp-" + HostName() + "-";
  std::error_code ec;
  std::filesystem::path dir = final_path.parent_path().empty() ? "." : final_path.parent_path();
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    std::string name = entry.path().filename().string();
    if (!name.starts_with(prefix)) continue;
    std::string_view pid_text = std::string_view(name).substr(prefix.size());
    int pid = 0;
    auto [end, perr] = std::from_chars(pid_text.data(), pid_text.data() + pid_text.size(), pid);
    if (perr != std::errc() || end == pid_text.data() + pid_text.size() || *end != '-' || pid <= 0) continue;
    // A pid that still runs may be a concurrent writer of the same file: leave it.
    if (pid == ::getpid() || ::kill(pid, 0) == 0 || errno == EPERM) continue;
    // remove_all: an export's temporary is a whole directory (export/zarr.cpp).
    std::filesystem::remove_all(entry.path(), ec);
  }
}

Status SyncDirectory(const std::filesystem::path& dir) {
  std::filesystem::path d = dir.empty() ? "." : dir;
  Fd fd(::open(d.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (fd.get() < 0) return WriteErrnoStatus("open directory for fsync", d, errno);
  if (::fsync(fd.get()) != 0) return WriteErrnoStatus("fsync directory", d, errno);
  return Status::Ok();
}

Status Publish(const std::filesystem::path& temp, const std::filesystem::path& final_path, bool replace) {
  if (replace) {
    if (::rename(temp.c_str(), final_path.c_str()) != 0) {
      return WriteErrnoStatus("rename into place", final_path, errno);
    }
  } else if (::renameat2(AT_FDCWD, temp.c_str(), AT_FDCWD, final_path.c_str(), RENAME_NOREPLACE) != 0) {
    int err = errno;
    if (err != EINVAL && err != ENOSYS) return WriteErrnoStatus("rename into place", final_path, err);
    // File systems without RENAME_NOREPLACE: link() fails on an existing target just the same.
    if (::link(temp.c_str(), final_path.c_str()) != 0) return WriteErrnoStatus("link into place", final_path, errno);
    ::unlink(temp.c_str());
  }
  return SyncDirectory(final_path.parent_path());
}

Status SyncAndPublish(const std::filesystem::path& temp, const std::filesystem::path& final_path, bool replace) {
  Status s = [&]() -> Status {
    Fd fd(::open(temp.c_str(), O_RDONLY | O_CLOEXEC));
    if (fd.get() < 0) return WriteErrnoStatus("open the temporary sibling for fsync", final_path, errno);
    if (::fsync(fd.get()) != 0) return WriteErrnoStatus("fsync", final_path, errno);
    return Publish(temp, final_path, replace);
  }();
  if (!s.ok()) ::unlink(temp.c_str());
  return s;
}

Result<AtomicFileWriter> AtomicFileWriter::Create(const std::filesystem::path& final_path) {
  AtomicFileWriter w;
  w.final_ = final_path;
  w.temp_ = TempPathFor(final_path);
  w.fd_ = ::open(w.temp_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (w.fd_ < 0) return WriteErrnoStatus("create a temporary sibling", final_path, errno);
  return w;
}

AtomicFileWriter::AtomicFileWriter(AtomicFileWriter&& o) noexcept
    : final_(std::move(o.final_)), temp_(std::exchange(o.temp_, {})), fd_(std::exchange(o.fd_, -1)),
      buffer_(std::move(o.buffer_)) {}

AtomicFileWriter::~AtomicFileWriter() {
  if (fd_ >= 0) ::close(fd_);
  if (!temp_.empty()) ::unlink(temp_.c_str());
}

Status AtomicFileWriter::Write(std::span<const uint8_t> bytes) {
  if (temp_.empty()) return InternalError(final_.string() + ": written after an error or its commit");
  // Small writes gather into writes of about 1 MiB; a large one goes out as it is.
  constexpr size_t kBuffer = 1 << 20;
  if (buffer_.size() + bytes.size() < kBuffer) {
    buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
    return Status::Ok();
  }
  return Flush(bytes);
}

Status AtomicFileWriter::Write(std::string_view text) {
  return Write({reinterpret_cast<const uint8_t*>(text.data()), text.size()});
}

Status AtomicFileWriter::Flush(std::span<const uint8_t> more) {
  Status s = WriteAll(fd_, buffer_, final_);
  if (s.ok()) s = WriteAll(fd_, more, final_);
  buffer_.clear();
  if (!s.ok()) {
    ::close(std::exchange(fd_, -1));
    ::unlink(std::exchange(temp_, {}).c_str());
  }
  return s;
}

Status AtomicFileWriter::Commit() {
  if (temp_.empty()) return InternalError(final_.string() + ": committed after an error or its commit");
  SOLID_RETURN_IF_ERROR(Flush());
  Status s = ::fsync(fd_) == 0 ? Status::Ok() : WriteErrnoStatus("fsync", final_, errno);
  if (::close(std::exchange(fd_, -1)) != 0 && s.ok()) s = WriteErrnoStatus("close", final_, errno);
  if (s.ok()) s = Publish(temp_, final_, /*replace=*/true);
  // Renamed, the temporary's name is free; failed, it is removed.
  ::unlink(std::exchange(temp_, {}).c_str());
  return s;
}

Status WriteFileAtomically(const std::filesystem::path& path, std::span<const uint8_t> bytes) {
  SOLID_ASSIGN_OR_RETURN(AtomicFileWriter writer, AtomicFileWriter::Create(path));
  SOLID_RETURN_IF_ERROR(writer.Write(bytes));
  return writer.Commit();
}

Status WriteFilesAtomically(std::span<const FileContent> outputs) {
  std::vector<std::filesystem::path> temps;
  Status s;
  for (const FileContent& f : outputs) {
    Result<std::filesystem::path> temp = WriteTemporary(f.path, f.bytes);
    if (!temp.ok()) {
      s = temp.status();
      break;
    }
    temps.push_back(*temp);
  }
  for (size_t i = 0; s.ok() && i < temps.size(); ++i) s = Publish(temps[i], outputs[i].path, /*replace=*/true);
  // Temporaries not yet renamed (unlinking a renamed one finds nothing).
  if (!s.ok()) {
    for (const std::filesystem::path& t : temps) ::unlink(t.c_str());
  }
  return s;
}

Result<std::vector<uint8_t>> ReadFile(const std::filesystem::path& path, uint64_t max_bytes) {
  Fd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (fd.get() < 0) return ErrnoStatus("open", path, errno);
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0) return ErrnoStatus("stat", path, errno);
  if (!S_ISREG(st.st_mode)) return InvalidArgumentError(path.string() + ": not a regular file");
  if (static_cast<uint64_t>(st.st_size) > max_bytes) {
    return LimitExceededError(fmt::format("{}: {} bytes, more than the limit of {}", path.string(),
                                          st.st_size, max_bytes));
  }
  std::vector<uint8_t> out(static_cast<size_t>(st.st_size));
  size_t done = 0;
  while (done < out.size()) {
    ssize_t n = ::read(fd.get(), out.data() + done, out.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return ErrnoStatus("read", path, errno);
    if (n == 0) break;
    done += static_cast<size_t>(n);
  }
  out.resize(done);
  return out;
}

bool IsInside(const std::filesystem::path& path, const std::filesystem::path& root) {
  // "a/b/" and "a/b" are the same directory; lexically_relative tells them apart.
  auto strip = [](std::filesystem::path p) {
    p = p.lexically_normal();
    return p.has_filename() || !p.has_relative_path() ? p : p.parent_path();
  };
  const std::filesystem::path relative = strip(path).lexically_relative(strip(root));
  return !relative.empty() && *relative.begin() != "..";
}

Result<std::filesystem::path> ResolveInside(const std::filesystem::path& root, std::string_view relative) {
  namespace fs = std::filesystem;
  const fs::path written(relative);
  auto refuse = [&](std::string_view why) {
    return CorruptError(fmt::format("path '{}' {}", relative, why));
  };
  if (relative.empty()) return refuse("is empty");
  if (relative.find('\0') != std::string_view::npos) return refuse("holds a NUL byte");
  if (written.is_absolute() || written.has_root_path()) return refuse(fmt::format("is absolute; it must lie inside {}", root.string()));
  std::error_code ec;
  const fs::path base = fs::absolute(root, ec).lexically_normal();
  if (ec) return IoError(fmt::format("{}: {}", root.string(), ec.message()));
  const fs::path resolved = (base / written).lexically_normal();
  if (!IsInside(resolved, base)) return refuse(fmt::format("leaves {}", root.string()));
  if (resolved.lexically_relative(base) == ".") return refuse(fmt::format("names {} itself", root.string()));
  // A symbolic link on the way may point anywhere: compare the real paths too.
  if (fs::is_symlink(fs::symlink_status(resolved, ec)) && !fs::exists(resolved, ec)) {
    return refuse("is a dangling symbolic link");
  }
  const fs::path real = fs::weakly_canonical(resolved, ec);
  const fs::path real_root = ec ? fs::path() : fs::weakly_canonical(base, ec);
  if (ec) return IoError(fmt::format("{}: {}", resolved.string(), ec.message()));
  if (!IsInside(real, real_root)) return refuse(fmt::format("leaves {} through a symbolic link", root.string()));
  return resolved;
}

Result<FileDigest> DigestFile(const std::filesystem::path& path) {
  Fd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (fd.get() < 0) return ErrnoStatus("open", path, errno);
  std::unique_ptr<XXH64_state_t, decltype(&XXH64_freeState)> state(XXH64_createState(), XXH64_freeState);
  XXH64_reset(state.get(), 0);
  // Uninitialized on purpose: zeroing a buffer that read() overwrites costs more than the hash.
  constexpr size_t kChunk = 256 << 10;
  auto buf = std::make_unique_for_overwrite<uint8_t[]>(kChunk);
  FileDigest digest;
  for (;;) {
    ssize_t n = ::read(fd.get(), buf.get(), kChunk);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return ErrnoStatus("read", path, errno);
    if (n == 0) break;
    XXH64_update(state.get(), buf.get(), static_cast<size_t>(n));
    digest.bytes += static_cast<uint64_t>(n);
  }
  digest.xxh64 = XXH64_digest(state.get());
  return digest;
}

}  // namespace solid::files
