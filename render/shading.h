// The shading core shared by Shade (shade.h) and the query views (query_views.h):
// one stratified ray-traced image of a top-level scene of instances (internal to
// solid::render). The lighting model is documented in shade.h.
#pragma once

#include <embree3/rtcore.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "solid/formats/asset.h"
#include "solid/formats/image_codec.h"
#include "solid/render/assets.h"
#include "solid/render/layout.h"
#include "solid/render/mask_pass.h"

namespace solid::render {

struct Vec3f {
  float x = 0, y = 0, z = 0;
  friend Vec3f operator+(Vec3f a, Vec3f b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
  friend Vec3f operator-(Vec3f a, Vec3f b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
  friend Vec3f operator*(Vec3f a, float s) { return {a.x * s, a.y * s, a.z * s}; }
  friend Vec3f operator*(Vec3f a, Vec3f b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
};
inline float Dot(Vec3f a, Vec3f b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3f Cross(Vec3f a, Vec3f b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline Vec3f ToFloat(Vec3 v) { return {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)}; }

// Textures of one asset, 8-bit sRGB RGB, with their mean linear colour.
struct DecodedTextures {
  struct Texture {
    int width = 0, height = 0;
    std::vector<uint8_t> rgb;
    Vec3f mean_linear;
  };
  std::vector<Texture> textures;
  uint64_t bytes = 0;
};
Result<DecodedTextures> DecodeTextures(const std::vector<gltf::Texture>& textures, std::string_view where);

// sRGB transfer functions.
float SrgbToLinear(uint8_t v);
uint8_t LinearToSrgb8(float v);
// Scene-linear radiance to display-linear [0, 1] (a filmic curve).
float ToneMap(float v);

// The linear base colour of `material` (nullptr: glTF's default, white) at `uv`.
Vec3f BaseColor(const gltf::Material* material, const DecodedTextures* textures, float u, float v);
// The mean linear base colour of `material` over its texture.
Vec3f MeanBaseColor(const gltf::Material* material, const DecodedTextures* textures);

// What the shader needs of one instance of the top-level scene.
struct ShadingSurface {
  const MeshGeometry* mesh = nullptr;
  const std::vector<gltf::Material>* materials = nullptr;
  const DecodedTextures* textures = nullptr;  // may be null: no textures
  Mat3 rotation;  // world from object, without the (uniform) scale
  double scale = 1;
  Vec3 translation;
};

struct ShadingLight {
  bool area = true;  // false: a point light
  Vec3f position;
  Vec3f u_axis, v_axis;  // area: the square's half-side vectors
  Vec3f normal;          // area: the emitting side
  float power_w = 0;
  // A point light at the camera's eye lights every point the camera sees: the segment to
  // it is the camera ray's own. Its shadow rays are not traced.
  bool at_eye = false;
};

struct ShadingScene {
  RTCScene scene = nullptr;              // instance id k shades as surfaces[k]
  std::vector<ShadingSurface> surfaces;  // by instance id
  std::vector<ShadingLight> lights;
  Vec3f ambient;  // uniform ambient radiance
  Vec3f sky;      // radiance from above, weighted by (1 + n_z) / 2
  float ambient_occlusion_m = 0.75f;  // range of the ambient obscurance rays
  Vec3f background;  // radiance of rays that leave the scene
};

// The shader's inner loops for one instruction set (film_kernels.h), and the widest set this
// CPU runs. Every set gives the same bits.
struct FilmKernels;
const FilmKernels& BestFilmKernels();

// A linear image with, per pixel, whether any sample hit a surface.
struct Film {
  int width = 0, height = 0;
  std::vector<float> rgb;  // linear radiance, 3 per pixel, row-major
  std::vector<uint8_t> covered;
  uint64_t rays = 0;  // traced: camera, shadow and ambient
};

// How a film spends its rays. A sample of a pixel is a camera ray's hit lit by one
// shadow ray per light (stratified over the area lights) and one ambient ray. Uniform
// (edges empty): every pixel takes spp samples, each with its own camera ray (stratified
// jitter, a box filter). Adaptive: an edge pixel is sampled as in uniform; a flat pixel
// takes the hit of one camera ray through its centre (from centre_hits, or traced), its
// base colour as the mean of 2x2 texture taps over the pixel's footprint (one tap at the
// centre when the footprint is under half a texel across), and lights that hit with
// FlatSamples(spp) samples. Its lighting (radiance over base colour) is then averaged over
// the flat pixels around it on the same surface (FilterFlatLighting): a flat pixel's noise
// is that of its shadows and ambient obscurance, which vary slowly over a surface, while
// its texture, which does not, keeps every pixel's own base colour. A light marked at_eye
// adds no shadow rays.
struct FilmSampling {
  int spp = 4;
  // 1 for an edge pixel, 0 for a flat one, row-major; empty: every pixel is an edge.
  std::vector<uint8_t> edges;
  // The mask pass's hits of the pixel centres (through the same camera, width and
  // height), which flat pixels then light instead of tracing their camera rays again; null:
  // flat pixels trace them.
  const std::vector<MaskPassResult::CentreHit>* centre_hits = nullptr;
};

// The samples of a flat pixel under adaptive sampling: spp / 4, at least one. The filter
// averages each over up to 49 pixels, so one sample there is worth more than four
// unfiltered ones; the edges, which are not filtered, take all spp.
inline int FlatSamples(int spp) { return std::max(1, spp / 4); }

// What FilterFlatLighting needs of each pixel, row-major.
inline constexpr uint32_t kNoSurface = UINT32_MAX;
struct FlatGuides {
  std::vector<uint32_t> surface;  // the instance a flat pixel's camera ray hit; kNoSurface: edge, background
  std::vector<float> depth;       // that hit's distance along its ray
  std::vector<Vec3f> normal;      // its shading normal
  std::vector<Vec3f> albedo;      // its base colour (linear)
};

// The half-width of FilterFlatLighting's box: 7 x 7 pixels. On 8 more-objects layouts at
// 640x480 and 4 spp (bench/render_quality_bench), radius 2 gave 36.04 dB, 3 36.17 dB, 4
// 35.99 dB and 5 35.73 dB, all in the same time: beyond 3 the mean blurs more shading
// than it removes noise.
inline constexpr int kFlatFilterRadius = 3;

// Replaces each flat pixel's lighting (radiance over base colour, per channel) by the mean
// lighting of the pixels within kFlatFilterRadius rows and columns (separably: along its
// row, then its column) that lie on its surface: the same instance, a depth within 2% per
// pixel of distance, shading normals within 25 degrees. Pixels without a surface or with a base
// colour channel below 1e-3 are left as they are and not used. Each pass's rows are
// shared by `threads`; the result does not depend on their number. Its scratch buffers
// are the calling thread's, kept for its next film.
void FilterFlatLighting(const FlatGuides& guides, int threads, Film* film,
                        const FilmKernels& kernels = BestFilmKernels());

// A relative depth step between neighbouring pixel centres that makes both edge pixels
// (EdgePixels), and the most FilterFlatLighting averages over per pixel of distance.
inline constexpr float kDepthStep = 0.02f;

// FilmSampling::edges from a mask pass: 1 where the pixel to a pixel's left, right, top or
// bottom holds another visible id (object or room) or a depth more than 2% nearer or
// farther (occlusion boundaries within one object or the room), where the pixel's area
// may span two surfaces.
std::vector<uint8_t> EdgePixels(const MaskPassResult& masks);

// Traces width x height pixels of `camera` as `sampling` says, pixel p seeded with
// MixSeed(seed, p) on the shading stream, rows shared by `threads`.
Film RenderFilm(const ShadingScene& scene, const Camera& camera, int width, int height, double near,
                const FilmSampling& sampling, int threads, uint64_t seed,
                const FilmKernels& kernels = BestFilmKernels());

// sRGB 8-bit RGB of a linear film, tone mapped by ToneMap.
Image8 EncodeFilm(const Film& film, const FilmKernels& kernels = BestFilmKernels());

}  // namespace solid::render
