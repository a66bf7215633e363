// Internal: the bytes of schemas/ compiled into the library (see cmake/SolidEmbedScript.cmake).
#pragma once
#include <string_view>
#include <vector>

namespace solid::schemas_internal {
struct EmbeddedFile {
  std::string_view name;  // path relative to schemas/, e.g. "shard.sql"
  std::string_view bytes;
};
const std::vector<EmbeddedFile>& EmbeddedFiles();
}  // namespace solid::schemas_internal
