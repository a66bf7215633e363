#include "solid/formats/schemas.h"

#include <string>

#include "embedded_schemas.h"

namespace solid::schemas {

Result<std::string_view> Get(std::string_view name) {
  for (const auto& file : schemas_internal::EmbeddedFiles()) {
    if (file.name == name) return file.bytes;
  }
  return NotFoundError("no embedded schema named '" + std::string(name) + "'");
}

std::vector<std::string_view> Names() {
  std::vector<std::string_view> names;
  for (const auto& file : schemas_internal::EmbeddedFiles()) names.push_back(file.name);
  return names;
}

}  // namespace solid::schemas
