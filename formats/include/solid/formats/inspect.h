// Summaries of a dataset or of one shard file, for people (FormatInspection)
// and for scripts (the JSON itself).
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "solid/formats/status.h"

namespace solid {

// Accepts a dataset directory, an assets directory (catalog.sqlite), a target shard or
// a query shard; the JSON's "kind" says which ("dataset", "assets", "target_shard",
// "query_shard"). Reads no image blob.
Result<nlohmann::json> Inspect(const std::filesystem::path& path);

// A report readable at a glance in a terminal.
std::string FormatInspection(const nlohmann::json& inspection);

}  // namespace solid
