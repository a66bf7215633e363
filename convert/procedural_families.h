// Internal to convert/: the procedural model families, shaped like ShapeNet's main
// categories. Each draws its parameters from the geometry stream once and returns the
// parts (in metres, +Y up, front -Z, the ShapeNetCore.v2 frame) and its material slots;
// procedural.cpp tessellates, textures and normalises them.
#pragma once

#include <string>
#include <vector>

#include "procedural_kit.h"
#include "solid/convert/procedural.h"

namespace solid::convert {

// How a material slot is textured (procedural.cpp draws the pattern).
enum class Surfacing { kWood, kMetal, kFabric, kPlastic, kLeather, kRubber, kScreen, kGlass, kCeramic, kPaint, kKeys };

struct MaterialSlot {
  std::string name;
  Surfacing surfacing;
};

struct ModelSpec {
  std::vector<kit::Part> parts;  // Part::material indexes `materials`
  std::vector<MaterialSlot> materials;
};

ModelSpec MakeFamilySpec(ShapeFamily family, Rng& rng);

}  // namespace solid::convert
