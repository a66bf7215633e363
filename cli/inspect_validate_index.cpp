#include <fmt/format.h>

#include <iostream>

#include "commands.h"
#include "exit_codes.h"
#include "progress.h"
#include "solid/formats/index.h"
#include "solid/formats/inspect.h"
#include "solid/formats/validate.h"

namespace solid::cli {

Command AddInspect(CLI::App& app) {
  auto options = std::make_shared<InspectOptions>();
  auto json = std::make_shared<bool>(false);
  CLI::App* cmd = app.add_subcommand("inspect", "Summarize a dataset, a target shard or a query shard: counts, sizes, "
                                                "proxy metrics, the manifest.");
  cmd->add_option("PATH", options->path, "Dataset directory or shard file")->required();
  cmd->add_flag("--json", *json, "Print JSON for scripts instead of the human summary");
  return [options, json] {
    Result<InspectReport> report = Inspect(*options);
    if (!report.ok()) return Fail(report.status(), {{"path", "PATH"}});
    std::cout << (*json ? report->ToJson().dump(2) + "\n" : InCommandTerms(report->ToText()));
    return int{kExitOk};
  };
}

Command AddValidate(CLI::App& app) {
  auto options = std::make_shared<ValidateOptions>();
  auto flags = std::make_shared<std::pair<bool, bool>>(false, false);  // --json, --no-decode
  CLI::App* cmd = app.add_subcommand("validate", "Check a dataset (or one shard file) completely; exit 0 only when "
                                                 "nothing is wrong, 1 when problems were found.");
  cmd->add_option("PATH", options->path, "Dataset directory or shard file")->required();
  cmd->add_flag("--json", flags->first, "Print the report as JSON");
  cmd->add_flag("--no-decode", flags->second, "Skip decoding images (checksums are still verified)");
  cmd->add_option("--max-problems", options->max_problems, "List at most this many problems (default 1000)")
      ->check(CLI::Range(size_t{1}, kMaxListedProblems));
  return [options, flags] {
    options->decode_images = !flags->second;
    Result<ValidationReport> report = [&] {
      ProgressLine progress("validate", "shards");
      options->progress = progress.Callback();
      return Validate(*options);
    }();
    if (!report.ok()) return Fail(report.status(), {{"path", "PATH"}, {"max_problems", "--max-problems"}});
    std::cout << (flags->first ? report->ToJson().dump(2) + "\n" : InCommandTerms(report->ToText()));
    return int{report->ok() ? kExitOk : kExitProblems};
  };
}

Command AddIndex(CLI::App& app) {
  auto options = std::make_shared<IndexOptions>();
  CLI::App* cmd = app.add_subcommand("index", "Build DATASET/index.sqlite from the complete shards present "
                                              "(shard list, model occurrences, metrics).");
  cmd->add_option("DATASET", options->dataset, "Dataset directory")->required();
  cmd->add_flag("--adopt", options->adopt,
                "When DATASET has no manifest.json: rebuild it from the shards' provenance, if they all agree");
  return [options] {
    Result<IndexReport> report = [&] {
      ProgressLine progress("index", "shards");
      options->progress = progress.Callback();
      return Index(*options);
    }();
    if (!report.ok()) return Fail(report.status(), {{"dataset", "DATASET"}});
    if (!report->adopted.empty()) fmt::print(stderr, "solid: {}\n", InCommandTerms(report->adopted));
    for (const Status& s : report->skipped) fmt::print(stderr, "solid: skipped: {}\n", InCommandTerms(s.message()));
    if (!report->missing_shards.empty()) {
      fmt::print(stderr, "solid: {}: shards {} are not there yet (not rendered, or being rendered): the index covers "
                         "the complete shards only; run solid index again once they are\n",
                 options->dataset.string(), Ranges(report->missing_shards));
    }
    fmt::print("indexed {} shards ({} images, {} instances), {} query shards ({} views), {} models{}\n",
               report->shards, report->images, report->instances, report->query_shards, report->query_views,
               report->models, report->skipped.empty() ? "" : fmt::format("; {} skipped", report->skipped.size()));
    return int{report->ok() ? kExitOk : kExitProblems};
  };
}

}  // namespace solid::cli
