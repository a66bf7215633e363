#include "shading.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>

#include <fmt/format.h>

#include "film_kernels.h"
#include "lanes.h"
#include "solid/formats/workers.h"

namespace solid::render {

// The kernel sets built (render/CMakeLists.txt), in film_kernels.cpp under these names.
#if SOLID_FILM_X86_LEVELS
namespace x86_64 {
extern const FilmKernels kFilmKernels;
}
namespace x86_64_v3 {
extern const FilmKernels kFilmKernels;
}
namespace x86_64_v4 {
extern const FilmKernels kFilmKernels;
}
namespace baseline = x86_64;
#else
namespace generic {
extern const FilmKernels kFilmKernels;
}
namespace baseline = generic;
#endif

std::vector<const FilmKernels*> RunnableFilmKernels() {
  std::vector<const FilmKernels*> runnable{&baseline::kFilmKernels};
#if SOLID_FILM_X86_LEVELS
  // GCC's levels check the instructions and that the OS saves the wider registers.
  __builtin_cpu_init();
  if (__builtin_cpu_supports("x86-64-v3")) runnable.push_back(&x86_64_v3::kFilmKernels);
  if (__builtin_cpu_supports("x86-64-v4")) runnable.push_back(&x86_64_v4::kFilmKernels);
#endif
  return runnable;
}

const FilmKernels& BestFilmKernels() {
  static const FilmKernels& best = *RunnableFilmKernels().back();
  return best;
}

namespace {

// Buffers a thread reuses from film to film. Allocated afresh for each image, 14 MB of
// them at 640x480 cost 4,000 page faults per image: 2.2 s of system time in a 64-image
// render at --jobs 2, and the other worker's mask pass took half as long again.
struct FilterScratch {
  FlatGuides guides;
  // FilterFlatLighting's planes, one value per pixel, so that its loops load kWidth
  // neighbouring pixels at once: a pixel's surface where it is usable (else -1), its
  // normal, its lighting, and the lighting's mean along its row.
  std::vector<int32_t> key;
  std::array<std::vector<float>, 3> normal, lighting, across;
};

FilterScratch& ThreadScratch() {
  thread_local FilterScratch scratch;
  return scratch;
}

}  // namespace

const std::array<float, 256>& SrgbLinearTable() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
      const double c = i / 255.0;
      t[i] = static_cast<float>(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
    }
    return t;
  }();
  return table;
}

float SrgbToLinear(uint8_t v) { return SrgbLinearTable()[v]; }

float ToneMap(float v) { return baseline::kFilmKernels.tone_map(v); }

uint8_t LinearToSrgb8(float v) {
  if (!(v > 0)) return 0;
  if (v >= 1) return 255;
  const float c = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
  return static_cast<uint8_t>(std::lround(c * 255.0f));
}

Vec3f BaseColor(const gltf::Material* material, const DecodedTextures* textures, float u, float v) {
  return baseline::kFilmKernels.base_color(material, textures, u, v);
}

Vec3f MeanBaseColor(const gltf::Material* material, const DecodedTextures* textures) {
  return baseline::kFilmKernels.mean_base_color(material, textures);
}

Result<DecodedTextures> DecodeTextures(const std::vector<gltf::Texture>& textures, std::string_view where) {
  DecodedTextures out;
  for (size_t t = 0; t < textures.size(); ++t) {
    const gltf::Texture& in = textures[t];
    ImageFormat format;
    if (in.mime_type == "image/png") {
      format = ImageFormat::kPng;
    } else if (in.mime_type == "image/jpeg") {
      format = ImageFormat::kJpeg;
    } else {
      return ParseError(fmt::format("{}: texture {} ({}): unsupported type '{}'", where, t, in.name, in.mime_type));
    }
    Result<Image8> decoded = DecodeImage(in.bytes, format, kTextureLimits);
    if (!decoded.ok()) return decoded.status().WithContext(fmt::format("{}: texture {} ({})", where, t, in.name));
    const Image8& img = *decoded;
    if (img.channels < 1 || img.channels > 4 || img.width == 0 || img.height == 0) {
      return ParseError(fmt::format("{}: texture {} ({}): {} channels, {}x{}", where, t, in.name, img.channels,
                                    img.width, img.height));
    }
    DecodedTextures::Texture tex;
    tex.width = static_cast<int>(img.width);
    tex.height = static_cast<int>(img.height);
    const size_t texels = static_cast<size_t>(img.width) * img.height;
    tex.rgb.resize(3 * texels);
    double sum[3] = {0, 0, 0};
    for (size_t i = 0; i < texels; ++i) {
      const uint8_t* p = &img.pixels[i * img.channels];
      // Grey (+ alpha) images replicate their one colour channel; alpha is dropped.
      const bool grey = img.channels < 3;
      for (int c = 0; c < 3; ++c) {
        const uint8_t v = grey ? p[0] : p[c];
        tex.rgb[3 * i + c] = v;
        sum[c] += SrgbToLinear(v);
      }
    }
    tex.mean_linear = {static_cast<float>(sum[0] / texels), static_cast<float>(sum[1] / texels),
                       static_cast<float>(sum[2] / texels)};
    out.bytes += tex.rgb.size();
    out.textures.push_back(std::move(tex));
  }
  return out;
}

std::vector<uint8_t> EdgePixels(const MaskPassResult& masks) {
  const int w = masks.width, h = masks.height;
  std::vector<uint8_t> edges(static_cast<size_t>(w) * h, 0);
  // Whether two pixels differ is symmetric, so each neighbouring pair is compared once (a
  // pixel with its right and lower neighbours) and marks both. Diagonal neighbours are not
  // compared: a boundary that only touches a pixel's corner covers little of its area. On
  // 8 more-objects layouts at 640x480 (bench/render_quality_bench) leaving them flat took
  // 0.15 rays per pixel fewer, shading 5% faster over three interleaved runs, and cost
  // 0.04 dB (36.13 against 36.17; SSIM 0.9787 against 0.9785).
  auto differ = [&](size_t p, size_t q) {
    const float d = masks.depth[p], e = masks.depth[q];
    // Infinite depths (rays that leave the scene) differ from any finite one: inf - inf is NaN.
    return masks.ids[q] != masks.ids[p] || (d != e && !(std::fabs(d - e) <= kDepthStep * std::min(d, e)));
  };
  auto mark = [&](size_t p, size_t q) {
    if (differ(p, q)) edges[p] = edges[q] = 1;
  };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = static_cast<size_t>(y) * w + x;
      if (x + 1 < w) mark(p, p + 1);
      if (y + 1 < h) mark(p, p + w);
    }
  }
  return edges;
}

void FilterFlatLighting(const FlatGuides& guides, int threads, Film* film, const FilmKernels& kernels) {
  const int height = film->height;
  const size_t pixels = film->rgb.size() / 3;
  FilterScratch& scratch = ThreadScratch();
  scratch.key.resize(pixels);
  for (int k = 0; k < 3; ++k) {
    scratch.normal[k].resize(pixels);
    scratch.lighting[k].resize(pixels);
    scratch.across[k].resize(pixels);
  }
  FilterJob job;
  job.guides = &guides;
  job.film = film;
  job.key = scratch.key.data();
  for (int k = 0; k < 3; ++k) {
    job.normal[k] = scratch.normal[k].data();
    job.lighting[k] = scratch.lighting[k].data();
    job.across[k] = scratch.across[k].data();
  }
  auto rows = [&](void (*row)(const FilterJob&, int)) {
    std::atomic<int> next{0};
    RunOnThreads(std::clamp(threads, 1, height), [&] {
      for (int y; (y = next.fetch_add(1, std::memory_order_relaxed)) < height;) row(job, y);
    });
  };
  rows(kernels.filter_keys);
  rows(kernels.filter_across);
  rows(kernels.filter_down);
}

Film RenderFilm(const ShadingScene& scene, const Camera& camera, int width, int height, double near,
                const FilmSampling& sampling, int threads, uint64_t seed, const FilmKernels& kernels) {
  const bool adaptive = !sampling.edges.empty();
  Film film;
  film.width = width;
  film.height = height;
  const size_t pixels = static_cast<size_t>(width) * height;
  film.rgb.assign(pixels * 3, 0.0f);
  film.covered.assign(pixels, 0);
  // A reference, not the thread_local itself, so that the worker threads write this thread's guides.
  FlatGuides& guides = ThreadScratch().guides;
  if (adaptive) {
    // Every pixel's surface is written below, and the rest only where it has one.
    guides.surface.resize(pixels);
    guides.depth.resize(pixels);
    guides.normal.resize(pixels);
    guides.albedo.resize(pixels);
  }
  std::vector<SurfaceFrame> frames;
  for (const ShadingSurface& s : scene.surfaces) {
    SurfaceFrame f{};
    for (int i = 0; i < 9; ++i) f.rotation[i] = static_cast<float>(s.rotation.m[i]);
    f.scale = static_cast<float>(s.scale);
    f.translation[0] = static_cast<float>(s.translation.x);
    f.translation[1] = static_cast<float>(s.translation.y);
    f.translation[2] = static_cast<float>(s.translation.z);
    frames.push_back(f);
  }
  std::atomic<int> next_tile_row{0};
  FilmJob job;
  job.scene = &scene;
  job.camera = &camera;
  job.eye = ToFloat(CameraPosition(camera));
  const Vec3 corner_direction = RayDirection(camera, 0, 0);
  job.direction_at_origin = ToFloat(corner_direction);
  job.direction_per_x = ToFloat(RayDirection(camera, 1, 0) - corner_direction);
  job.direction_per_y = ToFloat(RayDirection(camera, 0, 1) - corner_direction);
  job.width = width;
  job.height = height;
  job.near = near;
  job.spp = sampling.spp;
  job.edges = adaptive ? sampling.edges.data() : nullptr;
  job.centre_hits = adaptive && sampling.centre_hits != nullptr ? sampling.centre_hits->data() : nullptr;
  job.seed = seed;
  job.frames = frames.data();
  job.film = &film;
  job.guides = &guides;
  job.next_tile_row = &next_tile_row;
  std::atomic<uint64_t> total_rays{0};
  const int tile_rows = (height + kTile - 1) / kTile;
  RunOnThreads(std::clamp(threads, 1, std::max(1, tile_rows)), [&] { total_rays += kernels.shade_tiles(job); });
  film.rays = total_rays;
  if (adaptive) FilterFlatLighting(guides, threads, &film, kernels);
  return film;
}

const std::array<float, 255>& SrgbThresholds() {
  static const std::array<float, 255> table = [] {
    std::array<float, 255> t{};
    for (int k = 1; k < 256; ++k) {
      // Bisection over the bit patterns of the floats in [0, 1], which order as the values.
      uint32_t lo = 0, hi = std::bit_cast<uint32_t>(1.0f);
      while (lo < hi) {
        const uint32_t mid = lo + (hi - lo) / 2;
        if (LinearToSrgb8(std::bit_cast<float>(mid)) >= k) {
          hi = mid;
        } else {
          lo = mid + 1;
        }
      }
      t[k - 1] = std::bit_cast<float>(lo);
    }
    return t;
  }();
  return table;
}

// Per bucket b of [0, 1] in kCodeBuckets, the count of thresholds at or below b /
// kCodeBuckets: where EncodeFilm starts its search for a value in that bucket, a step or
// two short of its code instead of a binary search's eight.
const std::array<uint8_t, kCodeBuckets + 1>& SrgbCodeBuckets() {
  static const std::array<uint8_t, kCodeBuckets + 1> table = [] {
    const std::array<float, 255>& thresholds = SrgbThresholds();
    std::array<uint8_t, kCodeBuckets + 1> t{};
    for (int b = 0; b <= kCodeBuckets; ++b) {
      const float low = static_cast<float>(b) / kCodeBuckets;
      t[b] = static_cast<uint8_t>(std::upper_bound(thresholds.begin(), thresholds.end(), low) - thresholds.begin());
    }
    return t;
  }();
  return table;
}

Image8 EncodeFilm(const Film& film, const FilmKernels& kernels) {
  Image8 out;
  out.width = static_cast<uint32_t>(film.width);
  out.height = static_cast<uint32_t>(film.height);
  out.channels = 3;
  out.pixels.resize(film.rgb.size());
  kernels.encode(film.rgb.data(), film.rgb.size(), out.pixels.data());
  return out;
}

}  // namespace solid::render
