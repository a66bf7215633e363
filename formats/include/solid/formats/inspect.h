// `solid inspect`: summaries of a dataset, an assets directory or one shard file, for
// people (InspectReport::ToText) and for scripts (ToJson).
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "solid/formats/status.h"

namespace solid {

struct InspectOptions {
  // A dataset directory, an assets directory (catalog.sqlite), a target shard or a query shard.
  std::filesystem::path path;
};

struct InspectReport {
  // The summary for scripts; its "kind" says what path was ("dataset", "assets",
  // "target_shard", "query_shard"). A target shard's metrics are classed as the manifest in
  // its provenance says (1:1 without one); a dataset's as its manifest says.
  nlohmann::json summary;
  nlohmann::json ToJson() const { return summary; }
  // The same, readable at a glance in a terminal.
  std::string ToText() const;
};

// Reads no image blob. kInvalidArgument for `path` when it is empty, kNotFound when it
// names nothing inspect knows.
Result<InspectReport> Inspect(const InspectOptions& options);

}  // namespace solid
