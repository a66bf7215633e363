// libFuzzer target for the renderer's asset loader: gltf::ReadGlb (glb container, glTF
// JSON, Draco and plain geometry) followed by the decoding of every embedded texture,
// as render::AssetLibrary::Load and the shading's DecodeTextures do. A successful read
// must satisfy what LoadedAsset::Build relies on without checking (it hands the arrays
// to Embree): attribute arrays of matching lengths, indices inside them, material and
// texture indices in range.
#include <cstdint>
#include <span>

#include "fuzz/fuzz_util.h"
#include "solid/formats/glb.h"
#include "solid/formats/image_codec.h"

using solid::fuzz::Fail;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  solid::Result<solid::gltf::Asset> read = solid::gltf::ReadGlb(std::span<const uint8_t>(data, size), "fuzz.glb");
  if (!read.ok()) return 0;
  const solid::gltf::Asset& asset = *read;
  for (const solid::gltf::Node& node : asset.nodes) {
    for (const solid::gltf::Primitive& p : node.primitives) {
      if (p.positions.size() % 3 != 0) Fail("positions are not xyz triples");
      const size_t n = p.positions.size() / 3;
      if (!p.normals.empty() && p.normals.size() != 3 * n) Fail("normals and positions differ in count");
      if (!p.uvs.empty() && p.uvs.size() != 2 * n) Fail("uvs and positions differ in count");
      if (p.indices.size() % 3 != 0) Fail("indices are not triangles");
      for (uint32_t i : p.indices) {
        if (i >= n) Fail("an index is out of range");
      }
      if (p.material && *p.material >= asset.materials.size()) Fail("a material index is out of range");
    }
  }
  for (const solid::gltf::Material& m : asset.materials) {
    if (m.base_color_texture && *m.base_color_texture >= asset.textures.size()) Fail("a texture index is out of range");
  }
  for (const solid::gltf::Texture& t : asset.textures) {
    solid::ImageFormat format;
    if (t.mime_type == "image/png") {
      format = solid::ImageFormat::kPng;
    } else if (t.mime_type == "image/jpeg") {
      format = solid::ImageFormat::kJpeg;
    } else {
      continue;  // the renderer refuses it by name
    }
    solid::Result<solid::Image8> image = solid::DecodeImage(t.bytes, format);
    if (image.ok() && image->pixels.size() != size_t{image->width} * image->height * image->channels) {
      Fail("a decoded texture has the wrong number of bytes");
    }
  }
  return 0;
}
