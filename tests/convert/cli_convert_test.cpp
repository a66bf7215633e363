// `solid convert` as a user runs it: flags reach the library and its report reaches the
// terminal, with the exit codes of cli/exit_codes.h.
#include <gtest/gtest.h>

#include <filesystem>

#include "fixtures/input_trees.h"
#include "fixtures/run_command.h"
#include "formats/test_util.h"

namespace solid {
namespace {

namespace fs = std::filesystem;
using fixtures::RunCommand;
using fixtures::ShellQuote;
using testing::TempDir;

std::string Solid(const std::string& arguments) { return ShellQuote(SOLID_CLI_BINARY) + " " + arguments; }

TEST(CliConvert, SceneNetTextureLibraryCopiesFoldersAndListsUnmatchedMaterials) {
  TempDir dir;
  const fs::path root = dir.path() / "scenenet", out = dir.path() / "assets";
  ASSERT_OK(fixtures::WriteSceneNetTree(root));
  const auto run = RunCommand(Solid("convert scenenet " + ShellQuote(root.string()) + " " + ShellQuote(out.string()) +
                                    " --texture-library --jobs 2"));
  // The fixture tree holds a room in millimetres, which fails (suspect_units): a batch with
  // failed items exits 1 and names the reason, and the rest is converted.
  ASSERT_EQ(run.exit_status, 1) << run.output;
  EXPECT_NE(run.output.find("suspect_units"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("unknown/ created"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("Walls.132 -> Walls/"), std::string::npos) << run.output;
  for (const char* category : {"ceiling", "floor", "painting", "wall", "wood", "unknown"}) {
    EXPECT_TRUE(fs::is_directory(out / "textures" / category)) << category;
  }

  // Without the flag nothing is copied and nothing is said about textures.
  const fs::path plain = dir.path() / "plain";
  const auto without = RunCommand(Solid("convert scenenet " + ShellQuote(root.string()) + " " +
                                        ShellQuote(plain.string()) + " --jobs 2"));
  ASSERT_EQ(without.exit_status, 1) << without.output;
  EXPECT_EQ(without.output.find("unmatched folders"), std::string::npos) << without.output;
  EXPECT_FALSE(fs::exists(plain / "textures"));
}

TEST(CliConvert, MissingTextureLibraryIsAnErrorThatNamesTheFolder) {
  TempDir dir;
  const fs::path root = dir.path() / "scenenet";
  ASSERT_OK(fixtures::WriteSceneNetTree(root));
  fs::remove_all(root / "texture_library");
  const auto run = RunCommand(Solid("convert scenenet " + ShellQuote(root.string()) + " " +
                                    ShellQuote((dir.path() / "out").string()) + " --texture-library"));
  EXPECT_EQ(run.exit_status, 3) << run.output;  // exit_codes.h: kExitBadInput
  EXPECT_NE(run.output.find("texture_library"), std::string::npos) << run.output;
}

TEST(CliConvert, UnknownFlagIsAUsageError) {
  const auto run = RunCommand(Solid("convert procedural /nonexistent --no-such-flag"));
  EXPECT_EQ(run.exit_status, 2) << run.output;  // exit_codes.h: kExitUsage
}

}  // namespace
}  // namespace solid
