// Procedural assets for render tests, converted once per test program.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "solid/render/assets.h"
#include "solid/render/sample.h"

namespace solid::render::testing {

// An assets directory with 16 procedural models and 3 procedural rooms (seed 7),
// written once per process under the temporary directory and removed at exit.
const std::filesystem::path& ProceduralAssetsDir();

// An AssetLibrary over ProceduralAssetsDir() for both models and rooms.
std::shared_ptr<AssetLibrary> ProceduralLibrary();

// Layout 0 of `preset` at 96x72 on ProceduralLibrary() drawn with `seed`, with the sampler
// that drew it (which owns what the layout points to).
struct SmallLayout {
  std::unique_ptr<LayoutSampler> sampler;
  GeneratedLayout g;
};
SmallLayout DrawSmallLayout(const std::string& preset, uint64_t seed);

}  // namespace solid::render::testing
