// Our glb reader (formats/glb.cpp ReadGlb) against Debian's tinygltf on our own assets,
// Draco-compressed procedural shapes written by WriteGlb (docs/dependencies.md quotes what
// this prints): read time from memory, whether the triangles come out, and what each says
// about a damaged file. tinygltf's image decoding is replaced by a copy of the bytes, as
// ReadGlb keeps them.
//   glb_vs_tinygltf [--models N] [--triangles N] [--repeat N]
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <tiny_gltf.h>

#include <algorithm>

#include "solid/convert/procedural.h"
#include "solid/formats/glb.h"
#include "best_time.h"

namespace {

bool KeepImageBytes(tinygltf::Image* image, const int, std::string*, std::string*, int, int, const unsigned char* bytes,
                    int size, void*) {
  image->image.assign(bytes, bytes + size);
  return true;
}

struct Outcome {
  bool ok = false;
  size_t triangles = 0;  // readable without decoding anything ourselves
  std::string message;
};

Outcome Ours(const std::vector<uint8_t>& glb) {
  auto asset = solid::gltf::ReadGlb(glb, "asset.glb");
  Outcome out;
  if (!asset.ok()) {
    out.message = asset.status().ToString();
    return out;
  }
  out.ok = true;
  for (const auto& node : asset->nodes)
    for (const auto& prim : node.primitives) out.triangles += prim.indices.size() / 3;
  return out;
}

Outcome Theirs(const std::vector<uint8_t>& glb) {
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(KeepImageBytes, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  Outcome out;
  out.ok = loader.LoadBinaryFromMemory(&model, &err, &warn, glb.data(), static_cast<unsigned>(glb.size()));
  out.message = err + warn;
  while (!out.message.empty() && out.message.back() == '\n') out.message.pop_back();
  // Triangles are there only when an index accessor has a bufferView (Draco ones have none).
  for (const auto& mesh : model.meshes)
    for (const auto& prim : mesh.primitives)
      if (prim.indices >= 0 && model.accessors[prim.indices].bufferView >= 0)
        out.triangles += model.accessors[prim.indices].count / 3;
  return out;
}

using solid::bench::BestMs;

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"glb reading: formats/glb.cpp vs tinygltf, on our Draco assets"};
  int models = 4, triangles = 20000, repeat = 5;
  app.add_option("--models", models, "procedural shapes to write and read")->check(CLI::PositiveNumber);
  app.add_option("--triangles", triangles, "about this many triangles each")->check(CLI::Range(1250, 4000000));
  app.add_option("--repeat", repeat, "timed runs per file (the best is shown)")->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);

  solid::convert::ProceduralShapeOptions options;
  options.min_triangles = static_cast<int>(triangles * 0.8);
  options.max_triangles = triangles;
  std::vector<uint8_t> first;
  fmt::print("== reading our Draco glb files from memory (best of {})\n", repeat);
  for (int i = 0; i < models; ++i) {
    auto asset = solid::convert::MakeProceduralShape(0x5eed, i, fmt::format("procedural/shape-{:06}", i), options);
    auto glb = asset.ok() ? solid::gltf::WriteGlb(*asset) : solid::Result<std::vector<uint8_t>>(asset.status());
    if (!glb.ok()) {
      fmt::print(stderr, "{}\n", glb.status().ToString());
      return 1;
    }
    if (first.empty()) first = *glb;
    const Outcome ours = Ours(*glb), theirs = Theirs(*glb);
    const double ours_ms = BestMs(repeat, [&] { Ours(*glb); });
    const double theirs_ms = BestMs(repeat, [&] { Theirs(*glb); });
    fmt::print("shape {} ({:.0f} kB): ours {:7.2f} ms, {} triangles{}; tinygltf {:7.2f} ms, {} triangles readable{}{}\n",
               i, glb->size() / 1e3, ours_ms, ours.triangles, ours.ok ? "" : " FAILED", theirs_ms, theirs.triangles,
               theirs.ok ? "" : " FAILED", theirs.message.empty() ? "" : " (" + theirs.message + ")");
  }

  fmt::print("\n== damaged files\n");
  struct Damage {
    const char* what;
    std::vector<uint8_t> bytes;
  };
  std::vector<Damage> damages;
  damages.push_back({"truncated to half", std::vector<uint8_t>(first.begin(), first.begin() + first.size() / 2)});
  std::vector<uint8_t> flipped = first;
  flipped[flipped.size() - 200] ^= 0xff;  // inside the last Draco stream or texture
  damages.push_back({"one byte flipped near the end", flipped});
  std::vector<uint8_t> json_broken = first;
  json_broken[40] = '}';  // inside the JSON chunk
  damages.push_back({"JSON chunk broken", json_broken});
  for (const Damage& damage : damages) {
    const Outcome ours = Ours(damage.bytes), theirs = Theirs(damage.bytes);
    fmt::print("-- {}\n   ours:     {}\n   tinygltf: {}{}\n", damage.what,
               ours.ok ? fmt::format("accepted ({} triangles)", ours.triangles) : ours.message,
               theirs.ok ? "accepted" : "refused", theirs.message.empty() ? "" : ": " + theirs.message);
  }
  return 0;
}
