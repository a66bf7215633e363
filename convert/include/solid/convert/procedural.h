// The embedded default assets: label-free procedural shapes and rooms, so that the
// whole pipeline runs with no download. Deterministic: asset i of seed s is the same
// bytes on every machine. Shapes are centred at the origin, +Y up, largest extent 1;
// rooms are metres, +Y up, floor at y = 0, centred on the origin in x and z.
#pragma once

#include <cstdint>
#include <string>

#include "solid/convert/asset.h"
#include "solid/formats/status.h"

namespace solid::convert {

enum class ShapeFamily {
  kSuperquadric,
  kNoisySphere,
  kExtrusion,    // a random star/blob polygon extruded, with caps
  kRevolution,   // a random profile revolved about Y (vases, bottles)
  kTorus,
  kUnion,        // a few primitives (boxes, cylinders, spheres) unioned as separate parts
};
inline constexpr int kShapeFamilyCount = 6;
std::string_view ShapeFamilyName(ShapeFamily f);

struct ProceduralShapeOptions {
  int min_triangles = 2000;   // tessellation is chosen to land within [min, max]
  int max_triangles = 20000;
  int texture_size = 128;     // square, PNG
};

// Model i of the default set: family i % kShapeFamilyCount, parameters from (seed, i).
// Node name = key ("procedural/shape-000042"); one or two materials with a procedural
// texture (checker, stripes, noise or flat colour) and UVs.
Result<Asset> MakeProceduralShape(uint64_t seed, int index, const std::string& key,
                                  const ProceduralShapeOptions& options = {});

struct ProceduralRoomOptions {
  int texture_size = 256;
};

// Room i: box- or L-shaped, 4-16 m across and 2.5-4 m high, with textured floor,
// walls and ceiling as separate nodes named "floor", "wall", "ceiling" (SceneNet's
// structure classes), normals facing inwards, UVs in metres (textures repeat).
Result<Asset> MakeProceduralRoom(uint64_t seed, int index, const std::string& key,
                                 const ProceduralRoomOptions& options = {});

}  // namespace solid::convert
