// The files of schemas/ (SQL DDL, JSON Schemas, presets), compiled into the
// library so that a binary never depends on the source tree at run time.
#pragma once

#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

#include "solid/formats/status.h"

namespace solid::schemas {

// Bytes of an embedded file by its path relative to schemas/, e.g. "shard.sql".
// kNotFound for an unknown name. The view lives as long as the program.
Result<std::string_view> Get(std::string_view name);

// Every embedded path, sorted.
std::vector<std::string_view> Names();

// The inclusive ["minimum", "maximum"] of the integer at JSON pointer `pointer` of the
// embedded JSON Schema `name`, e.g. ("manifest.schema.json", "/properties/images"): the
// one source of the bounds that flags share with the files they end up in. kNotFound
// when the schema or either bound is missing.
Result<std::pair<int64_t, int64_t>> IntegerRange(std::string_view name, std::string_view pointer);

}  // namespace solid::schemas
