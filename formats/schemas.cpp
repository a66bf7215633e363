#include "solid/formats/schemas.h"

#include <nlohmann/json.hpp>

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

Result<std::pair<int64_t, int64_t>> IntegerRange(std::string_view name, std::string_view pointer) {
  SOLID_ASSIGN_OR_RETURN(std::string_view text, Get(name));
  // Our own embedded schema: a parse failure is a build defect, which the schema tests catch.
  const nlohmann::json doc = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  const nlohmann::json::json_pointer at{std::string(pointer)};
  if (!doc.is_object() || !doc.contains(at)) {
    return NotFoundError("schemas/" + std::string(name) + ": no " + std::string(pointer));
  }
  const nlohmann::json& node = doc.at(at);
  if (!node.contains("minimum") || !node.contains("maximum") || !node["minimum"].is_number_integer() ||
      !node["maximum"].is_number_integer()) {
    return NotFoundError("schemas/" + std::string(name) + ": " + std::string(pointer) + " has no integer bounds");
  }
  return std::pair<int64_t, int64_t>{node["minimum"].get<int64_t>(), node["maximum"].get<int64_t>()};
}

}  // namespace solid::schemas
