// The shader's inner loops (internal to solid::render), compiled once per instruction set
// (render/CMakeLists.txt: on x86-64 for the baseline, x86-64-v3 with AVX2 and x86-64-v4
// with AVX-512) and chosen at run time by what the CPU supports. The lanes of lanes.h are
// then as wide as the CPU's vectors. Every set gives the same bits (lanes.h: exactly
// rounded operations only, none contracted), so the choice changes speed, never pixels.
//
// A set's code lives in the namespace of its instruction set, and every symbol it defines
// outside it would be one the linker may take for all (tests/render/film_kernels_symbols.sh
// holds that there are none): allocation and threads stay in shading.cpp, which is built
// for the baseline.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <string_view>
#include <vector>

#include "shading.h"
#include "solid/render/shade.h"

namespace solid::render {

// A surface's placement in the float arithmetic of the shader.
struct SurfaceFrame {
  float rotation[9];  // row-major, world from object without the scale
  float scale;
  float translation[3];
};

// What the shading workers share for one film.
struct FilmJob {
  const ShadingScene* scene = nullptr;
  const Camera* camera = nullptr;
  Vec3f eye;
  // RayDirection is affine in the image point: a flat pixel's centre direction and its
  // neighbours' (for its footprint) are sums of these instead of three double evaluations.
  Vec3f direction_at_origin, direction_per_x, direction_per_y;
  int width = 0, height = 0;
  double near = 0;
  int spp = 4;
  const uint8_t* edges = nullptr;  // null: uniform sampling
  const MaskPassResult::CentreHit* centre_hits = nullptr;
  uint64_t seed = 0;
  const SurfaceFrame* frames = nullptr;  // by instance id
  Film* film = nullptr;
  FlatGuides* guides = nullptr;  // written where edges is not null
  std::atomic<int>* next_tile_row = nullptr;
};

// FilterFlatLighting's planes (see there), one value per pixel.
struct FilterJob {
  const FlatGuides* guides = nullptr;
  Film* film = nullptr;
  int32_t* key = nullptr;
  std::array<float*, 3> normal{}, lighting{}, across{};
};

struct FilmKernels {
  std::string_view instruction_set;  // as GCC's -march names it; "generic" where only one is built
  // Shades the tile rows it takes from job.next_tile_row until none is left; the rays it traced.
  uint64_t (*shade_tiles)(const FilmJob& job);
  // FilterFlatLighting's three passes over row y.
  void (*filter_keys)(const FilterJob& job, int y);
  void (*filter_across)(const FilterJob& job, int y);
  void (*filter_down)(const FilterJob& job, int y);
  // EncodeFilm's bytes of n linear values.
  void (*encode)(const float* linear, size_t n, uint8_t* out);
  // The scalar functions of shading.h.
  float (*tone_map)(float v);
  Vec3f (*base_color)(const gltf::Material* material, const DecodedTextures* textures, float u, float v);
  Vec3f (*mean_base_color)(const gltf::Material* material, const DecodedTextures* textures);
};

// The kernel sets this CPU runs, the baseline first and the widest last.
std::vector<const FilmKernels*> RunnableFilmKernels();

// Shade (shade.h) with the given kernel set.
Result<ShadeResult> ShadeWith(const Layout& layout, const LightRig& lights, const ShadeOptions& options,
                              TextureCache& textures, const MaskPassResult* masks, const FilmKernels& kernels);

// Shared tables of the baseline (shading.cpp).
// SrgbToLinear of every byte.
const std::array<float, 256>& SrgbLinearTable();
// thresholds[k - 1]: the least display-linear value that LinearToSrgb8 maps to k or more
// (it is monotonic), so that encoding a film costs a short search per channel instead of
// a pow, with the same bytes.
const std::array<float, 255>& SrgbThresholds();
// Per bucket b of [0, 1] in kCodeBuckets, the count of thresholds at or below b /
// kCodeBuckets: where the search starts, a step or two short of its code.
inline constexpr int kCodeBuckets = 4096;
const std::array<uint8_t, kCodeBuckets + 1>& SrgbCodeBuckets();

}  // namespace solid::render
