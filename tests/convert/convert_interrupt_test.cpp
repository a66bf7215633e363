// `solid convert` interrupted: SIGKILL at random points, or SIGTERM/SIGINT, then rerun.
// The catalog is never corrupt, no row points at a missing or different file, and the
// rerun ends with the assets and catalog of an undisturbed run.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <thread>

#include "fixtures/background_process.h"
#include "fixtures/input_trees.h"
#include "fixtures/run_command.h"
#include "formats/test_util.h"
#include "solid/formats/catalog.h"
#include "solid/formats/checksum.h"
#include "solid/formats/files.h"
#include "solid/formats/random.h"

namespace solid {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

// What an assets directory holds: every row's content, and every .glb's bytes by path.
struct AssetsDigest {
  std::map<std::string, std::string> rows;
  std::map<std::string, uint64_t> files;
  friend bool operator==(const AssetsDigest&, const AssetsDigest&) = default;
};

// Fails the test (and says why) if the catalog is unreadable or a row's file is absent or
// differs from the row.
AssetsDigest Digest(const fs::path& out) {
  AssetsDigest d;
  Result<Catalog> catalog = Catalog::OpenReadOnly(out / "catalog.sqlite");
  EXPECT_OK(catalog.status());
  if (!catalog.ok()) return d;
  Result<std::vector<CatalogEntry>> rows = catalog->All();
  EXPECT_OK(rows.status());
  for (const CatalogEntry& e : rows.ok() ? *rows : std::vector<CatalogEntry>{}) {
    d.rows[e.key] = fmt::format("{} {} {} {:x} {:x} {} {} {} {}", e.kind, e.source, AssetStatusName(e.status),
                                e.input_hash, e.output_xxh64.value_or(0), e.file.value_or("-"),
                                e.error_code.value_or("-"), e.warnings.dump(), e.counts.dump());
    if (!e.file) continue;
    Result<files::FileDigest> file = files::DigestFile(out / *e.file);
    EXPECT_TRUE(file.ok() && file->xxh64 == e.output_xxh64) << e.key << ": the row's file is missing or differs";
  }
  for (const auto& entry : fs::recursive_directory_iterator(out)) {
    if (entry.path().extension() != ".glb") continue;
    d.files[fs::relative(entry.path(), out).generic_string()] = files::DigestFile(entry.path()).value().xxh64;
  }
  return d;
}

bool AnyTemp(const fs::path& out) {
  for (const auto& entry : fs::recursive_directory_iterator(out)) {
    if (files::IsTempPath(entry.path())) return true;
  }
  return false;
}

std::vector<std::string> Procedural(const fs::path& out) {
  return {SOLID_CLI_BINARY, "convert", "procedural", out.string(), "--models", "12", "--rooms", "2",
          "--min-triangles", "2000", "--max-triangles", "6000", "--seed", "4", "--jobs", "2"};
}

std::vector<std::string> ShapeNet(const fs::path& root, const fs::path& out) {
  return {SOLID_CLI_BINARY, "convert", "shapenet", root.string(), out.string(), "--jobs", "2"};
}

std::string Shell(const std::vector<std::string>& arguments) {
  std::string command;
  for (const std::string& a : arguments) command += (command.empty() ? "" : " ") + fixtures::ShellQuote(a);
  return command;
}

// Runs `arguments` for random short times and SIGKILLs them, checking the catalog after
// each kill; then reruns to the end. Returns the kills that hit a running process.
int KillAtRandomPoints(const std::vector<std::string>& arguments, const fs::path& out, const fs::path& log,
                       uint64_t seed) {
  Rng rng(seed, 1);
  int kills = 0;
  for (int attempt = 0; attempt < 12; ++attempt) {
    fixtures::BackgroundProcess convert(arguments, log);
    std::this_thread::sleep_for(std::chrono::microseconds(rng.Int(2000, 120000)));
    if (!convert.Running()) break;
    convert.Signal(SIGKILL);
    convert.Wait();
    ++kills;
    if (fs::exists(out / "catalog.sqlite")) Digest(out);
  }
  return kills;
}

TEST(ConvertInterrupt, KilledProceduralConvertsResumeToTheSameAssets) {
  TempDir dir;
  const auto reference = fixtures::RunCommand(Shell(Procedural(dir.path() / "reference")));
  ASSERT_EQ(reference.exit_status, 0) << reference.output;
  const fs::path out = dir.path() / "killed";
  EXPECT_GE(KillAtRandomPoints(Procedural(out), out, dir.path() / "log", 0x6b1), 3);
  const auto rerun = fixtures::RunCommand(Shell(Procedural(out)));
  ASSERT_EQ(rerun.exit_status, 0) << rerun.output;
  EXPECT_FALSE(AnyTemp(out));
  EXPECT_EQ(Digest(out), Digest(dir.path() / "reference"));
}

TEST(ConvertInterrupt, KilledShapeNetConvertsResumeToTheSameAssets) {
  TempDir dir;
  const fs::path root = dir.path() / "ShapeNetCore.v2";
  ASSERT_OK(fixtures::WriteShapeNetV2Tree(root));
  // The tree holds two broken models: the batch exits 1, the same way every time.
  const auto reference = fixtures::RunCommand(Shell(ShapeNet(root, dir.path() / "reference")));
  ASSERT_EQ(reference.exit_status, 1) << reference.output;
  const fs::path out = dir.path() / "killed";
  KillAtRandomPoints(ShapeNet(root, out), out, dir.path() / "log", 0x6b2);
  const auto rerun = fixtures::RunCommand(Shell(ShapeNet(root, out)));
  ASSERT_EQ(rerun.exit_status, 1) << rerun.output;
  EXPECT_FALSE(AnyTemp(out));
  EXPECT_EQ(Digest(out), Digest(dir.path() / "reference"));
}

// SIGTERM and SIGINT: the assets in flight are finished, the run exits 143 or 130 and
// names what is done and the command that resumes; the rerun completes the same assets.
TEST(ConvertInterrupt, StopSignalsFinishTheAssetsInFlightAndTheRerunResumes) {
  TempDir dir;
  const auto reference = fixtures::RunCommand(Shell(Procedural(dir.path() / "reference")));
  ASSERT_EQ(reference.exit_status, 0) << reference.output;
  const fs::path out = dir.path() / "stopped";
  Rng rng(0x6b3, 1);
  int stops = 0;
  for (int attempt = 0; attempt < 5; ++attempt) {
    const int signo = attempt % 2 == 0 ? SIGINT : SIGTERM;
    fixtures::BackgroundProcess convert(Procedural(out), dir.path() / "log");
    ASSERT_TRUE(convert.WaitUntil([&] { return convert.Catches(signo); }, std::chrono::seconds(60)));
    std::this_thread::sleep_for(std::chrono::microseconds(rng.Int(0, 80000)));
    convert.Signal(signo);
    const int exit = convert.Wait();
    const std::string output = convert.Output();
    if (exit == 0) break;
    ++stops;
    ASSERT_EQ(exit, signo == SIGTERM ? 143 : 130) << output;
    EXPECT_NE(output.find("assets done, each with its file and catalog row"), std::string::npos) << output;
    EXPECT_NE(output.find("to resume, run the same command again"), std::string::npos) << output;
    EXPECT_FALSE(AnyTemp(out)) << output;
    Digest(out);
  }
  EXPECT_GE(stops, 2);
  const auto rerun = fixtures::RunCommand(Shell(Procedural(out)));
  ASSERT_EQ(rerun.exit_status, 0) << rerun.output;
  EXPECT_EQ(Digest(out), Digest(dir.path() / "reference"));
}

}  // namespace
}  // namespace solid
