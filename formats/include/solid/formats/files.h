// Atomic publication of files (write to a temporary sibling, sync,
// rename) so that a reader never sees a partial file, whatever kills the writer;
// and confinement of paths that come from data to the directory they belong to.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string_view>
#include <vector>

#include "solid/formats/status.h"

namespace solid::files {

// "<final>.tmp-<host>-<pid>-<n>": unique per writer, recognisable as ours.
std::filesystem::path TempPathFor(const std::filesystem::path& final_path);
bool IsTempPath(const std::filesystem::path& path);

// Removes "<final>.tmp-<this host>-<pid>-<n>" leftovers of writers that no longer run,
// files or whole directories.
void RemoveStaleTemps(const std::filesystem::path& final_path);

Status SyncDirectory(const std::filesystem::path& dir);

// Renames temp onto final and syncs the directory. With replace == false the
// rename fails with kAlreadyExists if final exists (two writers of one shard).
Status Publish(const std::filesystem::path& temp, const std::filesystem::path& final_path, bool replace);

// Syncs temp, a finished temporary sibling of final_path (a database written in place),
// and publishes it. On error temp is removed; messages name final_path.
Status SyncAndPublish(const std::filesystem::path& temp, const std::filesystem::path& final_path, bool replace);

// A file written as a stream and published atomically: the bytes go, buffered, to a
// temporary sibling of the final path (TempPathFor); Commit syncs it and renames it into
// place, replacing what is there. Destroyed uncommitted (an error, a cancel), it removes the
// temporary: a reader sees the old file or the whole new one, never part of one. Messages
// name the final path. Not thread-safe.
class AtomicFileWriter {
 public:
  static Result<AtomicFileWriter> Create(const std::filesystem::path& final_path);
  AtomicFileWriter(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter& operator=(AtomicFileWriter&&) = delete;
  ~AtomicFileWriter();

  Status Write(std::span<const uint8_t> bytes);
  Status Write(std::string_view text);
  // After an error, or once committed, the writer writes nothing more.
  Status Commit();

 private:
  AtomicFileWriter() = default;
  // Writes the buffer, then `more`; on error abandons the temporary.
  Status Flush(std::span<const uint8_t> more = {});
  std::filesystem::path final_, temp_;
  int fd_ = -1;
  std::vector<uint8_t> buffer_;
};

// Whole-file write through a synced temporary sibling (an AtomicFileWriter). On error the
// file at path is as it was, and no temporary is left.
Status WriteFileAtomically(const std::filesystem::path& path, std::span<const uint8_t> bytes);

// Writes all of bytes to fd, through short writes and EINTR; messages name path.
Status WriteAll(int fd, std::span<const uint8_t> bytes, const std::filesystem::path& path);

// Creates or truncates path and writes bytes, without sync or rename: for the many small
// files of an output that another file publishes (an export's images, which annotations.json
// names). On error the file is removed, so none is left half-written.
Status WritePlainFile(const std::filesystem::path& path, std::span<const uint8_t> bytes);

// The outputs of one command: none is renamed into place before all are written and
// synced, so a full disk changes none of them. Then they are renamed in order; a failed
// rename (rare, after the writes succeeded) leaves those before it published.
struct FileContent {
  std::filesystem::path path;
  std::span<const uint8_t> bytes;
};
Status WriteFilesAtomically(std::span<const FileContent> outputs);

// Reads a whole file, refusing more than max_bytes.
Result<std::vector<uint8_t>> ReadFile(const std::filesystem::path& path, uint64_t max_bytes);

// Lexically (no file system access): whether `path`, once normalised, is `root` or lies
// below it. Both should be absolute, or both relative to the same directory.
bool IsInside(const std::filesystem::path& path, const std::filesystem::path& root);

// A path read from untrusted data (a catalog row, an index row) that must name something
// inside `root`, resolved: root / relative, normalised. kCorrupt, naming `relative` and
// the reason, when `relative` is empty, absolute, has a root name, leaves `root` through
// "..", or names an existing file whose real path (symbolic links followed) lies outside
// the real path of `root`. A path that does not exist yet passes on its lexical form;
// its reader then fails with kNotFound. Callers add the row to the message.
Result<std::filesystem::path> ResolveInside(const std::filesystem::path& root, std::string_view relative);

// XXH64 and size of a whole file, streamed.
struct FileDigest {
  uint64_t bytes = 0;
  uint64_t xxh64 = 0;
};
Result<FileDigest> DigestFile(const std::filesystem::path& path);

}  // namespace solid::files
