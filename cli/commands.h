// Each subcommand registers its flags on the app and returns the function that
// runs it once the flags are parsed. Commands only map flags to options, call
// one library entry point, print, and map the result to an exit code.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "solid/formats/status.h"
#include "solid/render/assets.h"
#include "solid/render/params.h"

namespace solid::cli {

using Command = std::function<int()>;

Command AddInspect(CLI::App& app);
Command AddValidate(CLI::App& app);
Command AddIndex(CLI::App& app);
Command AddConvert(CLI::App& app);
Command AddSample(CLI::App& app);
Command AddRender(CLI::App& app);
Command AddOptimize(CLI::App& app);
Command AddMetrics(CLI::App& app);
Command AddExport(CLI::App& app);
Command AddReport(CLI::App& app);

// "WIDTHxHEIGHT", each 16..8192; errors name `flag`.
Result<std::pair<int, int>> ParseResolution(std::string_view flag, const std::string& text);

// Registers --params, --preset (mutually exclusive), --resolution and --scale-classes-at on
// `cmd`, into `source`.
void AddParamsFlags(CLI::App* cmd, render::ParamsSource* source);

// A range check whose bounds are those of the integer at `pointer` of an embedded JSON Schema
// (schemas::IntegerRange): a flag and the file it ends up in share one source.
CLI::Validator SchemaRange(std::string_view schema, std::string_view pointer);

// --seed S: a 64-bit unsigned integer; a sign is refused (CLI11 would wrap "-1").
CLI::Option* AddSeedOption(CLI::App* cmd, uint64_t* seed, const std::string& help);
// --jobs N, -j N: 1..kMaxJobs threads; not given, *jobs keeps 0 (all cores).
inline constexpr int kMaxJobs = 1024;
CLI::Option* AddJobsOption(CLI::App* cmd, int* jobs, const std::string& help);

// --asset-cache-mb N: the memory cap of the decoded-asset cache, MiB (default 2048).
void AddAssetCacheFlag(CLI::App* cmd, uint64_t* megabytes);
render::AssetLibraryOptions AssetLibraryOptionsFor(uint64_t megabytes);

// "0-3, 7, 9-12": inclusive ranges, or sorted indices joined into ranges.
std::string Ranges(const std::vector<std::pair<int64_t, int64_t>>& ranges);
std::string Ranges(const std::vector<int64_t>& sorted);

// A command's options-struct fields and the flags that set them, e.g. {"images", "--images"}.
using FlagNames = std::vector<std::pair<std::string_view, std::string_view>>;

// Library text says what remedies a problem in library terms: the call that does it
// ("adopting the shards (AdoptManifest)") or the options field ("RenderOptions::repair
// re-renders it"). For people at a shell each becomes its command ("solid index --adopt").
std::string InCommandTerms(std::string text);

// Prints "solid: <message>" on stderr and returns the exit code for the status. A status
// about an option field (Status::ForOption) that `flags` names is printed with the flag
// in place of the field; remedies are named as commands (InCommandTerms).
int Fail(const Status& status, const FlagNames& flags = {});

// `flags` and the flags of AddParamsFlags (the fields of render::ParamsSource).
FlagNames WithParamsFlags(FlagNames flags);

}  // namespace solid::cli

// SOLID_ASSIGN_OR_RETURN for command bodies: on error, print it and return its exit code.
#define SOLID_ASSIGN_OR_RETURN_EXIT(lhs, expr)                                         \
  auto SOLID_STATUS_CONCAT(solid_exit_, __LINE__) = (expr);                            \
  if (!SOLID_STATUS_CONCAT(solid_exit_, __LINE__).ok())                                \
    return ::solid::cli::Fail(SOLID_STATUS_CONCAT(solid_exit_, __LINE__).status());    \
  lhs = std::move(SOLID_STATUS_CONCAT(solid_exit_, __LINE__)).value()
