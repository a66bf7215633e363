#include <fmt/format.h>

#include <cstdio>

#include "commands.h"
#include "exit_codes.h"
#include "signals.h"
#include "solid/formats/schemas.h"
#include "solid/render/params.h"

namespace solid::cli {

Result<std::pair<int, int>> ParseResolution(std::string_view flag, const std::string& text) {
  return render::ParseResolution(flag, text);
}

CLI::Validator SchemaRange(std::string_view schema, std::string_view pointer) {
  const Result<std::pair<int64_t, int64_t>> range = schemas::IntegerRange(schema, pointer);
  if (!range.ok()) {
    const std::string why = range.status().message();
    return CLI::Validator([why](std::string&) { return why; }, "");
  }
  return CLI::Range(range->first, range->second);
}

CLI::Option* AddSeedOption(CLI::App* cmd, uint64_t* seed, const std::string& help) {
  // CLI11 2.1 reads "-1" into an unsigned as 2^64 - 1: refuse a sign before it converts.
  const CLI::Validator unsigned_integer(
      [](std::string& text) -> std::string {
        if (text.empty() || text.find_first_of("-+") != std::string::npos) {
          return "a seed is a non-negative integer below 2^64, not " + text;
        }
        return "";
      },
      "UINT64");
  return cmd->add_option("--seed", *seed, help)->capture_default_str()->check(unsigned_integer);
}

CLI::Option* AddJobsOption(CLI::App* cmd, int* jobs, const std::string& help) {
  return cmd->add_option("--jobs,-j", *jobs, help + " (default: all cores)")->check(CLI::Range(1, kMaxJobs));
}

void AddParamsFlags(CLI::App* cmd, render::ParamsSource* source) {
  auto* params = cmd->add_option("--params", source->params, "Params file (JSON; see schemas/params.schema.json)");
  auto* preset = cmd->add_option("--preset", source->preset,
                                 "A Table-1 preset: random-placement, occlusion, scale-distribution, rotation, "
                                 "scenenet-background, more-objects");
  params->excludes(preset);
  preset->excludes(params);
  cmd->add_option("--resolution", source->resolution,
                  "WIDTHxHEIGHT, overrides the params' (the presets say 640x480, where Table 1's areas are)");
  cmd->add_option("--scale-classes-at", source->scale_classes_at,
                  "WIDTHxHEIGHT: count COCO's small/medium/large as at this resolution (areas scaled by the "
                  "pixel-count ratio); overrides the params' render.scale_classes_at (default: the resolution)");
}

FlagNames WithParamsFlags(FlagNames flags) {
  flags.insert(flags.end(), {{"params", "--params"},
                             {"preset", "--preset"},
                             {"resolution", "--resolution"},
                             {"scale_classes_at", "--scale-classes-at"}});
  return flags;
}

void AddAssetCacheFlag(CLI::App* cmd, uint64_t* megabytes) {
  cmd->add_option("--asset-cache-mb", *megabytes,
                  "Memory cap of decoded models and rooms (meshes, BVHs, textures), MiB; least recently used are "
                  "dropped first")
      ->capture_default_str()
      ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 30));
}

render::AssetLibraryOptions AssetLibraryOptionsFor(uint64_t megabytes) {
  render::AssetLibraryOptions options;
  options.cache_bytes = megabytes << 20;
  return options;
}

std::string Ranges(const std::vector<std::pair<int64_t, int64_t>>& ranges) {
  std::string out;
  for (const auto& [a, b] : ranges) {
    out += (out.empty() ? "" : ", ") + (a == b ? std::to_string(a) : fmt::format("{}-{}", a, b));
  }
  return out;
}

std::string Ranges(const std::vector<int64_t>& sorted) {
  std::vector<std::pair<int64_t, int64_t>> ranges;
  for (int64_t k : sorted) {
    if (!ranges.empty() && ranges.back().second + 1 == k) {
      ranges.back().second = k;
    } else {
      ranges.emplace_back(k, k);
    }
  }
  return Ranges(ranges);
}

std::string InCommandTerms(std::string text) {
  static constexpr std::pair<std::string_view, std::string_view> kCommands[] = {
      {"AdoptManifest", "solid index --adopt"},
      {"BuildIndex", "solid index"},
      {"InspectReport::ToJson", "solid inspect --json"},
      {"RenderOptions::adopt", "solid render --adopt"},
      {"RenderOptions::repair", "solid render --repair"},
      {"convert::Convert", "solid convert"},
  };
  for (const auto& [library, command] : kCommands) {
    for (size_t at = text.find(library); at != std::string::npos; at = text.find(library, at + command.size())) {
      text.replace(at, library.size(), command);
    }
  }
  return text;
}

int Fail(const Status& status, const FlagNames& flags) {
  std::string message = status.message();
  for (const auto& [field, flag] : flags) {
    if (status.option() != field) continue;
    const std::string prefix = std::string(field) + ": ";
    if (const size_t at = message.find(prefix); at != std::string::npos) {
      message.replace(at, prefix.size(), std::string(flag) + ": ");
    }
  }
  fmt::print(stderr, "solid: {}\n", InCommandTerms(std::move(message)));
  return status.code() == StatusCode::kCancelled ? StopExitCode() : ExitCodeFor(status);
}

}  // namespace solid::cli
