// A contact sheet to look at assets with: one query view per model (a row of tiles per
// model set), then shaded layouts of a preset, in one PNG. For eyes, not for numbers.
//
//   contact_sheet --assets A [--rooms R] [--models 64] [--views 2] [--preset scenenet-background]
//                 [--layouts 12] [--seed 1] --out sheet.png
//
// Or of a rendered dataset (README's picture, docs/contact-sheet.png): rows of a stored image,
// its visible masks and its full masks, each at --scale of the image, then the query views of
// the model seen most often in those images, all read back from the shards as a user would.
//
//   contact_sheet --dataset D [--images 2] [--scale 0.4] --out sheet.png
#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include <fmt/format.h>

#include "solid/formats/dataset.h"
#include "solid/formats/image_codec.h"
#include "solid/formats/random.h"
#include "solid/formats/rle.h"
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

// `image` reduced by box filtering to `width` x `height` (each output pixel the mean of the
// input pixels its footprint covers, so thin objects do not alias away).
Image8 Reduce(const Image8& image, uint32_t width, uint32_t height) {
  Image8 out{width, height, 3, std::vector<uint8_t>(static_cast<size_t>(width) * height * 3)};
  for (uint32_t y = 0; y < height; ++y) {
    const uint32_t y0 = y * image.height / height, y1 = std::max(y0 + 1, (y + 1) * image.height / height);
    for (uint32_t x = 0; x < width; ++x) {
      const uint32_t x0 = x * image.width / width, x1 = std::max(x0 + 1, (x + 1) * image.width / width);
      for (uint32_t c = 0; c < 3; ++c) {
        uint32_t sum = 0;
        for (uint32_t sy = y0; sy < y1; ++sy) {
          for (uint32_t sx = x0; sx < x1; ++sx) sum += image.pixels[(static_cast<size_t>(sy) * image.width + sx) * image.channels + c];
        }
        out.pixels[(static_cast<size_t>(y) * width + x) * 3 + c] = static_cast<uint8_t>(sum / ((y1 - y0) * (x1 - x0)));
      }
    }
  }
  return out;
}

// A colour per instance ordinal, hues a golden angle apart, so neighbours differ.
std::array<uint8_t, 3> InstanceColour(int32_t ordinal) {
  const double hue = std::fmod(static_cast<double>(ordinal) * 0.618033988749895, 1.0) * 6;
  const double f = hue - std::floor(hue);
  const std::array<double, 6 * 3> sectors = {1, f, 0, 1 - f, 1, 0, 0, 1, f, 0, 1 - f, 1, f, 0, 1, 1, 0, 1 - f};
  const size_t k = static_cast<size_t>(hue) % 6;
  auto channel = [&](size_t c) { return static_cast<uint8_t>(60 + 195 * sectors[k * 3 + c]); };
  return {channel(0), channel(1), channel(2)};
}

// The image darkened, with each mask's pixels in its instance's colour (`alpha` of it over
// what is there) and the mask's boundary in full colour: overlapping full masks stay apart.
Image8 MaskPanel(const Image8& image, const std::vector<InstanceRecord>& instances, bool full, double alpha) {
  Image8 panel = image;
  for (uint8_t& p : panel.pixels) p = static_cast<uint8_t>(p * 0.35);
  for (const InstanceRecord& instance : instances) {
    Result<rle::Rle> rle = rle::FromString(full ? instance.full_rle : instance.visible_rle, image.height, image.width);
    if (!rle.ok()) continue;
    const std::vector<uint8_t> mask = rle::DecodeRowMajor(*rle);
    const std::array<uint8_t, 3> colour = InstanceColour(instance.ordinal);
    auto set = [&](uint32_t x, uint32_t y) { return x < image.width && y < image.height && mask[static_cast<size_t>(y) * image.width + x]; };
    for (uint32_t y = 0; y < image.height; ++y) {
      for (uint32_t x = 0; x < image.width; ++x) {
        if (!set(x, y)) continue;
        const bool edge = !set(x - 1, y) || !set(x + 1, y) || !set(x, y - 1) || !set(x, y + 1);
        const double a = edge ? 1.0 : alpha;
        uint8_t* p = &panel.pixels[(static_cast<size_t>(y) * image.width + x) * 3];
        for (size_t c = 0; c < 3; ++c) p[c] = static_cast<uint8_t>(p[c] * (1 - a) + colour[c] * a);
      }
    }
  }
  return panel;
}

Status WritePng(const Image8& sheet, const std::string& out) {
  SOLID_ASSIGN_OR_RETURN(const std::vector<uint8_t> png, EncodeImage(sheet, ImageFormat::kPng));
  std::ofstream file(out, std::ios::binary);
  file.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  return file ? Status::Ok() : IoError(out + ": cannot write");
}

// The README's picture: what a dataset holds, read back from its shards.
Status DatasetSheet(const std::string& root, int images, double scale, const std::string& out) {
  SOLID_ASSIGN_OR_RETURN(Dataset dataset, Dataset::Open(root));
  const Manifest& manifest = dataset.manifest();
  const auto tile_w = static_cast<uint32_t>(std::lround(manifest.width * scale));
  const auto tile_h = static_cast<uint32_t>(std::lround(manifest.height * scale));
  std::vector<std::array<Image8, 3>> rows;
  std::map<std::string, int> seen;
  // Images spread over the dataset, each with at least one visible instance.
  for (int k = 0; k < images; ++k) {
    const int64_t image_id = manifest.images * k / std::max(1, images) + manifest.images / (2 * std::max(1, images));
    SOLID_ASSIGN_OR_RETURN(const ImageRecord record, dataset.ReadImage(image_id));
    SOLID_ASSIGN_OR_RETURN(const std::vector<InstanceRecord> instances, dataset.Instances(image_id));
    SOLID_ASSIGN_OR_RETURN(const Image8 image, DecodeImage(record.image, record.format));
    for (const InstanceRecord& i : instances) seen[i.model_key] += i.visible_area > 0 ? 1 : 0;
    rows.push_back({Reduce(image, tile_w, tile_h), Reduce(MaskPanel(image, instances, false, 0.8), tile_w, tile_h),
                    Reduce(MaskPanel(image, instances, true, 0.3), tile_w, tile_h)});
  }
  const auto most_seen = std::max_element(seen.begin(), seen.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  std::vector<QueryViewRecord> views;
  if (most_seen != seen.end()) {
    SOLID_ASSIGN_OR_RETURN(views, dataset.QueryViews(most_seen->first));
  }
  const uint32_t gap = 4, width = 3 * tile_w + 2 * gap;
  const uint32_t view_side = views.empty() ? 0 : (width - gap * 7) / 8;
  Image8 sheet{width, static_cast<uint32_t>(rows.size()) * (tile_h + gap) + view_side, 3, {}};
  sheet.pixels.assign(static_cast<size_t>(sheet.width) * sheet.height * 3, 255);
  for (size_t r = 0; r < rows.size(); ++r) {
    for (size_t c = 0; c < 3; ++c) {
      Paste(sheet, rows[r][c], static_cast<int>(c * (tile_w + gap)), static_cast<int>(r * (tile_h + gap)),
            static_cast<int>(tile_w), static_cast<int>(tile_h));
    }
  }
  for (size_t v = 0; v < views.size() && v < 8; ++v) {
    SOLID_ASSIGN_OR_RETURN(const Image8 view, DecodeImage(views[v].image, views[v].format));
    const double fit = static_cast<double>(view_side) / std::max(view.width, view.height);
    const Image8 tile = Reduce(view, std::max(1u, static_cast<uint32_t>(view.width * fit)),
                               std::max(1u, static_cast<uint32_t>(view.height * fit)));
    Paste(sheet, tile, static_cast<int>(v * (view_side + gap)), static_cast<int>(rows.size() * (tile_h + gap)),
          static_cast<int>(view_side), static_cast<int>(view_side));
  }
  SOLID_RETURN_IF_ERROR(WritePng(sheet, out));
  fmt::print("{}: {} images of {} with their visible and full masks, {} query views of {}\n", out, rows.size(), root,
             views.size(), most_seen != seen.end() ? most_seen->first : "no model");
  return Status::Ok();
}

int Run(int argc, char** argv) {
  CLI::App app{"Contact sheet of query views and shaded layouts, or of a rendered dataset"};
  std::string assets, rooms, preset = "scenenet-background", out, dataset;
  int models = 64, views = 2, layouts = 12, columns = 8, images = 2;
  double scale = 0.4;
  uint64_t seed = 1;
  app.add_option("--dataset", dataset, "A rendered dataset: its images, visible and full masks, and query views")
      ->excludes(app.add_option("--assets", assets, "Assets directory with the models"));
  app.add_option("--images", images, "With --dataset: images shown")->capture_default_str();
  app.add_option("--scale", scale, "With --dataset: tile size as a share of the image's")->capture_default_str();
  app.add_option("--rooms", rooms, "Assets directory with the rooms (default: --assets)");
  app.add_option("--models", models, "Models shown (the first N by key)")->capture_default_str();
  app.add_option("--views", views, "Query views per model (of 8 azimuths)")->capture_default_str();
  app.add_option("--preset", preset, "Preset of the shaded layouts")->capture_default_str();
  app.add_option("--layouts", layouts, "Shaded layouts (320x240)")->capture_default_str();
  app.add_option("--columns", columns, "Tiles per row")->capture_default_str();
  app.add_option("--seed", seed, "Dataset seed")->capture_default_str();
  app.add_option("--out", out, "PNG to write")->required();
  CLI11_PARSE(app, argc, argv);
  if (!dataset.empty()) {
    const Status status = DatasetSheet(dataset, images, scale, out);
    if (!status.ok()) fmt::print(stderr, "{}\n", status.ToString());
    return status.ok() ? 0 : 1;
  }
  if (assets.empty()) {
    fmt::print(stderr, "--assets or --dataset is required\n");
    return 2;
  }

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
  if (const Status written = WritePng(sheet, out); !written.ok()) {
    fmt::print(stderr, "{}\n", written.ToString());
    return 1;
  }
  fmt::print("{}: {} query views of {} models, {} layouts of {}\n", out, tiles.size(), shown, renders.size(), preset);
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return Run(argc, argv); }
