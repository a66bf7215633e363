// The embedded default assets: label-free procedural shapes and rooms, so that the
// whole pipeline runs with no download. Deterministic: asset i of seed s is the same
// bytes on every machine. Shapes are centred at the origin, +Y up, largest extent 1;
// rooms are metres, +Y up, floor at y = 0, centred on the origin in x and z.
#pragma once

#include <cstdint>
#include <string>

#include "solid/formats/asset.h"
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

// The accepted triangle ranges: every family can be tessellated finely and coarsely enough.
inline constexpr int kMinProceduralTriangles = 256;
inline constexpr int kMaxProceduralTriangles = 4'000'000;

struct ProceduralShapeOptions {
  // Tessellation lands within [min, max]; kInvalidArgument unless
  // kMinProceduralTriangles <= min, 1.25 * min <= max <= kMaxProceduralTriangles.
  int min_triangles = 2000;
  int max_triangles = 20000;
  int texture_size = 128;     // square, PNG, in [4, 4096]
};

// kInvalidArgument naming the rule an out-of-range option breaks.
Status CheckProceduralShapeOptions(const ProceduralShapeOptions& options);

// Model i of the default set: family i % kShapeFamilyCount, parameters from (seed, i).
// Node name = key ("procedural/shape-000042"); one or two materials with a procedural
// texture (checker, stripes, noise or flat colour) and UVs. Closed meshes wound
// counter-clockwise seen from outside; smooth normals that keep creases sharper than
// 60 degrees (box faces are flat). The triangle count is drawn log-uniformly inside the
// range. Asset::extras holds generator, family, seed (hex) and index. kInvalidArgument
// for a negative index or options out of range. Bit-identical output needs the same
// libm (sin, cos, pow) and PNG encoder; the code itself avoids <random> distributions
// and fused multiply-adds. Thread-safe.
Result<gltf::Asset> MakeProceduralShape(uint64_t seed, int index, const std::string& key,
                                  const ProceduralShapeOptions& options = {});

struct ProceduralRoomOptions {
  int texture_size = 256;  // square, PNG, in [4, 4096]; one texture repeat per metre
};

// Room i: box- or L-shaped, 4-16 m across and 2.5-4 m high, with textured floor,
// walls and ceiling as separate nodes named "floor", "wall", "ceiling" with extras.structure set alike (SceneNet's
// structure classes), normals facing inwards, UVs in metres (textures repeat).
// Floor, walls and ceiling meet at bit-identical positions: the room is one closed,
// inward-wound mesh, cut into panels of at most about 1 m. Materials "floor", "wall",
// "ceiling"; Asset::extras adds plan ("box" or "L"), size_m [x, y, z] and the key.
Result<gltf::Asset> MakeProceduralRoom(uint64_t seed, int index, const std::string& key,
                                 const ProceduralRoomOptions& options = {});

}  // namespace solid::convert
