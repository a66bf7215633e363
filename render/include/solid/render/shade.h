// Shading: the RGB image of a layout, ray traced with Embree on the mask pass's
// camera and pixel grid (so masks and images line up), after solid-method.md 2.6-2.7.
//
// Light (radiometric units as Cycles uses them, linear Rec.709 radiance):
// - three square, one-sided, Lambertian ("spread 180 deg") area lights aimed at one
//   placed object (key, fill, back; SampleLights), Cycles' convention for a light of
//   power P W and area A: radiance P / (4 A). One shadow ray per light per sample to
//   a stratified point on the light, so small lights give soft, noise-free shadows;
// - the ceiling's emission (U(0.5, 1) x its colour in rooms, U(0, 1) x grey 0.8 in
//   the white cube) as an overhead "sky": irradiance pi * L_c * F * (1 + n_z) / 2,
//   F the view factor of the room's ceiling from the target's height; plus a uniform
//   ambient of the world's grey 0.05 and one diffuse bounce of the sky off the shell
//   (mean shell albedo x sky). Both ambient terms are multiplied by an ambient
//   obscurance: one cosine-weighted ray per sample, up to 0.75 m, a blocker at t
//   letting t / 0.75 through (far less noisy than binary occlusion). This
//   stands in for the reference's emissive ceiling with 3 diffuse bounces at a
//   fraction of the cost (no path tracing, no denoiser);
// - materials: glTF base colour factor x base colour texture (sRGB decoded,
//   bilinear, repeat wrap), Lambertian diffuse (1 - metallic) plus a normalized
//   Blinn-Phong lobe (exponent 2 / roughness^4 - 2, at most 1024) with F0 = 0.04
//   (dielectric) blended to the base colour by metallic. Alpha is ignored (opaque, as
//   in the ID pass). Surfaces are two-sided.
// Anti-aliasing: samples_per_pixel stratified, jittered samples over each pixel (a
// box filter); light-point and ambient directions use their own shuffled strata.
// Output: the mean radiance through a filmic tone curve (Narkowicz's ACES fit, so
// that highlights roll off as under the reference's Filmic view transform), then sRGB.
//
// Determinism: lights draw from Rng(MixSeed(layout.seed, layout.restart), lights
// stream); pixel p draws from Rng(MixSeed(that seed, p), shading stream). The image
// is the same bytes for any thread count.
#pragma once

#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/asset.h"
#include "solid/formats/image_codec.h"
#include "solid/render/layout.h"
#include "solid/render/mask_pass.h"

namespace solid::render {

// A square area light whose emitting side faces `direction`.
struct AreaLight {
  Vec3 position;   // centre, world metres
  Vec3 direction;  // unit, from the light towards the target object's centre
  double size_m = 0;
  double power_w = 0;  // Blender watts
};

// The lights of one image (solid-method.md 2.6 with D8's fixes).
struct LightRig {
  size_t target = 0;  // index into Layout::objects
  AreaLight key, fill, back;
  double ceiling_strength = 0;  // emission strength, times the ceiling's colour
  nlohmann::json ToJson() const;
};

// Draws the lights of `layout` on its lights stream. Positions: lattice columns over
// the floor at horizontal radius [0.8 R, R], R the camera's horizontal distance from
// the origin. Key: any such column, z ~ U(2, 5) m, U(150, 300) W, size U(0.01, 0.25).
// Fill: within +-60 deg of the key's azimuth, z ~ U(0.1, 1), U(10, 30) W, 0.25 m.
// Back: within 180 +- 30 deg of the camera's azimuth, z ~ U(6, 10), U(20, 60) W, 0.25 m.
// Heights are clamped to the column's [floor + 0.05, ceiling - 0.05] (its ceiling when
// that is empty); a position inside a placed box is redrawn. kInvalidArgument for a
// layout without objects; kLimitExceeded when a light finds no position in 1000
// draws (the caller restarts the scene, as the reference does).
Result<LightRig> SampleLights(const Layout& layout);

// Decoded base-colour textures (8-bit sRGB RGB), decoded once per asset and kept
// while the asset lives, up to a memory cap. Share one per process. Thread-safe.
struct DecodedTextures;
class TextureCache {
 public:
  explicit TextureCache(uint64_t cap_bytes = uint64_t{1} << 30);
  ~TextureCache();
  TextureCache(const TextureCache&) = delete;
  TextureCache& operator=(const TextureCache&) = delete;

  // The decoded `textures` of `owner` (the asset or room that holds them); `where`
  // names the owner in errors (kParseError or kLimitExceeded from a bad image).
  Result<std::shared_ptr<const DecodedTextures>> Get(const std::vector<gltf::Texture>& textures,
                                                     const std::shared_ptr<const void>& owner,
                                                     std::string_view where);
  uint64_t bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// How a pixel's samples are spent.
enum class Sampling {
  // Every pixel traces samples_per_pixel camera rays (stratified jitter, a box filter),
  // each lit by its own shadow ray per light and ambient ray; also the query views'
  // sampling and the reference of bench/render_quality_bench.
  kUniform,
  // Driven by the layout's mask pass: pixels next to (left, right, above, below) an object
  // boundary or a depth step of more than 2% (edges and occlusion boundaries) are sampled
  // as kUniform; every other pixel takes the hit of its centre ray (found by the mask
  // pass, or traced when the mask pass has none), filters its texture over the pixel's
  // footprint (ray differentials, 2x2 taps) and lights that hit with
  // samples_per_pixel / 4 samples (at least one); then its lighting (radiance over
  // base colour) is averaged over the flat pixels within three rows and columns on the
  // same surface (same instance, depth and normal), which keeps each pixel's texture. On
  // 640x480 layouts of more-objects, against kUniform at 4 spp: at 4 spp 1.6 dB higher
  // PSNR in half its shading time (README, bench/render_quality_bench.cpp). The default
  // of RenderOptions.
  kAdaptive,
};

struct ShadeOptions {
  int samples_per_pixel = 4;  // 1..1024; factored into the most square n x m strata
  int threads = 1;            // rows are shared out over this many threads
  Sampling sampling = Sampling::kUniform;
};

struct ShadeResult {
  Image8 image;  // layout.width x layout.height, 3 channels, sRGB
  uint64_t rays = 0;  // traced: camera, shadow and ambient
  double ms = 0;  // wall time: scene build, textures and tracing
};

// Shades `layout` lit by `lights`; `masks` is the layout's mask pass (RunMaskPass), which
// Sampling::kAdaptive needs and kUniform ignores. kInvalidArgument for bad options, a
// layout without a room, a light target out of range, or adaptive sampling without a
// mask pass of the layout's size; texture errors name the asset.
Result<ShadeResult> Shade(const Layout& layout, const LightRig& lights, const ShadeOptions& options,
                          TextureCache& textures, const MaskPassResult* masks = nullptr);

}  // namespace solid::render
