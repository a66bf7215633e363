// The files of schemas/ (SQL DDL, JSON Schemas, presets), compiled into the
// library so that a binary never depends on the source tree at run time.
#pragma once

#include <string_view>
#include <vector>

#include "solid/formats/status.h"

namespace solid::schemas {

// Bytes of an embedded file by its path relative to schemas/, e.g. "shard.sql".
// kNotFound for an unknown name. The view lives as long as the program.
Result<std::string_view> Get(std::string_view name);

// Every embedded path, sorted.
std::vector<std::string_view> Names();

}  // namespace solid::schemas
