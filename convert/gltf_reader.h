// Internal: glTF 2.0 (.gltf, .glb) input for `solid convert gltf`, through tinygltf, for
// untrusted files (Objaverse, ABO, any exporter). The default scene is flattened into one
// node of baked geometry in glTF units (metres, +Y up), one primitive per glTF material
// in first-use order; limits are checked before anything is allocated (docs/limits.md).
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "obj_to_asset.h"
#include "solid/formats/asset.h"

namespace solid::convert {

struct GltfReadLimits {
  uint64_t max_file_bytes = uint64_t{1} << 30;  // the .glb/.gltf and each external file
  uint32_t max_json_depth = 64;
  uint32_t max_node_depth = 64;
  uint64_t max_node_instances = 100'000;       // mesh instances after flattening
  uint64_t max_primitives = 100'000;           // primitive instances in all
  uint64_t max_vertices = 50'000'000;          // baked, in all
  uint64_t max_triangles = 50'000'000;
  uint64_t max_image_bytes = uint64_t{64} << 20;  // and kTextureLimits' sides and pixels
  uint64_t max_decoded_bytes = uint64_t{1} << 30;  // EXT_meshopt_compression fallback buffers, in all
};

// A model that cannot be converted: the catalog's error_code and a message naming the
// file and the JSON pointer ("/meshes/2/primitives/0") or byte offset.
struct GltfFailure {
  std::string code;
  std::string message;
};

struct GltfModel {
  gltf::Asset asset;  // one node named `node_name`, metres
  std::vector<ConvertWarning> warnings;
  nlohmann::json counts = nlohmann::json::object();
};

// `bytes` is the content of `path` (read by the caller); external buffers and images
// resolve against path's folder and must stay inside `confine_root`. Failure codes:
// parse_error, limit_exceeded, corrupt (bounds, indices, Draco or meshopt streams),
// unsupported_extension (a required extension we do not decode: KHR_texture_basisu...),
// unsupported_feature (sparse accessors), external_path_rejected, missing_file,
// empty_geometry, node_cycle.
struct GltfReadResult {
  bool ok = false;
  GltfModel model;
  GltfFailure failure;
};
GltfReadResult ReadGltfModel(std::span<const uint8_t> bytes, const std::filesystem::path& path,
                             const std::filesystem::path& confine_root, const std::string& node_name,
                             const GltfReadLimits& limits = {});

// ShapeNetCore.v2's normalisation (model_normalized.obj), as procedural shapes have it:
// the mean of the vertices at the origin, a bounding-box diagonal of 1. Returns the
// source bounding-box extent (x, y, z) before scaling; zero for an empty asset.
std::array<double, 3> NormalizeAsShapeNetV2(gltf::Asset* asset);

}  // namespace solid::convert
