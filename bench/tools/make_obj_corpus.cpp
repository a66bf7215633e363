// Writes a ShapeNet-v2-like corpus for the convert benchmark: N models of procedural
// shapes as models/model_normalized.{obj,mtl} + images/texture*.png, in the Assimp
// conventions of ShapeNet v2 (docs "input-formats" 1.5), with triangle counts spread
// log-uniformly over [--min-triangles, --max-triangles].
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cmath>
#include <fstream>

#include "solid/convert/procedural.h"
#include "solid/formats/checksum.h"

namespace fs = std::filesystem;
using namespace solid;

namespace {

bool WriteModel(const gltf::Asset& asset, const fs::path& dir) {
  fs::create_directories(dir / "models");
  fs::create_directories(dir / "images");
  std::string obj = "# File produced by Open Asset Import Library (http://www.assimp.sf.net)\n"
                    "# (assimp v3.2.0)\n\nmtllib model_normalized.mtl\n\n";
  std::string mtl = "# File produced by Open Asset Import Library (http://www.assimp.sf.net)\n\n";
  for (size_t t = 0; t < asset.textures.size(); ++t) {
    std::ofstream(dir / "images" / fmt::format("texture{}.png", t), std::ios::binary)
        .write(reinterpret_cast<const char*>(asset.textures[t].bytes.data()),
               static_cast<std::streamsize>(asset.textures[t].bytes.size()));
  }
  for (size_t m = 0; m < asset.materials.size(); ++m) {
    const gltf::Material& mat = asset.materials[m];
    mtl += fmt::format("newmtl material_{}\nKd {} {} {}\nKa 0 0 0\nKs 0.4 0.4 0.4\nd {}\nNs 10\nillum 2\n", m,
                       mat.base_color[0], mat.base_color[1], mat.base_color[2], mat.base_color[3]);
    if (mat.base_color_texture) mtl += fmt::format("map_Kd ../images/texture{}.png\n", *mat.base_color_texture);
    mtl += "\n";
  }
  size_t base = 0;
  for (const gltf::Node& node : asset.nodes) {
    for (size_t p = 0; p < node.primitives.size(); ++p) {
      const gltf::Primitive& prim = node.primitives[p];
      size_t n = prim.positions.size() / 3;
      for (size_t i = 0; i < n; ++i) {
        obj += fmt::format("v {:f} {:f} {:f}\n", prim.positions[3 * i], prim.positions[3 * i + 1], prim.positions[3 * i + 2]);
      }
      for (size_t i = 0; i < n && !prim.uvs.empty(); ++i) {
        obj += fmt::format("vt {:g} {:g} 0\n", prim.uvs[2 * i], 1.0f - prim.uvs[2 * i + 1]);
      }
      for (size_t i = 0; i < n && !prim.normals.empty(); ++i) {
        obj += fmt::format("vn {:g} {:g} {:g}\n", prim.normals[3 * i], prim.normals[3 * i + 1], prim.normals[3 * i + 2]);
      }
      obj += fmt::format("g mesh{}\nusemtl material_{}\n", p, prim.material.value_or(0));
      for (size_t i = 0; i + 2 < prim.indices.size(); i += 3) {
        obj += "f ";
        for (int k = 0; k < 3; ++k) {
          size_t v = base + prim.indices[i + static_cast<size_t>(k)] + 1;
          obj += fmt::format(" {}/{}/{}", v, v, v);
        }
        obj += "\n";
      }
      base += n;
    }
  }
  std::ofstream(dir / "models" / "model_normalized.obj", std::ios::binary) << obj;
  std::ofstream(dir / "models" / "model_normalized.mtl", std::ios::binary) << mtl;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out;
  int models = 300, min_triangles = 5000, max_triangles = 100000;
  uint64_t seed = 1;
  CLI::App app{"Write a ShapeNet-v2-like OBJ corpus for the convert benchmark"};
  app.add_option("OUT", out, "Corpus root")->required();
  app.add_option("--models", models, "Number of models")->capture_default_str();
  app.add_option("--min-triangles", min_triangles)->capture_default_str();
  app.add_option("--max-triangles", max_triangles)->capture_default_str();
  app.add_option("--seed", seed)->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  for (int i = 0; i < models; ++i) {
    // Log-uniform triangle budgets: ShapeNet has a heavy tail of large models.
    double t = (Xxh64(fmt::format("{}-{}", seed, i)) >> 11) * 0x1.0p-53;
    int target = static_cast<int>(min_triangles * std::pow(double(max_triangles) / min_triangles, t));
    convert::ProceduralShapeOptions options;
    options.min_triangles = target;
    options.max_triangles = target * 2;
    std::string id = Hex64(Xxh64(fmt::format("model-{}-{}", seed, i))) + Hex64(static_cast<uint64_t>(i));
    auto asset = convert::MakeProceduralShape(seed, i, "02691156/" + id, options);
    if (!asset.ok()) {
      fmt::print(stderr, "model {}: {}\n", i, asset.status().message());
      return 1;
    }
    WriteModel(*asset, fs::path(out) / "02691156" / id);
  }
  fmt::print("wrote {} models to {}\n", models, out);
  return 0;
}
