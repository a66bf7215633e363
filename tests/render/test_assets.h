// Procedural assets for render tests, converted once per test program.
#pragma once

#include <filesystem>
#include <memory>

#include "solid/render/assets.h"

namespace solid::render::testing {

// An assets directory with 16 procedural models and 3 procedural rooms (seed 7),
// written once per process under the temporary directory and removed at exit.
const std::filesystem::path& ProceduralAssetsDir();

// An AssetLibrary over ProceduralAssetsDir() for both models and rooms.
std::shared_ptr<AssetLibrary> ProceduralLibrary();

}  // namespace solid::render::testing
