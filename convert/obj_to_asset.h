// From parsed OBJ + MTL to an Asset, with the cleaning rules of docs "input-formats"
// section 4 ("Geometry", "Coordinates", "Materials and textures"):
//   - reversed-winding twins kept; same-winding duplicates (equal (v, vt, vn) corner
//     triples up to cyclic rotation, within one primitive) removed; degenerate
//     triangles (repeated position index or zero cross product in double) removed;
//   - blocks, groups and objects with no triangle dropped, and unused materials;
//   - one glTF vertex per distinct (v, vt, vn) in a primitive;
//   - normals renormalised (zero -> the triangle's geometric normal); a corner without
//     vn in a primitive with normals gets the geometric normal; no vn at all -> none;
//   - UVs -> (u, 1 - v), never wrapped; corners without vt in a primitive with UVs or a
//     textured material get OBJ (0, 0);
//   - materials: name verbatim, baseColor (Kd, d), d < 1 -> BLEND, metallic 0;
//     undefined usemtl -> default material of that name (Kd 0.8, d 1); faces before any
//     usemtl take the sole MTL material if there is exactly one, else none (glTF's default);
//   - textures resolved against the MTL's directory and confined to a root folder
//     (absolute paths, URIs, '..' escapes and symlinks leaving it are refused), JPEG/PNG
//     by magic bytes, embedded once per file, or only validated (SceneNet).
// Warnings carry the codes of input-formats section 4 ("texture_path_rejected", ...).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "solid/formats/asset.h"
#include "obj.h"
#include "solid/formats/status.h"

namespace solid::convert {

struct ConvertWarning {
  std::string code;     // e.g. "missing_texture", "undefined_material", "texture_path_rejected"
  std::string message;  // names the file and line where that applies
};

// Triangle counts cover the objects keep_object keeps, except triangles_in, which is
// every OBJ triangle. Normal and UV counts are per corner of an emitted triangle;
// texture counts are per used material, except textures_embedded (distinct files).
struct CleanCounts {
  uint64_t triangles_in = 0, triangles_out = 0;
  uint64_t reversed_twins = 0;          // kept: positions of an earlier triangle of the primitive, reversed
  uint64_t duplicates_removed = 0, degenerates_removed = 0;
  uint64_t empty_blocks_dropped = 0;    // ObjData blocks without triangles (line-only groups...)
  uint64_t normals_renormalized = 0;    // | |vn| - 1 | > 1e-6
  uint64_t zero_normals = 0, normals_from_geometry = 0;  // both get the geometric normal
  uint64_t uvs_filled = 0;
  uint64_t textures_embedded = 0;
  uint64_t textures_missing = 0;        // "missing_texture"
  uint64_t textures_rejected = 0;       // path rejected, directory (kEmbed), unsupported, too large
};

enum class NodeGrouping {
  // ShapeNet: one node, one mesh, one primitive per used material in first-use order.
  // Faces before any usemtl take the sole MTL material if there is exactly one, else none.
  kSingleNode,
  // SceneNet: one node per OBJ object (`o`, else `g`), names verbatim. Consecutive blocks
  // with the same name are one object; a name that recurs after another object is a new
  // object, named .001, .002... (the first free suffix; the first object keeps the name).
  // Only objects with triangles take part in the naming. Faces before any usemtl get no
  // material (the glTF default).
  kPerObject,
};

enum class TextureMode {
  kEmbed,         // read, check and embed referenced images
  kValidateOnly,  // resolve and report, embed nothing (SceneNet: textures are chosen at render time)
};

struct ObjAssetOptions {
  NodeGrouping grouping = NodeGrouping::kSingleNode;
  std::string node_name;  // kSingleNode: the node's name
  // kPerObject: which objects to keep (all when empty); called with the node name,
  // after the .001 renaming.
  std::function<bool(const std::string& object_name)> keep_object;
  TextureMode textures = TextureMode::kEmbed;
  std::filesystem::path mtl_dir;       // texture paths resolve against this
  std::filesystem::path confine_root;  // and must stay inside this (the model folder)
  std::string obj_name;                // for messages ("model.obj")
  std::string mtl_name;                // for messages ("model.mtl")
  uint64_t max_texture_bytes = 64 << 20;
};

struct ObjAsset {
  gltf::Asset asset;
  CleanCounts counts;
  std::vector<ConvertWarning> warnings;
};

// `mtl` may be null (missing MTL: a "missing_mtl" warning when the OBJ names one).
// Fails with kCorrupt and a message containing "empty_geometry" when no triangle
// survives (keep_object included), "index_out_of_range" for a corner outside `obj`'s
// arrays, "position_out_of_range" for a used position beyond float range; with
// kInvalidArgument when the MTL has a map_Kd and options.confine_root is empty.
// Reads texture files (and nothing else); thread-safe.
Result<ObjAsset> BuildAssetFromObj(const ObjData& obj, const MtlData* mtl, const ObjAssetOptions& options);

}  // namespace solid::convert
