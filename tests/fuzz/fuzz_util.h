// Shared by the fuzz targets and the seed generator.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <string_view>

#include "fixtures/layered_dataset.h"

namespace solid::fuzz {

// Prints and aborts: a broken reader contract is a finding, like a sanitizer report.
[[noreturn]] inline void Fail(std::string_view what) {
  std::fprintf(stderr, "fuzz contract broken: %.*s\n", static_cast<int>(what.size()), what.data());
  std::abort();
}

// A directory of this process for readers that take a path (SQLite files, a dataset):
// on tmpfs when there is one, since every execution writes a file. Parallel workers
// (-jobs, -workers) are separate processes and get separate directories. Removed at exit;
// a crash leaves it behind (with the file that crashed, for inspection).
inline const std::filesystem::path& ScratchDir() {
  static const std::filesystem::path dir = [] {
    std::error_code ec;
    std::filesystem::path base = std::filesystem::is_directory("/dev/shm", ec) && access("/dev/shm", W_OK) == 0
                                     ? std::filesystem::path("/dev/shm")
                                     : std::filesystem::temp_directory_path();
    std::string pattern = (base / "solid-fuzz-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) Fail("cannot create a scratch directory");
    std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(ScratchDir(), ignored);
    });
    return std::filesystem::path(pattern);
  }();
  return dir;
}

inline void WriteFileOrDie(const std::filesystem::path& path, std::span<const uint8_t> bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) Fail("cannot write " + path.string());
}

// A SQLite file and its companions: a mutated header can switch an input to WAL mode,
// and the -wal/-shm files SQLite then creates must not leak into the next execution.
inline void RemoveSqliteFiles(const std::filesystem::path& path) {
  std::error_code ec;
  for (const char* suffix : {"", "-wal", "-shm", "-journal"}) std::filesystem::remove(path.string() + suffix, ec);
}

// The dataset behind the shard, query-shard and index seeds, and the one the index
// target reads its mutated index.sqlite against: small, so that the seeds are a few KiB.
inline fixtures::LayeredDatasetOptions SeedDatasetOptions() {
  fixtures::LayeredDatasetOptions o;
  o.seed = 7;
  o.images = 2;
  o.shard_size = 2;
  o.width = 32;
  o.height = 24;
  o.max_objects = 3;
  o.models = 2;
  o.depth = true;
  return o;
}

}  // namespace solid::fuzz
