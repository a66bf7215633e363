#include <fmt/format.h>

#include <iostream>

#include "commands.h"
#include "exit_codes.h"
#include "progress.h"
#include "solid/formats/index.h"
#include "solid/formats/inspect.h"
#include "solid/formats/dataset.h"
#include "solid/formats/validate.h"

namespace solid::cli {

Command AddInspect(CLI::App& app) {
  struct Flags {
    std::string path;
    bool json = false;
  };
  auto flags = std::make_shared<Flags>();
  CLI::App* cmd = app.add_subcommand("inspect", "Summarize a dataset, a target shard or a query shard: counts, sizes, "
                                                "proxy metrics, the manifest.");
  cmd->add_option("PATH", flags->path, "Dataset directory or shard file")->required();
  cmd->add_flag("--json", flags->json, "Print JSON for scripts instead of the human summary");
  return [flags] {
    Result<nlohmann::json> result = Inspect(flags->path);
    if (!result.ok()) return Fail(result.status());
    std::cout << (flags->json ? result->dump(2) + "\n" : FormatInspection(*result));
    return int{kExitOk};
  };
}

Command AddValidate(CLI::App& app) {
  struct Flags {
    std::string path;
    bool json = false, no_decode = false;
    size_t max_problems = 1000;
  };
  auto flags = std::make_shared<Flags>();
  CLI::App* cmd = app.add_subcommand("validate", "Check a dataset (or one shard file) completely; exit 0 only when "
                                                 "nothing is wrong, 1 when problems were found.");
  cmd->add_option("PATH", flags->path, "Dataset directory or shard file")->required();
  cmd->add_flag("--json", flags->json, "Print the report as JSON");
  cmd->add_flag("--no-decode", flags->no_decode, "Skip decoding images (checksums are still verified)");
  cmd->add_option("--max-problems", flags->max_problems, "List at most this many problems (default 1000)")
      ->check(CLI::Range(size_t{1}, size_t{1} << 20));
  return [flags] {
    std::error_code exists_ec;
    if (!std::filesystem::exists(flags->path, exists_ec)) {
      return Fail(NotFoundError(flags->path + ": no such dataset directory or shard file"));
    }
    ValidateOptions options;
    options.decode_images = !flags->no_decode;
    options.max_problems = flags->max_problems;
    ProgressLine progress("validate", "shards");
    options.progress = progress.Callback();
    std::error_code ec;
    ValidationReport report = std::filesystem::is_regular_file(flags->path, ec)
                                  ? ValidateShardFile(flags->path, options)
                                  : ValidateDataset(flags->path, options);
    if (flags->json) {
      std::cout << report.ToJson().dump(2) << "\n";
    } else {
      for (const ValidationProblem& p : report.problems) {
        std::cout << (p.location.empty() ? p.message : p.location + ": " + p.message) << "\n";
      }
      if (report.problems_not_listed > 0) std::cout << report.problems_not_listed << " more problems not listed\n";
      std::cout << fmt::format("{}: {} shards, {} query shards, {} images, {} instances, {} query views checked; "
                               "{} problems\n",
                               report.ok() ? "OK" : "FAILED", report.shards, report.query_shards, report.images,
                               report.instances, report.query_views,
                               report.problems.size() + static_cast<size_t>(report.problems_not_listed));
    }
    return int{report.ok() ? kExitOk : kExitProblems};
  };
}

Command AddIndex(CLI::App& app) {
  struct Flags {
    std::string path;
    bool adopt = false;
  };
  auto flags = std::make_shared<Flags>();
  CLI::App* cmd = app.add_subcommand("index", "Build DATASET/index.sqlite from the complete shards present "
                                              "(shard list, model occurrences, metrics).");
  cmd->add_option("DATASET", flags->path, "Dataset directory")->required();
  cmd->add_flag("--adopt", flags->adopt,
                "When DATASET has no manifest.json: rebuild it from the shards' provenance, if they all agree");
  return [flags] {
    const std::string* path = &flags->path;
    std::error_code exists_ec;
    if (flags->adopt && !std::filesystem::exists(DatasetPaths(*path).manifest(), exists_ec)) {
      Result<AdoptReport> adopted = AdoptManifest(*path);
      if (!adopted.ok()) return Fail(adopted.status());
      fmt::print(stderr, "solid: {}\n", adopted->Summary(*path));
    }
    Result<IndexReport> report = [&] {
      ProgressLine progress("index", "shards");
      return BuildIndex(*path, progress.Callback());
    }();
    if (!report.ok()) return Fail(report.status());
    for (const Status& s : report->skipped) fmt::print(stderr, "solid: skipped: {}\n", s.message());
    if (!report->missing_shards.empty()) {
      fmt::print(stderr, "solid: {}: shards {} are not there yet (not rendered, or being rendered): the index covers "
                         "the complete shards only; run solid index again once they are\n",
                 *path, Ranges(report->missing_shards));
    }
    fmt::print("indexed {} shards ({} images, {} instances), {} query shards ({} views), {} models{}\n",
               report->shards, report->images, report->instances, report->query_shards, report->query_views,
               report->models, report->skipped.empty() ? "" : fmt::format("; {} skipped", report->skipped.size()));
    return int{report->skipped.empty() ? kExitOk : kExitProblems};
  };
}

}  // namespace solid::cli
