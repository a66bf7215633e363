// fuzz_seeds OUT: writes the generated seed corpora of the fuzz targets, one directory per
// target (OUT/shard, OUT/query_shard, OUT/index, OUT/catalog, OUT/glb, OUT/image, OUT/rle,
// OUT/manifest, OUT/params). Binary seeds are produced by our writers rather than checked
// in, so they follow the formats as they change. The SQLite files are rewritten with
// 512-byte pages (VACUUM): the same schema and rows in a few KiB instead of one 16 KiB page
// per table and index, so that mutations land on content rather than on free space.
// The text seeds of obj and search_space are checked in under tests/fuzz/corpus/.
#include <sqlite3.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "fixtures/layered_dataset.h"
#include "fuzz/fuzz_util.h"
#include "solid/formats/catalog.h"
#include "solid/formats/dataset.h"
#include "solid/formats/glb.h"
#include "solid/formats/image_codec.h"
#include "solid/formats/rle.h"
#include "solid/formats/schemas.h"
#include "solid/render/params.h"

namespace fs = std::filesystem;
using solid::fuzz::Fail;

namespace {

template <typename T>
T OrDie(solid::Result<T> r, std::string_view what) {
  if (!r.ok()) Fail(fmt::format("{}: {}", what, r.status().message()));
  return std::move(r).value();
}

void OrDie(const solid::Status& s, std::string_view what) {
  if (!s.ok()) Fail(fmt::format("{}: {}", what, s.message()));
}

void Write(const fs::path& path, std::span<const uint8_t> bytes) { solid::fuzz::WriteFileOrDie(path, bytes); }

void Write(const fs::path& path, std::string_view text) {
  Write(path, {reinterpret_cast<const uint8_t*>(text.data()), text.size()});
}

// Copies a SQLite file to `to` with 512-byte pages and a rollback journal.
void CopyCompacted(const fs::path& from, const fs::path& to) {
  fs::copy_file(from, to, fs::copy_options::overwrite_existing);
  sqlite3* db = nullptr;
  if (sqlite3_open(to.c_str(), &db) != SQLITE_OK) Fail("sqlite3_open " + to.string());
  char* error = nullptr;
  if (sqlite3_exec(db, "PRAGMA journal_mode = DELETE; PRAGMA page_size = 512; VACUUM;", nullptr, nullptr, &error) !=
      SQLITE_OK) {
    Fail(fmt::format("VACUUM {}: {}", to.string(), error != nullptr ? error : "?"));
  }
  sqlite3_close(db);
}

solid::Image8 Gradient(uint32_t width, uint32_t height, uint32_t channels) {
  solid::Image8 image{width, height, channels, {}};
  for (uint32_t y = 0; y < height; ++y) {
    for (uint32_t x = 0; x < width; ++x) {
      for (uint32_t c = 0; c < channels; ++c) image.pixels.push_back(static_cast<uint8_t>(x * 40 + y * 30 + c * 70));
    }
  }
  return image;
}

// A tetrahedron with normals and uvs: four vertices, four triangles.
solid::gltf::Primitive Tetrahedron() {
  solid::gltf::Primitive p;
  p.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  p.normals = {-0.577f, -0.577f, -0.577f, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  p.uvs = {0, 0, 1, 0, 0, 1, 1, 1};
  p.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  return p;
}

void WriteGlbSeeds(const fs::path& dir) {
  const std::vector<uint8_t> png = OrDie(solid::EncodeImage(Gradient(4, 4, 3), solid::ImageFormat::kPng), "png");
  const std::vector<uint8_t> jpeg = OrDie(solid::EncodeImage(Gradient(8, 8, 3), solid::ImageFormat::kJpeg), "jpeg");

  // What `solid convert` writes: Draco geometry, a textured and a plain material, extras.
  solid::gltf::Asset asset;
  asset.textures = {{"wood.png", "image/png", png}, {"metal.jpg", "image/jpeg", jpeg}};
  asset.materials.push_back({"textured", {1, 1, 1, 1}, false, 0, 1, 0, false});
  asset.materials.push_back({"glass", {0.2f, 0.5f, 0.9f, 0.4f}, true, 0.1f, 0.3f, 1, true});
  solid::gltf::Node node{"02691156/model", {Tetrahedron(), Tetrahedron()}, {{"structure", "wall"}}};
  node.primitives[0].material = 0;
  node.primitives[1].material = 1;
  node.primitives[1].uvs.clear();
  asset.nodes.push_back(node);
  asset.nodes.push_back({"bare", {Tetrahedron()}, nlohmann::json::object()});
  asset.nodes.back().primitives[0].normals.clear();
  asset.extras = {{"source", "fuzz seed"}};
  Write(dir / "draco.glb", OrDie(solid::gltf::WriteGlb(asset), "WriteGlb"));

  // Plain accessors (other tools' glb files): float attributes, normalized ushort uvs,
  // ubyte and uint indices, a strided view, a texture in a bufferView.
  const solid::gltf::Primitive t = Tetrahedron();
  std::vector<uint8_t> bin;
  auto view = [&](const void* data, size_t bytes, std::optional<uint32_t> stride = std::nullopt) {
    bin.resize((bin.size() + 3) & ~size_t{3}, 0);
    nlohmann::json v = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}};
    if (stride) v["byteStride"] = *stride;
    const auto* p = static_cast<const uint8_t*>(data);
    bin.insert(bin.end(), p, p + bytes);
    return v;
  };
  std::vector<float> interleaved;  // position and normal per vertex
  for (size_t v = 0; v < 4; ++v) {
    interleaved.insert(interleaved.end(), t.positions.begin() + 3 * v, t.positions.begin() + 3 * v + 3);
    interleaved.insert(interleaved.end(), t.normals.begin() + 3 * v, t.normals.begin() + 3 * v + 3);
  }
  const std::vector<uint16_t> uvs = {0, 0, 65535, 0, 0, 65535, 65535, 65535};
  const std::vector<uint8_t> indices8(t.indices.begin(), t.indices.end());
  nlohmann::json views = nlohmann::json::array();
  views.push_back(view(interleaved.data(), interleaved.size() * 4, 24));
  views.push_back(view(uvs.data(), uvs.size() * 2));
  views.push_back(view(indices8.data(), indices8.size()));
  views.push_back(view(t.indices.data(), t.indices.size() * 4));
  views.push_back(view(png.data(), png.size()));
  bin.resize((bin.size() + 3) & ~size_t{3}, 0);
  const nlohmann::json gltf = {
      {"asset", {{"version", "2.0"}, {"extras", {{"source", "fuzz seed"}}}}},
      {"buffers", {{{"byteLength", bin.size()}}}},
      {"bufferViews", views},
      {"accessors",
       {{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
        {{"bufferView", 0}, {"byteOffset", 12}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
        {{"bufferView", 1}, {"componentType", 5123}, {"normalized", true}, {"count", 4}, {"type", "VEC2"}},
        {{"bufferView", 2}, {"componentType", 5121}, {"count", 12}, {"type", "SCALAR"}},
        {{"bufferView", 3}, {"componentType", 5125}, {"count", 12}, {"type", "SCALAR"}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"TEXCOORD_0", 2}}}, {"indices", 3}, {"material", 0}},
           {{"attributes", {{"POSITION", 0}}}, {"indices", 4}, {"mode", 4}}}}}}},
      {"nodes", {{{"mesh", 0}, {"name", "plain"}, {"extras", {{"structure", "floor"}}}}, {{"name", "empty"}}}},
      {"materials",
       {{{"name", "m"},
         {"pbrMetallicRoughness",
          {{"baseColorFactor", {1, 0.5, 0.25, 1}}, {"baseColorTexture", {{"index", 0}}}, {"metallicFactor", 0}}},
         {"alphaMode", "MASK"},
         {"doubleSided", true}}}},
      {"textures", {{{"source", 0}}}},
      {"images", {{{"bufferView", 4}, {"mimeType", "image/png"}, {"name", "tex.png"}}}}};
  const std::vector<uint8_t> plain = OrDie(solid::gltf::PackGlb(gltf, bin), "PackGlb");
  OrDie(solid::gltf::ReadGlb(plain, "plain.glb").status(), "the plain glb seed does not read back");
  Write(dir / "plain.glb", plain);
}

void WriteImageSeeds(const fs::path& dir) {
  // image_fuzz's first byte picks the decoder: the ImageFormat value, or 3 for depth EXR.
  auto seed = [&](const std::string& name, uint8_t selector, std::vector<uint8_t> bytes) {
    bytes.insert(bytes.begin(), selector);
    Write(dir / name, bytes);
  };
  using solid::ImageFormat;
  seed("rgb.png", 0, OrDie(solid::EncodeImage(Gradient(5, 3, 3), ImageFormat::kPng), "png"));
  seed("grey.png", 0, OrDie(solid::EncodeImage(Gradient(3, 2, 1), ImageFormat::kPng), "png"));
  seed("rgba.png", 0, OrDie(solid::EncodeImage(Gradient(2, 3, 4), ImageFormat::kPng), "png"));
  seed("rgb.jpeg", 1, OrDie(solid::EncodeImage(Gradient(8, 8, 3), ImageFormat::kJpeg, 50), "jpeg"));
  seed("rgb.webp", 2, OrDie(solid::EncodeImage(Gradient(6, 4, 3), ImageFormat::kWebp, 50), "webp"));
  std::vector<float> depth(6 * 4);
  for (size_t i = 0; i < depth.size(); ++i) depth[i] = 1.0f + 0.25f * static_cast<float>(i);
  seed("depth.exr", 3, OrDie(solid::EncodeDepthExr({6, 4, depth}), "exr"));
}

void WriteRleSeeds(const fs::path& dir) {
  // rle_fuzz's input: a mode byte (1: counts string, 0: uint32 runs), height, width, payload.
  auto header = [](uint8_t mode, uint32_t height, uint32_t width) {
    std::vector<uint8_t> out(9);
    out[0] = mode;
    std::memcpy(out.data() + 1, &height, 4);
    std::memcpy(out.data() + 5, &width, 4);
    return out;
  };
  struct Shape {
    const char* name;
    uint32_t height, width;
    solid::rle::Box box;
  };
  for (const Shape& s : {Shape{"box", 24, 32, {5, 3, 10, 7}}, Shape{"border", 6, 9, {-2, 4, 20, 9}},
                         Shape{"empty", 4, 4, {0, 0, 0, 0}}, Shape{"full", 3, 5, {0, 0, 5, 3}}}) {
    const solid::rle::Rle r = solid::rle::FromBox(s.box, s.height, s.width);
    std::vector<uint8_t> text = header(1, s.height, s.width);
    const std::string counts = solid::rle::ToString(r);
    text.insert(text.end(), counts.begin(), counts.end());
    Write(dir / fmt::format("{}.string", s.name), text);
    std::vector<uint8_t> runs = header(0, s.height, s.width);
    for (uint32_t c : r.counts) {
      runs.resize(runs.size() + 4);
      std::memcpy(runs.data() + runs.size() - 4, &c, 4);
    }
    Write(dir / fmt::format("{}.runs", s.name), runs);
  }
  // Runs long enough for multi-character numbers and the delta coding of runs 3 and on.
  std::vector<uint8_t> mask(64 * 48, 0);
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = (i / 7 + i / 500) % 3 == 0;
  std::vector<uint8_t> text = header(1, 48, 64);
  const std::string counts = solid::rle::ToString(solid::rle::EncodeRowMajor(mask, 48, 64));
  text.insert(text.end(), counts.begin(), counts.end());
  Write(dir / "stripes.string", text);
}

void WriteCatalogSeed(const fs::path& dir, const fs::path& scratch) {
  const fs::path path = scratch / "catalog.sqlite";
  {
    solid::Catalog catalog = OrDie(solid::Catalog::OpenForWriting(path), "catalog");
    solid::CatalogEntry ok;
    ok.key = "02691156/1a04e3eab45ca15dd86060f189eb133";
    ok.kind = "model";
    ok.source = "shapenet_v2";
    ok.file = "models/02691156/1a04e3eab45ca15dd86060f189eb133.glb";
    ok.input_files = {"02691156/1a04e3eab45ca15dd86060f189eb133/models/model_normalized.obj"};
    ok.input_hash = 0x1234;
    ok.converter_version = "0.2.0";
    ok.options_hash = 0x5678;
    ok.vertices = 120;
    ok.triangles = 200;
    ok.materials = 2;
    ok.textures = 1;
    ok.bounds = std::array<double, 6>{-1, -0.5, -0.25, 1, 0.5, 0.25};
    ok.bytes_in = 40000;
    ok.bytes_out = 3000;
    ok.output_xxh64 = 0xfedcba9876543210ULL;
    ok.status = solid::AssetStatus::kOkWithWarnings;
    ok.warnings = {{{"code", "missing_texture"}, {"message", "texture.jpg not found"}}};
    ok.counts = {{"objects", 3}};
    ok.extras = {{"synset", "02691156"}};
    OrDie(catalog.Put(ok), "put");
    solid::CatalogEntry room = ok;
    room.key = "room/bedroom-01";
    room.kind = "room";
    room.source = "scenenet";
    room.file = "rooms/bedroom-01.glb";
    room.status = solid::AssetStatus::kOk;
    room.warnings = nlohmann::json::array();
    OrDie(catalog.Put(room), "put");
    solid::CatalogEntry failed;
    failed.key = "02691156/broken";
    failed.kind = "model";
    failed.source = "shapenet_v1";
    failed.status = solid::AssetStatus::kFailed;
    failed.error_code = "parse_error";
    failed.error = "model.obj:12: bad face";
    OrDie(catalog.Put(failed), "put");
  }
  CopyCompacted(path, dir / "catalog.sqlite");
}

void WriteDatasetSeeds(const fs::path& out, const fs::path& scratch) {
  // The index seed must describe the dataset index_fuzz writes: the same options.
  const solid::DatasetPaths seed(scratch / "dataset");
  OrDie(solid::fixtures::WriteLayeredDataset(seed.root, solid::fuzz::SeedDatasetOptions()), "dataset");
  CopyCompacted(seed.shard(0), out / "shard" / "depth.sqlite");
  CopyCompacted(seed.query_shard(0), out / "query_shard" / "views.sqlite");
  CopyCompacted(seed.index(), out / "index" / "index.sqlite");
  // Without depth maps, and with images only partly covered by objects.
  solid::fixtures::LayeredDatasetOptions plain = solid::fuzz::SeedDatasetOptions();
  plain.depth = false;
  plain.images = 1;
  plain.seed = 3;
  plain.queries = false;
  const solid::DatasetPaths second(scratch / "plain");
  OrDie(solid::fixtures::WriteLayeredDataset(second.root, plain), "dataset");
  CopyCompacted(second.shard(0), out / "shard" / "plain.sqlite");
}

void WriteJsonSeeds(const fs::path& out) {
  const solid::Manifest manifest = solid::fixtures::LayeredManifest(solid::fuzz::SeedDatasetOptions());
  Write(out / "manifest" / "manifest.json", manifest.ToJson().dump(2) + "\n");
  for (const std::string& name : solid::render::PresetNames()) {
    const solid::render::LayoutParams params = OrDie(solid::render::LoadPreset(name), "preset");
    Write(out / "params" / (name + ".json"), solid::render::ParamsToJson(params).dump(2) + "\n");
    Write(out / "params" / (name + ".preset.json"),
          OrDie(solid::schemas::Get(fmt::format("presets/{}.json", name)), "preset text"));
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_seeds OUT\n");
    return 2;
  }
  const fs::path out = argv[1];
  for (const char* target : {"shard", "query_shard", "index", "catalog", "glb", "image", "rle", "manifest", "params"}) {
    fs::create_directories(out / target);
  }
  const fs::path scratch = solid::fuzz::ScratchDir();
  WriteDatasetSeeds(out, scratch);
  WriteCatalogSeed(out / "catalog", scratch);
  WriteGlbSeeds(out / "glb");
  WriteImageSeeds(out / "image");
  WriteRleSeeds(out / "rle");
  WriteJsonSeeds(out);
  return 0;
}
