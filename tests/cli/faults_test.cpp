// Every writing command under injected I/O faults (tests/fixtures/fault_inject.c, loaded
// with LD_PRELOAD into the `solid` process): a full disk, a read-only or vanished output
// directory, a failed rename, a failed fsync. Each command must exit with the I/O exit code
// and a message naming the path and the cause, leave nothing partial and nothing of an
// earlier run changed, and a rerun without the fault must end where an undisturbed run ends.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <map>
#include <set>
#include <sstream>

#include "fixtures/run_command.h"
#include "formats/test_util.h"
#include "render/dataset_digest.h"
#include "render/test_assets.h"
#include "solid/formats/catalog.h"
#include "solid/formats/checksum.h"
#include "solid/formats/files.h"
#include "solid/formats/index.h"
#include "solid/formats/validate.h"

namespace solid::cli {
namespace {

namespace fs = std::filesystem;
using fixtures::CommandRun;
using fixtures::RunCommand;
using fixtures::ShellQuote;
using solid::testing::TempDir;

constexpr int kExitIoError = 4;

enum class Command { kConvert, kRender, kIndex, kOptimize, kExport, kExportZarr };

std::string_view CommandName(Command c) {
  switch (c) {
    case Command::kConvert: return "Convert";
    case Command::kRender: return "Render";
    case Command::kIndex: return "Index";
    case Command::kOptimize: return "Optimize";
    case Command::kExport: return "Export";
    case Command::kExportZarr: return "ExportZarr";
  }
  return "?";
}

struct Fault {
  std::string name;
  std::string spec;   // CLASS=ERRNO of SOLID_FAULT
  int error_number;   // whose strerror text the message must show
  bool partial;       // a write budget of half the command's output, so that it fails mid-way
};

const Fault kFaults[] = {
    {"NoSpace", "write=ENOSPC", ENOSPC, true},
    {"ReadOnlyDirectory", "create=EROFS", EROFS, false},
    {"VanishedDirectory", "create=ENOENT", ENOENT, false},
    {"FailedRename", "rename=EIO", EIO, false},
    {"FailedFsync", "fsync=EIO", EIO, false},
};
// The same rename as FailedRename with another errno: once is enough.
const Fault kCrossDeviceRename = {"CrossDeviceRename", "rename=EXDEV", EXDEV, false};

void PrintTo(Command c, std::ostream* os) { *os << CommandName(c); }
void PrintTo(const Fault& f, std::ostream* os) { *os << f.name; }

std::string Shell(const std::vector<std::string>& arguments) {
  std::string command;
  for (const std::string& a : arguments) command += (command.empty() ? "" : " ") + ShellQuote(a);
  return command;
}

// path relative to root -> XXH64 of its bytes, for every regular file below root.
std::map<std::string, uint64_t> Snapshot(const fs::path& root) {
  std::map<std::string, uint64_t> files;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(root, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file()) continue;
    Result<files::FileDigest> d = files::DigestFile(it->path());
    EXPECT_TRUE(d.ok()) << d.status().ToString();
    files[fs::relative(it->path(), root).generic_string()] = d.ok() ? d->xxh64 : 0;
  }
  return files;
}

uint64_t TotalBytes(const fs::path& root) {
  uint64_t bytes = 0;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(root, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_regular_file()) bytes += it->file_size();
  }
  return bytes;
}

// The catalog's rows as text, key -> row; an empty map when there is no catalog.
std::map<std::string, std::string> CatalogRows(const fs::path& assets) {
  std::map<std::string, std::string> rows;
  if (!fs::exists(assets / "catalog.sqlite")) return rows;
  Result<Catalog> catalog = Catalog::OpenReadOnly(assets / "catalog.sqlite");
  EXPECT_TRUE(catalog.ok()) << catalog.status().ToString();
  if (!catalog.ok()) return rows;
  Result<std::vector<CatalogEntry>> all = catalog->All();
  EXPECT_TRUE(all.ok()) << all.status().ToString();
  if (!all.ok()) return rows;
  for (const CatalogEntry& e : *all) {
    rows[e.key] = fmt::format("{} {} {} {} {} {} {} {} {}", e.file.value_or("-"), AssetStatusName(e.status),
                              Hex64(e.input_hash), Hex64(e.options_hash), e.output_xxh64.value_or(0), e.vertices,
                              e.triangles, e.bytes_out, e.error_code.value_or("-"));
  }
  return rows;
}

// The trace without its wall-clock column, which no two runs share.
std::string TraceWithoutSeconds(const fs::path& path) {
  Result<std::vector<uint8_t>> bytes = files::ReadFile(path, 1 << 20);
  EXPECT_TRUE(bytes.ok()) << bytes.status().ToString();
  if (!bytes.ok()) return {};
  std::istringstream in(std::string(bytes->begin(), bytes->end()));
  std::string out;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> cells;
    std::istringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    for (size_t i = 0; i < cells.size(); ++i) out += i == 3 ? "" : cells[i] + ",";
    out += "\n";
  }
  return out;
}

class WriterFaults : public ::testing::TestWithParam<std::tuple<Command, Fault>> {
 protected:
  Command command() const { return std::get<0>(GetParam()); }
  const Fault& fault() const { return std::get<1>(GetParam()); }

  // The command's own output below `dir`.
  fs::path Output(const fs::path& dir) const {
    switch (command()) {
      case Command::kConvert: return dir / "assets";
      case Command::kRender:
      case Command::kIndex: return dir / "dataset";
      case Command::kOptimize: return dir / "fit";
      case Command::kExport: return dir / "coco";
      case Command::kExportZarr: return dir / "zarr";
    }
    return dir;
  }

  // What an earlier run left: some assets, the first shard, a whole dataset (for index and
  // export), an earlier fit.
  void MakePrior(const fs::path& dir) const {
    const std::string assets = render::testing::ProceduralAssetsDir().string();
    const fs::path out = Output(dir);
    CommandRun run;
    switch (command()) {
      case Command::kConvert:
        run = RunCommand(Shell({SOLID_CLI_BINARY, "convert", "procedural", out.string(), "--models", "4", "--rooms", "0",
                                "--seed", "3", "--jobs", "2"}));
        break;
      case Command::kRender: run = RunCommand(Shell(RenderArguments(out, {"--shard", "0"}))); break;
      case Command::kIndex: run = RunCommand(Shell(RenderArguments(out, {}))); break;
      case Command::kExport: run = RunCommand(Shell(RenderArguments(dir / "dataset", {}))); break;
      case Command::kExportZarr: {
        // The zarr store needs query views.
        std::vector<std::string> a = RenderArguments(dir / "dataset", {"--query-size", "32"});
        std::erase(a, "--no-queries");
        run = RunCommand(Shell(a));
        break;
      }
      case Command::kOptimize: {
        fs::create_directories(out);
        const std::string earlier = "an earlier fit\n";
        for (const char* name : {"params.json", "trace.csv"}) {
          ASSERT_OK(files::WriteFileAtomically(out / name, {reinterpret_cast<const uint8_t*>(earlier.data()),
                                                            earlier.size()}));
        }
        return;
      }
    }
    ASSERT_EQ(run.exit_status, 0) << run.output;
  }

  std::vector<std::string> RenderArguments(const fs::path& out, const std::vector<std::string>& extra) const {
    std::vector<std::string> a = {SOLID_CLI_BINARY, "render", "--preset", "random-placement", "--resolution", "64x48",
                                  "--assets", render::testing::ProceduralAssetsDir().string(), "--out", out.string(),
                                  "--images", "6", "--shard-size", "2", "--spp", "1", "--no-queries", "--seed", "5",
                                  "--jobs", "2"};
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  }

  // The command under test, as a shell command line.
  std::string CommandLine(const fs::path& dir) const {
    const fs::path out = Output(dir);
    switch (command()) {
      case Command::kConvert:
        return Shell({SOLID_CLI_BINARY, "convert", "procedural", out.string(), "--models", "8", "--rooms", "0", "--seed",
                      "3", "--jobs", "2"});
      case Command::kRender: return Shell(RenderArguments(out, {}));
      case Command::kIndex: return Shell({SOLID_CLI_BINARY, "index", out.string()});
      case Command::kOptimize:
        return Shell({SOLID_CLI_BINARY, "optimize", "--preset", "random-placement", "--target-row", "occlusion",
                      "--assets", render::testing::ProceduralAssetsDir().string(), "--out",
                      (out / "params.json").string(), "--trace", (out / "trace.csv").string(), "--layouts", "12",
                      "--confirm-layouts", "12", "--max-evals", "3", "--max-seconds", "1000", "--rounds", "1",
                      "--eval-resolution", "64x48", "--seed", "5", "--jobs", "1"});
      case Command::kExport:
        // From the directory: annotations.json names the dataset as given, the same in every run.
        return "cd " + ShellQuote(dir.string()) + " && " +
               Shell({SOLID_CLI_BINARY, "export", "coco", "dataset", out.string()});
      case Command::kExportZarr: return Shell({SOLID_CLI_BINARY, "export", "zarr", (dir / "dataset").string(), out.string()});
    }
    return {};
  }

  // Where the fault strikes: the whole output, except that a vanished directory is one
  // below it (a vanished top directory would be recreated like any missing one).
  std::string Glob(const fs::path& dir) const {
    const fs::path out = Output(dir);
    // The store is written in its temporary sibling, zarr.tmp-<host>-<pid>-<n>, then renamed.
    if (command() == Command::kExportZarr) return out.string() + (fault().spec == "create=ENOENT" ? "*/masks/*" : "*");
    if (fault().spec != "create=ENOENT") return out.string() + "/*";
    switch (command()) {
      case Command::kConvert: return (out / "models").string() + "/*";
      case Command::kRender: return (out / "shards").string() + "/*";
      case Command::kExport: return (out / "images").string() + "/*";
      case Command::kExportZarr:
      case Command::kIndex:
      case Command::kOptimize: return out.string() + "/*";
    }
    return {};
  }

  std::string FaultyCommandLine(const fs::path& dir, uint64_t written_by_reference) const {
    std::string spec = fault().spec + ":" + Glob(dir);
    if (fault().partial) spec += ":" + std::to_string(std::max<uint64_t>(1, written_by_reference / 2));
    const char* asan = std::getenv("ASAN_OPTIONS");
    const std::string asan_options =
        (asan && *asan ? std::string(asan) + ":" : std::string()) + "verify_asan_link_order=0";
    // Exported, as the command line may start with a cd.
    return "export LD_PRELOAD=" + ShellQuote(SOLID_FAULT_INJECT_LIBRARY) + " SOLID_FAULT=" + ShellQuote(spec) +
           " ASAN_OPTIONS=" + ShellQuote(asan_options) + "; " + CommandLine(dir);
  }

  // What two complete runs must share.
  void ExpectSameResult(const fs::path& reference, const fs::path& rerun) const {
    const fs::path want = Output(reference), have = Output(rerun);
    switch (command()) {
      case Command::kConvert: {
        auto files = [](const fs::path& root) {
          auto s = Snapshot(root);
          std::erase_if(s, [](const auto& kv) { return kv.first.starts_with("catalog.sqlite"); });
          return s;
        };
        EXPECT_EQ(files(have), files(want));
        EXPECT_EQ(CatalogRows(have), CatalogRows(want));
        break;
      }
      case Command::kRender: {
        Result<render::testing::DatasetDigest> a = render::testing::DigestDataset(want);
        Result<render::testing::DatasetDigest> b = render::testing::DigestDataset(have);
        ASSERT_OK(a.status());
        ASSERT_OK(b.status());
        EXPECT_EQ(b->images.size(), 6u);
        EXPECT_TRUE(*a == *b);
        const ValidationReport report = ValidateDataset(have);
        EXPECT_TRUE(report.ok()) << (report.problems.empty() ? "" : report.problems[0].message);
        EXPECT_TRUE(fs::exists(have / "index.sqlite"));
        break;
      }
      case Command::kIndex:
        EXPECT_EQ(Snapshot(have).at("index.sqlite"), Snapshot(want).at("index.sqlite"));
        break;
      case Command::kOptimize:
        EXPECT_EQ(Snapshot(have).at("params.json"), Snapshot(want).at("params.json"));
        EXPECT_EQ(TraceWithoutSeconds(have / "trace.csv"), TraceWithoutSeconds(want / "trace.csv"));
        break;
      case Command::kExport:
        EXPECT_EQ(Snapshot(have), Snapshot(want));
        EXPECT_TRUE(Snapshot(have).count("annotations.json"));
        break;
      case Command::kExportZarr:
        EXPECT_EQ(Snapshot(have), Snapshot(want));
        EXPECT_TRUE(Snapshot(have).count(".zgroup"));
        break;
    }
  }

  // After the failed run: no temporary, nothing an earlier run wrote changed, and what is
  // new is complete.
  void ExpectNothingPartial(const fs::path& prior, const fs::path& failed, const fs::path& reference) const {
    const auto before = Snapshot(Output(prior)), after = Snapshot(Output(failed)), done = Snapshot(Output(reference));
    for (const auto& [name, digest] : after) EXPECT_FALSE(files::IsTempPath(name)) << name << " left behind";
    for (const auto& [name, digest] : before) {
      if (name.starts_with("catalog.sqlite")) continue;  // rows are compared instead
      ASSERT_TRUE(after.count(name)) << name << " of the earlier run is gone";
      EXPECT_EQ(after.at(name), digest) << name << " of the earlier run changed";
    }
    switch (command()) {
      case Command::kConvert: {
        // Assets converted before the fault stay, complete and recorded; the rerun resumes there.
        const auto rows = CatalogRows(Output(failed)), reference_rows = CatalogRows(Output(reference));
        for (const auto& [key, row] : CatalogRows(Output(prior))) EXPECT_EQ(rows.count(key), 1u) << key;
        for (const auto& [key, row] : rows) EXPECT_EQ(row, reference_rows.at(key)) << key;
        for (const auto& [name, digest] : after) {
          if (name.starts_with("catalog.sqlite")) continue;
          ASSERT_TRUE(done.count(name)) << name << " is no output of an undisturbed run";
          EXPECT_EQ(digest, done.at(name)) << name << " is incomplete";
        }
        break;
      }
      case Command::kRender:
      case Command::kIndex: {
        // Shards hold their timings, so completeness is validation rather than equal bytes.
        for (const auto& [name, digest] : after) {
          if (name.ends_with(".sqlite") && name != "index.sqlite") {
            const ValidationReport report = ValidateShardFile(Output(failed) / name);
            EXPECT_TRUE(report.ok()) << name << ": " << (report.problems.empty() ? "" : report.problems[0].message);
          }
        }
        if (after.count("index.sqlite") && !before.count("index.sqlite")) {
          Result<std::vector<std::string>> diffs = CompareIndex(Output(failed));
          ASSERT_OK(diffs.status());
          EXPECT_TRUE(diffs->empty()) << diffs->front();
        }
        break;
      }
      case Command::kOptimize: EXPECT_EQ(after, before); break;
      case Command::kExport:
        // Images written before the fault may stay (annotations.json, published last, is what
        // makes an export): each must be whole.
        EXPECT_FALSE(after.count("annotations.json"));
        for (const auto& [name, digest] : after) {
          ASSERT_TRUE(done.count(name)) << name << " is no output of an undisturbed run";
          EXPECT_EQ(digest, done.at(name)) << name << " is incomplete";
        }
        break;
      case Command::kExportZarr:
        // All or nothing: no store, and no temporary beside it.
        EXPECT_FALSE(fs::exists(Output(failed)));
        for (const auto& entry : fs::directory_iterator(failed)) EXPECT_FALSE(files::IsTempPath(entry.path())) << entry.path();
        break;
    }
  }
};

TEST_P(WriterFaults, FailCleanlyAndRerunToTheUndisturbedResult) {
  TempDir dir;
  const fs::path prior = dir.path() / "prior", reference = dir.path() / "reference", run = dir.path() / "run";
  MakePrior(prior);
  if (HasFatalFailure()) return;
  fs::copy(prior, reference, fs::copy_options::recursive);
  fs::copy(prior, run, fs::copy_options::recursive);

  const CommandRun undisturbed = RunCommand(CommandLine(reference));
  ASSERT_TRUE(undisturbed.exit_status == 0 || (command() == Command::kOptimize && undisturbed.exit_status == 1))
      << undisturbed.output;
  // The index is rewritten whole, to the same size: the others add to what was there.
  const uint64_t written = command() == Command::kIndex ? fs::file_size(Output(reference) / "index.sqlite")
                                                        : TotalBytes(Output(reference)) - TotalBytes(Output(prior));

  const CommandRun faulty = RunCommand(FaultyCommandLine(run, written));
  EXPECT_EQ(faulty.exit_status, kExitIoError) << faulty.output;
  EXPECT_NE(faulty.output.find(Output(run).string()), std::string::npos) << "no path named:\n" << faulty.output;
  EXPECT_NE(faulty.output.find(std::strerror(fault().error_number)), std::string::npos)
      << "no cause \"" << std::strerror(fault().error_number) << "\":\n" << faulty.output;
  ExpectNothingPartial(prior, run, reference);

  const CommandRun rerun = RunCommand(CommandLine(run));
  ASSERT_EQ(rerun.exit_status, undisturbed.exit_status) << rerun.output;
  ExpectSameResult(reference, run);
}

std::string TestName(const ::testing::TestParamInfo<WriterFaults::ParamType>& info) {
  return std::string(CommandName(std::get<0>(info.param))) + std::get<1>(info.param).name;
}

INSTANTIATE_TEST_SUITE_P(
    AllWriters, WriterFaults,
    ::testing::Combine(::testing::Values(Command::kConvert, Command::kRender, Command::kIndex, Command::kOptimize,
                                         Command::kExport, Command::kExportZarr),
                       ::testing::ValuesIn(kFaults)),
    TestName);
INSTANTIATE_TEST_SUITE_P(Rename, WriterFaults,
                         ::testing::Combine(::testing::Values(Command::kRender), ::testing::Values(kCrossDeviceRename)),
                         TestName);

}  // namespace
}  // namespace solid::cli
