// A contact sheet to look at assets with: one query view per model (a row of tiles per
// model set), then shaded layouts of a preset, in one PNG. For eyes, not for numbers.
//
//   contact_sheet --assets A [--rooms R] [--models 64] [--views 2] [--preset scenenet-background]
//                 [--layouts 12] [--seed 1] --out sheet.png
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include <fmt/format.h>

#include "solid/formats/image_codec.h"
#include "solid/formats/random.h"
#include "solid/render/assets.h"
#include "solid/render/params.h"
#include "solid/render/query_views.h"
#include "solid/render/sample.h"
#include "solid/render/shade.h"

namespace {

using namespace solid;
using namespace solid::render;

// Pastes `tile` centred into the cell (cx, cy) of size w x h of `sheet`.
void Paste(Image8& sheet, const Image8& tile, int x0, int y0, int w, int h) {
  const int ox = x0 + (w - static_cast<int>(tile.width)) / 2, oy = y0 + (h - static_cast<int>(tile.height)) / 2;
  for (uint32_t y = 0; y < tile.height; ++y) {
    for (uint32_t x = 0; x < tile.width; ++x) {
      const int sx = ox + static_cast<int>(x), sy = oy + static_cast<int>(y);
      if (sx < 0 || sy < 0 || sx >= static_cast<int>(sheet.width) || sy >= static_cast<int>(sheet.height)) continue;
      for (int c = 0; c < 3; ++c) {
        sheet.pixels[(static_cast<size_t>(sy) * sheet.width + sx) * 3 + c] = tile.pixels[(y * tile.width + x) * tile.channels + c];
      }
    }
  }
}

int Run(int argc, char** argv) {
  CLI::App app{"Contact sheet of query views and shaded layouts"};
  std::string assets, rooms, preset = "scenenet-background", out;
  int models = 64, views = 2, layouts = 12, columns = 8;
  uint64_t seed = 1;
  app.add_option("--assets", assets, "Assets directory with the models")->required();
  app.add_option("--rooms", rooms, "Assets directory with the rooms (default: --assets)");
  app.add_option("--models", models, "Models shown (the first N by key)")->capture_default_str();
  app.add_option("--views", views, "Query views per model (of 8 azimuths)")->capture_default_str();
  app.add_option("--preset", preset, "Preset of the shaded layouts")->capture_default_str();
  app.add_option("--layouts", layouts, "Shaded layouts (320x240)")->capture_default_str();
  app.add_option("--columns", columns, "Tiles per row")->capture_default_str();
  app.add_option("--seed", seed, "Dataset seed")->capture_default_str();
  app.add_option("--out", out, "PNG to write")->required();
  CLI11_PARSE(app, argc, argv);

  auto library = AssetLibrary::Open(assets, rooms.empty() ? assets : rooms);
  if (!library.ok()) {
    fmt::print(stderr, "{}\n", library.status().ToString());
    return 1;
  }
  TextureCache textures;
  std::vector<Image8> tiles, renders;
  const size_t shown = std::min<size_t>(static_cast<size_t>(models), (*library)->models().size());
  for (size_t i = 0; i < shown; ++i) {
    auto model = (*library)->Model(i);
    if (!model.ok()) {
      fmt::print(stderr, "{}\n", model.status().ToString());
      return 1;
    }
    QueryViewOptions options;
    options.long_side = 160;
    options.render_size = 256;
    options.threads = 2;
    auto rendered = RenderQueryViews(*model, MixSeed(seed, i), options, textures);
    if (!rendered.ok()) {
      fmt::print(stderr, "{}\n", rendered.status().ToString());
      return 1;
    }
    for (int v = 0; v < views && v < static_cast<int>(rendered->views.size()); ++v) {
      tiles.push_back(rendered->views[static_cast<size_t>(v * 8 / std::max(1, views)) % rendered->views.size()].image);
    }
  }
  if (layouts > 0) {
    auto params = LoadPreset(preset);
    if (!params.ok()) {
      fmt::print(stderr, "{}\n", params.status().ToString());
      return 1;
    }
    params->width = 320;
    params->height = 240;
    auto sampler = LayoutSampler::Create(*params, *library);
    if (!sampler.ok()) {
      fmt::print(stderr, "{}\n", sampler.status().ToString());
      return 1;
    }
    for (int i = 0; i < layouts; ++i) {
      auto generated = GenerateLayout(**sampler, seed, i);
      if (!generated.ok()) continue;
      auto shaded = Shade(generated->layout, generated->lights, {.samples_per_pixel = 4, .threads = 2}, textures);
      if (shaded.ok()) renders.push_back(std::move(shaded->image));
    }
  }
  const int tile = 170, render_w = 330, render_h = 250;
  const int render_columns = std::max(1, columns * tile / render_w);
  const int tile_rows = (static_cast<int>(tiles.size()) + columns - 1) / columns;
  const int render_rows = (static_cast<int>(renders.size()) + render_columns - 1) / render_columns;
  Image8 sheet{static_cast<uint32_t>(columns * tile), static_cast<uint32_t>(tile_rows * tile + render_rows * render_h), 3, {}};
  sheet.pixels.assign(static_cast<size_t>(sheet.width) * sheet.height * 3, 255);
  for (size_t k = 0; k < tiles.size(); ++k) {
    Paste(sheet, tiles[k], static_cast<int>(k % columns) * tile, static_cast<int>(k / columns) * tile, tile, tile);
  }
  for (size_t k = 0; k < renders.size(); ++k) {
    Paste(sheet, renders[k], static_cast<int>(k % render_columns) * render_w,
          tile_rows * tile + static_cast<int>(k / render_columns) * render_h, render_w, render_h);
  }
  auto png = EncodeImage(sheet, ImageFormat::kPng);
  if (!png.ok()) {
    fmt::print(stderr, "{}\n", png.status().ToString());
    return 1;
  }
  std::ofstream(out, std::ios::binary).write(reinterpret_cast<const char*>(png->data()), static_cast<std::streamsize>(png->size()));
  fmt::print("{}: {} query views of {} models, {} layouts of {}\n", out, tiles.size(), shown, renders.size(), preset);
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return Run(argc, argv); }
