#include "scene_export.h"

#include <cmath>
#include <cstring>
#include <map>

#include <fmt/format.h>

#include "solid/formats/glb.h"
#include "solid/render/shade.h"
#include "room.h"

namespace solid::render {
namespace {

using nlohmann::json;

constexpr int kFloat = 5126, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

class Document {
 public:
  json gltf = {{"asset", {{"version", "2.0"}, {"generator", "solid " SOLID_VERSION " export-scene"}}}};
  std::vector<uint8_t> bin;

  // A bufferView over `bytes`, 4-byte aligned; returns its index.
  size_t View(const void* bytes, size_t size, std::optional<int> target) {
    const size_t offset = bin.size();
    bin.resize(offset + size);
    std::memcpy(bin.data() + offset, bytes, size);
    bin.resize((bin.size() + 3) & ~size_t{3}, 0);
    json view = {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", size}};
    if (target) view["target"] = *target;
    gltf["bufferViews"].push_back(view);
    return gltf["bufferViews"].size() - 1;
  }

  size_t FloatAccessor(const std::vector<float>& values, int components, bool with_bounds) {
    const char* types[] = {"", "SCALAR", "VEC2", "VEC3"};
    json a = {{"bufferView", View(values.data(), values.size() * sizeof(float), kArrayBuffer)},
              {"componentType", kFloat},
              {"count", values.size() / components},
              {"type", types[components]}};
    if (with_bounds) {
      std::vector<float> lo(components, INFINITY), hi(components, -INFINITY);
      for (size_t i = 0; i < values.size(); ++i) {
        lo[i % components] = std::min(lo[i % components], values[i]);
        hi[i % components] = std::max(hi[i % components], values[i]);
      }
      a["min"] = lo;
      a["max"] = hi;
    }
    gltf["accessors"].push_back(a);
    return gltf["accessors"].size() - 1;
  }

  size_t IndexAccessor(const std::vector<uint32_t>& indices) {
    gltf["accessors"].push_back(
        {{"bufferView", View(indices.data(), indices.size() * sizeof(uint32_t), kElementArrayBuffer)},
         {"componentType", kUnsignedInt},
         {"count", indices.size()},
         {"type", "SCALAR"}});
    return gltf["accessors"].size() - 1;
  }

  // Materials and textures of one asset; returns the index of its first material.
  size_t AddMaterials(const std::vector<gltf::Material>& materials, const std::vector<gltf::Texture>& textures) {
    const size_t first_texture = gltf.contains("textures") ? gltf["textures"].size() : 0;
    for (const gltf::Texture& t : textures) {
      gltf["images"].push_back({{"bufferView", View(t.bytes.data(), t.bytes.size(), std::nullopt)},
                                {"mimeType", t.mime_type},
                                {"name", t.name}});
      gltf["textures"].push_back({{"sampler", 0}, {"source", gltf["images"].size() - 1}});
    }
    if (!textures.empty() && !gltf.contains("samplers")) {
      gltf["samplers"] = json::array({{{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 10497}, {"wrapT", 10497}}});
    }
    const size_t first = gltf.contains("materials") ? gltf["materials"].size() : 0;
    for (const gltf::Material& m : materials) {
      json pbr = {{"baseColorFactor", m.base_color}, {"metallicFactor", m.metallic}, {"roughnessFactor", m.roughness}};
      if (m.base_color_texture) pbr["baseColorTexture"] = {{"index", first_texture + *m.base_color_texture}};
      json material = {{"name", m.name}, {"pbrMetallicRoughness", pbr}};
      if (m.blend) material["alphaMode"] = "BLEND";
      if (m.double_sided) material["doubleSided"] = true;
      gltf["materials"].push_back(material);
    }
    return first;
  }

  // One glTF mesh of `mesh`, a primitive per material; returns the mesh index.
  size_t AddMesh(const std::string& name, const MeshGeometry& mesh, size_t first_material) {
    std::map<uint32_t, std::vector<size_t>> by_material;
    for (size_t t = 0; t < mesh.TriangleCount(); ++t) by_material[mesh.triangle_material[t]].push_back(t);
    json primitives = json::array();
    for (const auto& [material, triangles] : by_material) {
      std::vector<uint32_t> remap(mesh.VertexCount(), UINT32_MAX), indices;
      std::vector<float> positions, normals, uvs;
      bool unit_normals = true;
      for (size_t t : triangles) {
        for (int k = 0; k < 3; ++k) {
          const uint32_t v = mesh.indices[3 * t + k];
          if (remap[v] == UINT32_MAX) {
            remap[v] = static_cast<uint32_t>(positions.size() / 3);
            positions.insert(positions.end(), &mesh.positions[3 * size_t{v}], &mesh.positions[3 * size_t{v}] + 3);
            const float* n = &mesh.normals[3 * size_t{v}];
            unit_normals = unit_normals && std::fabs(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1) < 1e-3f;
            normals.insert(normals.end(), n, n + 3);
            uvs.insert(uvs.end(), &mesh.uvs[2 * size_t{v}], &mesh.uvs[2 * size_t{v}] + 2);
          }
          indices.push_back(remap[v]);
        }
      }
      json attributes = {{"POSITION", FloatAccessor(positions, 3, true)}, {"TEXCOORD_0", FloatAccessor(uvs, 2, false)}};
      // The validator requires unit normals; a source without them gets none.
      if (unit_normals) attributes["NORMAL"] = FloatAccessor(normals, 3, false);
      json primitive = {{"attributes", attributes}, {"indices", IndexAccessor(indices)}};
      if (material != kNoMaterial) primitive["material"] = first_material + material;
      primitives.push_back(primitive);
    }
    gltf["meshes"].push_back({{"name", name}, {"primitives", primitives}});
    return gltf["meshes"].size() - 1;
  }
};

// glTF's column-major 4x4 of a row-major [R | t].
json Matrix(const Affine3x4& a) {
  return json::array({a[0], a[4], a[8], 0.0, a[1], a[5], a[9], 0.0, a[2], a[6], a[10], 0.0, a[3], a[7], a[11], 1.0});
}

}  // namespace

Result<std::vector<uint8_t>> ExportSceneGlb(const Layout& layout) {
  if (layout.room == nullptr) return InvalidArgumentError("export-scene: the layout has no room");
  Document doc;
  json& g = doc.gltf;
  g["nodes"] = json::array();
  json children = json::array();

  const size_t room_material = doc.AddMaterials(layout.room->materials(), layout.room->textures());
  const size_t room_mesh = doc.AddMesh("room " + layout.room->key(), layout.room->mesh(), room_material);
  g["nodes"].push_back({{"name", "room " + layout.room->key()}, {"mesh", room_mesh}});
  children.push_back(g["nodes"].size() - 1);

  std::map<const LoadedAsset*, size_t> meshes;
  for (size_t k = 0; k < layout.objects.size(); ++k) {
    const PlacedObject& o = layout.objects[k];
    auto it = meshes.find(o.asset.get());
    if (it == meshes.end()) {
      const size_t first = doc.AddMaterials(o.asset->materials(), o.asset->textures());
      it = meshes.emplace(o.asset.get(), doc.AddMesh(o.model_key, o.asset->mesh(), first)).first;
    }
    g["nodes"].push_back({{"name", fmt::format("object {} {}", k, o.model_key)},
                          {"mesh", it->second},
                          {"matrix", Matrix(o.WorldFromObject())},
                          {"extras", {{"model_key", o.model_key}, {"render_id", k}, {"size_m", o.size_m}}}});
    children.push_back(g["nodes"].size() - 1);
  }

  const double yfov = 2 * std::atan(layout.height / 2.0 / layout.camera.fy);
  g["cameras"] = json::array({{{"type", "perspective"},
                               {"perspective",
                                {{"yfov", yfov},
                                 {"aspectRatio", static_cast<double>(layout.width) / layout.height},
                                 {"znear", layout.near},
                                 {"zfar", 1000.0}}}}});
  g["nodes"].push_back({{"name", "camera"}, {"camera", 0}, {"matrix", Matrix(layout.camera.world_from_camera)}});
  children.push_back(g["nodes"].size() - 1);

  // Z up (ours) to Y up (glTF): -90 degrees about X.
  const double h = std::sqrt(0.5);
  g["nodes"].push_back({{"name", "world"}, {"rotation", {-h, 0.0, 0.0, h}}, {"children", children}});
  json extras = {{"layout_index", layout.index},
                 {"seed", fmt::format("{:016x}", layout.seed)},
                 {"restart", layout.restart},
                 {"room", layout.room->key()},
                 {"resolution", {layout.width, layout.height}}};
  // glTF has no area lights, so another renderer reproduces `solid render`'s rig from
  // these; a layout that has none (SampleLights fails) is still worth looking at.
  if (const Result<LightRig> lights = SampleLights(layout); lights.ok()) extras["lights"] = lights->ToJson();
  g["scenes"] = json::array({{{"nodes", {g["nodes"].size() - 1}}, {"extras", extras}}});
  g["scene"] = 0;
  g["buffers"] = json::array({{{"byteLength", doc.bin.size()}}});
  return gltf::PackGlb(g, doc.bin);
}

}  // namespace solid::render
