// Issue 43: `solid --version` names the version and the commit the binary was built from, and
// a rendered dataset's manifest records the same pair, so a dataset can be traced to its code.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include "fixtures/run_command.h"
#include "formats/test_util.h"
#include "render/test_assets.h"
#include "solid/formats/dataset.h"
#include "solid/formats/version.h"

namespace solid::cli {
namespace {

using fixtures::RunCommand;
using fixtures::ShellQuote;

TEST(Version, PrintsTheVersionAndTheCommitOfTheBuild) {
  const fixtures::CommandRun run = RunCommand(ShellQuote(SOLID_CLI_BINARY) + " --version");
  EXPECT_EQ(run.exit_status, 0);
  EXPECT_EQ(run.output, fmt::format("solid {} (commit {})\n", Version(), BuildCommit()));
}

// The commit is read at build time, not at configure time: a stale one would name code the
// binary does not contain. Where the sources are a git checkout (CI's clean clone is), it is
// their HEAD.
TEST(Version, TheCommitIsTheCheckoutsHead) {
  const fixtures::CommandRun head =
      RunCommand("git -C " + ShellQuote(SOLID_SOURCE_DIR) + " rev-parse --short=12 HEAD 2>/dev/null");
  if (head.exit_status != 0) GTEST_SKIP() << "the sources are not a git checkout";
  const std::string sha = head.output.substr(0, head.output.find('\n'));
  ASSERT_EQ(sha.size(), 12u) << head.output;
  EXPECT_EQ(std::string(BuildCommit()).substr(0, 12), sha);
}

TEST(Version, TheManifestsGeneratorCarriesTheSame) {
  solid::testing::TempDir dir;
  const std::string out = (dir.path() / "ds").string();
  const fixtures::CommandRun run = RunCommand(
      ShellQuote(SOLID_CLI_BINARY) + " render --preset random-placement --resolution 64x48 --assets " +
      ShellQuote(render::testing::ProceduralAssetsDir().string()) + " --out " + ShellQuote(out) +
      " --images 1 --shard-size 1 --spp 1 --no-queries");
  ASSERT_EQ(run.exit_status, 0) << run.output;
  Result<Manifest> manifest = ReadManifest(out);
  ASSERT_TRUE(manifest.ok()) << manifest.status().ToString();
  EXPECT_EQ(manifest->generator_name, "solid");
  EXPECT_EQ(manifest->generator_version, Version());
  EXPECT_EQ(manifest->git_sha, BuildCommit());
}

}  // namespace
}  // namespace solid::cli
