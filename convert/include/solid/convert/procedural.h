// The embedded default assets: label-free procedural shapes and rooms, so that the
// whole pipeline runs with no download. Deterministic: asset i of seed s is the same
// bytes on every machine. Shapes are in ShapeNetCore.v2's frame and normalisation;
// rooms are metres, +Y up, floor at y = 0, centred on the origin in x and z.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "solid/formats/asset.h"
#include "solid/formats/status.h"

namespace solid::convert {

// Families shaped like ShapeNetCore's main categories; each is parametric (legs, arms,
// backs, shelves, wheels, wings... drawn per model) with a material per part.
enum class ShapeFamily {
  kChair, kTable, kSofa, kBed, kCabinet, kBookshelf, kLamp, kDisplay, kCar,
  kAirplane, kBottle, kVase, kMug, kBowl, kBench, kTrashBin, kGuitar, kLaptop,
};
inline constexpr int kShapeFamilyCount = 18;
// "chair", "table", ..., "trash_bin", "guitar", "laptop".
std::string_view ShapeFamilyName(ShapeFamily f);
// The ShapeNetCore.v2 synset a family imitates ("03001627" for chair).
std::string_view ShapeFamilySynset(ShapeFamily f);
// Family names to families, in the given order; kInvalidArgument naming an unknown one
// and listing the valid names.
Result<std::vector<ShapeFamily>> ParseShapeFamilies(const std::vector<std::string>& names);

// The accepted triangle ranges: every family can be tessellated finely and coarsely enough.
inline constexpr int kMinProceduralTriangles = 1000;
inline constexpr int kMaxProceduralTriangles = 4'000'000;

struct ProceduralShapeOptions {
  // Tessellation lands within [min, max]; kInvalidArgument unless
  // kMinProceduralTriangles <= min, 1.25 * min <= max <= kMaxProceduralTriangles.
  int min_triangles = 2000;
  int max_triangles = 20000;
  int texture_size = 128;  // square, PNG, in [4, 4096]
  // The families to draw from, model i taking families[i % size]; empty: the default
  // mix, a cycle of 32 that holds every family once (models 0-17 in enum order), then
  // more of ShapeNetCore's largest categories (table, chair, airplane, car, sofa, lamp,
  // bench). kInvalidArgument for a family listed twice.
  std::vector<ShapeFamily> families;
};

// kInvalidArgument naming the rule an out-of-range option breaks.
Status CheckProceduralShapeOptions(const ProceduralShapeOptions& options);

// The family of model `index` under `options`.
ShapeFamily FamilyOfIndex(int index, const ProceduralShapeOptions& options);

// Model i: parameters from (seed, i), family FamilyOfIndex(i). +Y up, front -Z, and
// normalised as ShapeNetCore.v2's model_normalized.obj: the mean of its vertices at the
// origin, a bounding-box diagonal of 1. Node name = key ("procedural/shape-000042");
// one material per part kind (frame, seat, tyres...), each with a procedural texture
// and UVs. Every part is a closed mesh wound counter-clockwise seen from outside; parts
// overlap where they join, as modelled furniture does. Smooth normals keep creases
// sharper than 60 degrees. The triangle count is drawn log-uniformly inside the range.
// Asset::extras: generator, family, synset and synset_name (as ShapeNet catalog rows
// carry them), seed (hex), index. kInvalidArgument for a negative index or options out
// of range. Bit-identical output needs the same libm (sin, cos, pow, exp) and PNG
// encoder; the code avoids <random> distributions and fused multiply-adds. Thread-safe.
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
