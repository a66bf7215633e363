// files::FileLock: one holder at a time, released on destruction and with its process,
// and never a lock file left behind by a holder that let go.
#include "solid/formats/file_lock.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>

#include "formats/test_util.h"

namespace solid::files {
namespace {

namespace fs = std::filesystem;
using solid::testing::TempDir;

TEST(FileLock, OneHolderAtATime) {
  TempDir dir;
  const fs::path shard = dir.path() / "shard-000000.sqlite";
  {
    FileLock first = FileLock::TryAcquire(shard).value();
    EXPECT_EQ(first.state(), FileLock::State::kHeld);
    EXPECT_TRUE(fs::exists(LockPathFor(shard)));
    FileLock second = FileLock::TryAcquire(shard).value();
    EXPECT_EQ(second.state(), FileLock::State::kHeldByOther);
    // Moving keeps the one lock.
    FileLock moved = std::move(first);
    EXPECT_EQ(FileLock::TryAcquire(shard).value().state(), FileLock::State::kHeldByOther);
  }
  EXPECT_FALSE(fs::exists(LockPathFor(shard)));
  EXPECT_TRUE(FileLock::TryAcquire(shard).value().held());
}

TEST(FileLock, ALeftoverLockFileIsNoLock) {
  TempDir dir;
  const fs::path shard = dir.path() / "shard-000001.sqlite";
  { std::ofstream(LockPathFor(shard)) << ""; }
  EXPECT_TRUE(FileLock::TryAcquire(shard).value().held());
}

// A holder killed with SIGKILL keeps nobody out: the kernel drops its flock.
TEST(FileLock, AKilledHolderReleasesTheLock) {
  TempDir dir;
  const fs::path shard = dir.path() / "shard-000002.sqlite";
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t child = fork();
  if (child == 0) {
    Result<FileLock> lock = FileLock::TryAcquire(shard);
    const char ok = lock.ok() && lock->held() ? 'y' : 'n';
    [[maybe_unused]] const ssize_t n = write(ready[1], &ok, 1);
    pause();
    _exit(0);
  }
  char ok = 0;
  ASSERT_EQ(read(ready[0], &ok, 1), 1);
  ASSERT_EQ(ok, 'y');
  EXPECT_EQ(FileLock::TryAcquire(shard).value().state(), FileLock::State::kHeldByOther);
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  close(ready[0]);
  close(ready[1]);
  EXPECT_TRUE(fs::exists(LockPathFor(shard)));  // the file stays; the lock does not
  EXPECT_TRUE(FileLock::TryAcquire(shard).value().held());
}

TEST(FileLock, LockPathsAreRecognised) {
  EXPECT_EQ(LockPathFor("shards/shard-000003.sqlite"), fs::path("shards/shard-000003.sqlite.lock"));
  EXPECT_TRUE(IsLockPath("shards/shard-000003.sqlite.lock"));
  EXPECT_FALSE(IsLockPath("shards/shard-000003.sqlite"));
}

}  // namespace
}  // namespace solid::files
