// libFuzzer target for ReadGltfModel, the read path of `solid convert gltf` (tinygltf with
// our file-system callbacks, Draco, meshopt, node flattening). The bytes are tried as the
// file they start like (.glb when they begin with "glTF", else .gltf); external URIs point
// into a folder that does not exist, so they fail as missing files. Besides crashes and
// sanitizer reports, it aborts when a successful read breaks the reader's contract: one
// node, every index inside its primitive, attribute arrays of matching sizes.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>

#include "convert/gltf_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  const bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  solid::convert::GltfReadLimits limits;
  // Small inputs cannot describe more than this honestly; the caps keep each run fast.
  limits.max_vertices = 1'000'000;
  limits.max_triangles = 1'000'000;
  limits.max_node_instances = 10'000;
  limits.max_primitives = 10'000;
  limits.max_decoded_bytes = 64 << 20;
  const std::filesystem::path path = glb ? "/nonexistent-solid-fuzz/model.glb" : "/nonexistent-solid-fuzz/model.gltf";
  solid::convert::GltfReadResult r =
      solid::convert::ReadGltfModel(bytes, path, path.parent_path(), "fuzz", limits);
  if (!r.ok) {
    if (r.failure.code.empty() || r.failure.message.empty()) std::abort();
    return 0;
  }
  const solid::gltf::Asset& a = r.model.asset;
  if (a.nodes.size() != 1) std::abort();
  for (const solid::gltf::Primitive& p : a.nodes[0].primitives) {
    const size_t n = p.positions.size() / 3;
    if (p.positions.size() % 3 != 0 || p.indices.size() % 3 != 0) std::abort();
    if (!p.normals.empty() && p.normals.size() != p.positions.size()) std::abort();
    if (!p.uvs.empty() && p.uvs.size() != 2 * n) std::abort();
    for (uint32_t i : p.indices) {
      if (i >= n) std::abort();
    }
    if (p.material && *p.material >= a.materials.size()) std::abort();
  }
  for (const solid::gltf::Material& m : a.materials) {
    if (m.base_color_texture && *m.base_color_texture >= a.textures.size()) std::abort();
  }
  return 0;
}
