// The in-memory asset every converter produces and the glTF writer consumes: nodes
// of meshes of primitives, metallic-roughness materials and embedded textures.
// Coordinates are glTF's: metres (or unitless for ShapeNet), +Y up, UV origin at
// the top-left (OBJ v is flipped to 1 - v before it gets here).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace solid::gltf {

struct Texture {
  std::string name;            // source file name, for diagnostics and the glTF image name
  std::string mime_type;       // "image/png" or "image/jpeg"
  std::vector<uint8_t> bytes;  // embedded as is
};

struct Material {
  std::string name;                                 // verbatim (SceneNet picks textures by it)
  std::array<float, 4> base_color = {1, 1, 1, 1};   // linear RGBA; alpha = OBJ d
  bool blend = false;                               // alphaMode BLEND when alpha < 1
  float metallic = 0.0f, roughness = 1.0f;
  std::optional<uint32_t> base_color_texture;       // index into Asset::textures
  bool double_sided = false;
};

struct Primitive {
  std::optional<uint32_t> material;  // index into Asset::materials; none = glTF default material
  std::vector<float> positions;      // xyz per vertex
  std::vector<float> normals;        // xyz per vertex, unit length, or empty
  std::vector<float> uvs;            // uv per vertex, or empty
  std::vector<uint32_t> indices;     // triangles
};

struct Node {
  std::string name;                     // verbatim; ShapeNet: "<synset>/<model>"
  std::vector<Primitive> primitives;    // one glTF mesh per node
  nlohmann::json extras = nlohmann::json::object();
};

struct Asset {
  std::vector<Node> nodes;
  std::vector<Material> materials;
  std::vector<Texture> textures;
  nlohmann::json extras = nlohmann::json::object();  // asset-level provenance (source frame, centroid...)
};

// Axis-aligned bounds of every position of every node.
struct Bounds {
  std::array<double, 3> min = {0, 0, 0}, max = {0, 0, 0};
  bool empty = true;
};
Bounds ComputeBounds(const Asset& asset);
uint64_t TriangleCount(const Asset& asset);
uint64_t VertexCount(const Asset& asset);

}  // namespace solid::gltf
