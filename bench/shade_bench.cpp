// Shading and query-view throughput on procedural assets (or an assets directory):
// renders `--layouts` layouts of each preset at 640x480 and 320x240, then the query
// views of `--models` models, and prints milliseconds per image and images per
// second. `--out DIR` also writes every image as PNG, for looking at them.
// Not a Google Benchmark program: one item is a whole image, so plain wall time is
// the measurement that matters (layout sampling and the mask pass are excluded).
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "solid/convert/convert.h"
#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"
#include "solid/formats/random.h"
#include "solid/render/query_views.h"
#include "solid/render/sample.h"
#include "solid/render/shade.h"

namespace {

using namespace solid;
using namespace solid::render;

struct Resolution {
  int width, height, spp;
};

Status WritePng(const std::filesystem::path& path, const Image8& image) {
  SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> png, EncodeImage(image, ImageFormat::kPng));
  return files::WriteFileAtomically(path, png);
}

Status Run(const std::filesystem::path& assets, const std::vector<std::string>& presets, int layouts, int models,
           int threads, const std::filesystem::path& out) {
  SOLID_ASSIGN_OR_RETURN(std::shared_ptr<AssetLibrary> library, AssetLibrary::Open(assets, assets));
  TextureCache textures;
  if (!out.empty()) std::filesystem::create_directories(out);
  for (const std::string& preset : presets) {
    SOLID_ASSIGN_OR_RETURN(LayoutParams params, LoadPreset(preset));
    for (const Resolution r : {Resolution{640, 480, 4}, Resolution{320, 240, 1}}) {
      params.width = r.width;
      params.height = r.height;
      SOLID_ASSIGN_OR_RETURN(auto sampler, LayoutSampler::Create(params, library));
      double ms = 0;
      for (int i = 0; i < layouts; ++i) {
        SOLID_ASSIGN_OR_RETURN(GeneratedLayout g, GenerateLayout(*sampler, 1, i, MaskPassOptions{threads}));
        SOLID_ASSIGN_OR_RETURN(LightRig lights, SampleLights(g.layout));
        SOLID_ASSIGN_OR_RETURN(ShadeResult shaded, Shade(g.layout, lights, ShadeOptions{r.spp, threads}, textures, &g.masks));
        ms += shaded.ms;
        if (!out.empty()) {
          SOLID_RETURN_IF_ERROR(WritePng(out / fmt::format("{}-{}x{}-{:03}.png", preset, r.width, r.height, i),
                                         shaded.image));
        }
      }
      fmt::print("shade\t{}\t{}x{}\t{} spp\t{} threads\t{:.1f} ms/image\t{:.2f} images/s\n", preset, r.width,
                 r.height, r.spp, threads, ms / layouts, 1000.0 * layouts / ms);
    }
  }
  double ms = 0;
  int views = 0;
  QueryViewOptions options;
  options.threads = threads;
  for (int m = 0; m < models && m < static_cast<int>(library->models().size()); ++m) {
    SOLID_ASSIGN_OR_RETURN(auto model, library->Model(static_cast<size_t>(m)));
    SOLID_ASSIGN_OR_RETURN(QueryViewsResult q, RenderQueryViews(model, MixSeed(1, m), options, textures));
    ms += q.ms;
    views += static_cast<int>(q.views.size());
    for (const QueryView& v : q.views) {
      if (out.empty()) continue;
      SOLID_RETURN_IF_ERROR(WritePng(out / fmt::format("query-{:02}-{:03.0f}.png", m, v.azimuth_deg), v.image));
    }
  }
  fmt::print("query\t{} models\t{} views\t{} threads\t{:.1f} ms/view\t{:.1f} views/s\n", models, views, threads,
             ms / views, 1000.0 * views / ms);
  return Status::Ok();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Shading and query-view throughput"};
  std::filesystem::path assets, out;
  std::vector<std::string> presets = {"random-placement", "occlusion"};
  int layouts = 4, models = 4, threads = 2;
  app.add_option("--assets", assets, "assets directory with models and rooms (default: procedural, generated)");
  app.add_option("--preset", presets, "presets to render")->capture_default_str();
  app.add_option("--layouts", layouts, "layouts per preset and resolution")->capture_default_str();
  app.add_option("--models", models, "models whose query views are rendered")->capture_default_str();
  app.add_option("--threads", threads, "threads per image")->capture_default_str();
  app.add_option("--out", out, "write PNGs here");
  CLI11_PARSE(app, argc, argv);
  std::filesystem::path generated;
  if (assets.empty()) {
    generated = std::filesystem::temp_directory_path() / fmt::format("solid-shade-bench-{}", ::getpid());
    const auto report = convert::Convert({.out = generated, .procedural = {16, 3, 7}});
    if (!report.ok()) {
      fmt::print(stderr, "procedural assets: {}\n", report.status().ToString());
      return 1;
    }
    assets = generated;
  }
  const Status status = Run(assets, presets, layouts, models, threads, out);
  if (!generated.empty()) std::filesystem::remove_all(generated);
  if (!status.ok()) {
    fmt::print(stderr, "shade_bench: {}\n", status.ToString());
    return 1;
  }
  return 0;
}
