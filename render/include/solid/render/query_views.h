// Query views: every model alone on an empty background, seen from 8 azimuths, as
// the reference renders them (solid-method.md 2.8) with D16's "fit" framing.
//
// The model is centred on its bounding box at the origin and rotated by Euler XYZ
// (-30 deg, U(-180, 180), U(-180, 180)) drawn once per model from `seed`. The camera
// circles it at elevation 0 (Z up) at distance d such that the bounding sphere
// (radius: half the box diagonal) spans 80% of the frame: rho = 0.8 d tan(fov / 2).
// Light: one point light at the camera of 1000 W x (d / 3 m)^2 (the reference's
// 1000 W at 3 m, scaled with the distance), the world's grey 0.05 as ambient and
// background. Shading as shade.h. Each view is cropped tightly to the model's projected
// extent (its vertices' bounding box in the render_size frame, no margin) and traced
// directly at that crop's aspect with its long side `long_side`, at samples_per_pixel
// uniform samples per pixel.
// The background is linear grey 0.05: sRGB (59, 59, 59) after the tone curve.
//
// Views where no sample hits the object are left out (D6: failed views are not stored);
// `failed` lists their azimuths. Deterministic: the same bytes for any thread count.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "solid/formats/image_codec.h"
#include "solid/render/assets.h"
#include "solid/render/shade.h"

namespace solid::render {

struct QueryViewOptions {
  int views = 8;            // at azimuths 0, 360 / views, ... degrees
  int render_size = 384;    // square render before cropping, pixels
  int long_side = 224;      // of each stored view, pixels
  double hfov_deg = 39.6;   // on both axes
  double light_power_w = 1000;
  int samples_per_pixel = 4;
  int threads = 1;
};

struct QueryView {
  Image8 image;  // RGB, long side = long_side
  double azimuth_deg = 0, elevation_deg = 0;
  // The view's rectangle [x0, x1) x [y0, y1) of the render_size x render_size frame, in
  // that frame's pixel coordinates.
  double crop_x0 = 0, crop_y0 = 0, crop_x1 = 0, crop_y1 = 0;
};

struct QueryViewsResult {
  std::vector<QueryView> views;
  std::vector<double> failed;  // azimuths (degrees) of views where the model covers nothing
  std::array<double, 3> euler_xyz_deg = {0, 0, 0};  // the model's rotation
  double distance = 0;  // camera distance, in the model's units
  double ms = 0;
};

// kInvalidArgument for bad options. Texture errors name the model.
// Seed: e.g. MixSeed(dataset seed, XXH64 of the model key).
Result<QueryViewsResult> RenderQueryViews(const std::shared_ptr<const LoadedAsset>& model, uint64_t seed,
                                          const QueryViewOptions& options, TextureCache& textures);

}  // namespace solid::render
