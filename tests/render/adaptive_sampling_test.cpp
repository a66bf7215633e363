// Adaptive (mask-driven) sampling, issue 22: which pixels count as edges, that edges are
// sampled as uniform sampling samples them and flat pixels with fewer rays, that the
// filter of flat pixels' lighting averages only over their own surface and keeps their
// texture, that the image is the same for any thread count, and that its error against a
// high-spp reference is no worse than uniform sampling's at the same spp.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "formats/test_util.h"
#include "render/dataset_digest.h"
#include "render/test_assets.h"
#include "shading.h"
#include "solid/render/render_dataset.h"
#include "solid/render/sample.h"
#include "solid/render/shade.h"

namespace solid::render {
namespace {

MaskPassResult FlatMasks(int w, int h) {
  MaskPassResult m;
  m.width = w;
  m.height = h;
  m.ids.assign(static_cast<size_t>(w) * h, 0);
  m.depth.assign(static_cast<size_t>(w) * h, 1.0f);
  return m;
}

TEST(AdaptiveSampling, EdgesAreIdBoundariesAndDepthSteps) {
  MaskPassResult m = FlatMasks(12, 8);
  m.ids[3 * 12 + 3] = 1;  // one object pixel at (3, 3)
  for (int y = 0; y < 8; ++y) {
    m.depth[y * 12 + 8] = 1.05f;  // a 5% step between columns 7 and 8 ...
    m.depth[y * 12 + 9] = 1.06f;  // ... and a 1% one between 8 and 9
    m.depth[y * 12 + 10] = m.depth[y * 12 + 11] = std::numeric_limits<float>::infinity();
  }
  const std::vector<uint8_t> e = EdgePixels(m);
  auto edge = [&](int x, int y) { return e[static_cast<size_t>(y) * 12 + x] != 0; };
  // The pixel and its four neighbours; its diagonal neighbours only touch it at a corner.
  for (int y = 2; y <= 4; ++y) {
    for (int x = 2; x <= 4; ++x) EXPECT_EQ(edge(x, y), x == 3 || y == 3) << x << "," << y;
  }
  EXPECT_FALSE(edge(0, 0));
  EXPECT_FALSE(edge(5, 6));
  EXPECT_TRUE(edge(7, 0));
  EXPECT_TRUE(edge(8, 5));
  // Column 9 sees the 1% step (flat) and the sky beyond column 10 (edge); 11 sees only sky.
  EXPECT_TRUE(edge(9, 1));
  EXPECT_TRUE(edge(10, 1));
  EXPECT_FALSE(edge(11, 1));
}

// Any pixel whose left, right, upper or lower neighbour holds another id or a depth more
// than 2% away, by the definition, on random ids and depths (with sky) that make every
// case common.
TEST(AdaptiveSampling, EdgesMatchTheirDefinitionOnRandomMasks) {
  std::mt19937 rng(3);
  MaskPassResult m = FlatMasks(37, 23);
  for (size_t p = 0; p < m.ids.size(); ++p) {
    m.ids[p] = rng() % 7 == 0 ? 2 : 1;
    const uint32_t r = rng() % 10;
    m.depth[p] = r == 0 ? std::numeric_limits<float>::infinity() : 1.0f + 0.01f * static_cast<float>(r % 4);
  }
  const std::vector<uint8_t> e = EdgePixels(m);
  int edges = 0;
  for (int y = 0; y < 23; ++y) {
    for (int x = 0; x < 37; ++x) {
      const size_t p = static_cast<size_t>(y) * 37 + x;
      bool expected = false;
      for (int qy = std::max(0, y - 1); qy <= std::min(22, y + 1); ++qy) {
        for (int qx = std::max(0, x - 1); qx <= std::min(36, x + 1); ++qx) {
          if (qx != x && qy != y) continue;
          const size_t q = static_cast<size_t>(qy) * 37 + qx;
          const float d = m.depth[p], dq = m.depth[q];
          const bool same_depth = d == dq || std::fabs(d - dq) <= 0.02f * std::min(d, dq);
          expected = expected || m.ids[q] != m.ids[p] || !same_depth;
        }
      }
      EXPECT_EQ(e[p] != 0, expected) << x << "," << y;
      edges += expected;
    }
  }
  // Both kinds of pixel occur.
  EXPECT_GT(edges, 37 * 23 / 4);
  EXPECT_LT(edges, 37 * 23);
}

struct Fixture {
  testing::SmallLayout drawn = testing::DrawSmallLayout("more-objects", 5);
  const GeneratedLayout& g = drawn.g;
  ShadeResult Shade(Sampling sampling, int spp, int threads, const MaskPassResult* masks, TextureCache& textures) const {
    ShadeOptions o;
    o.samples_per_pixel = spp;
    o.threads = threads;
    o.sampling = sampling;
    return render::Shade(g.layout, g.lights, o, textures, masks).value();
  }
};

TEST(AdaptiveSampling, EdgePixelsAsUniformFlatOnesWithFewerRays) {
  const Fixture f;
  TextureCache textures;
  const ShadeResult uniform = f.Shade(Sampling::kUniform, 4, 1, nullptr, textures);
  // Every pixel an edge (a checkerboard of ids): exactly the uniform image.
  MaskPassResult all_edges = FlatMasks(96, 72);
  for (int y = 0; y < 72; ++y) {
    for (int x = 0; x < 96; ++x) all_edges.ids[y * 96 + x] = (x + y) % 2;
  }
  const ShadeResult edges = f.Shade(Sampling::kAdaptive, 4, 1, &all_edges, textures);
  EXPECT_EQ(edges.image.pixels, uniform.image.pixels);
  EXPECT_EQ(edges.rays, uniform.rays);
  // Every pixel flat: one camera ray and one light sample each, instead of four of each.
  const MaskPassResult all_flat = FlatMasks(96, 72);
  const ShadeResult flat = f.Shade(Sampling::kAdaptive, 4, 1, &all_flat, textures);
  EXPECT_LT(flat.rays, uniform.rays / 2);
  // The layout's own mask pass: in between.
  const ShadeResult adaptive = f.Shade(Sampling::kAdaptive, 4, 1, &f.g.masks, textures);
  EXPECT_GT(adaptive.rays, flat.rays);
  EXPECT_LT(adaptive.rays, uniform.rays);
}

// Flat pixels light the hit the mask pass found for their centre ray instead of tracing it
// again: one camera ray fewer per flat pixel, and the same image but for float rounding
// (the mask pass normalises its rays in double precision).
TEST(AdaptiveSampling, FlatPixelsLightTheMaskPassHitsInsteadOfTracingThem) {
  const Fixture f;
  TextureCache textures;
  ASSERT_EQ(f.g.masks.centre_hits.size(), size_t{96} * 72);
  MaskPassResult traced = f.g.masks;
  traced.centre_hits.clear();
  const ShadeResult from_masks = f.Shade(Sampling::kAdaptive, 4, 1, &f.g.masks, textures);
  const ShadeResult from_rays = f.Shade(Sampling::kAdaptive, 4, 1, &traced, textures);
  const std::vector<uint8_t> edges = EdgePixels(f.g.masks);
  const auto flat = static_cast<uint64_t>(std::count(edges.begin(), edges.end(), 0));
  EXPECT_GT(flat, edges.size() / 2);
  EXPECT_EQ(from_rays.rays - from_masks.rays, flat);
  ASSERT_EQ(from_masks.image.pixels.size(), from_rays.image.pixels.size());
  int most = 0;
  size_t differing = 0;
  for (size_t i = 0; i < from_rays.image.pixels.size(); ++i) {
    const int d = std::abs(from_masks.image.pixels[i] - from_rays.image.pixels[i]);
    most = std::max(most, d);
    differing += d != 0;
  }
  EXPECT_LE(most, 2);
  EXPECT_LT(differing, from_rays.image.pixels.size() / 100);
  // Hits naming a triangle or surface the layout lacks (another layout's pass) are refused.
  for (const uint32_t surface : {0u, static_cast<uint32_t>(f.g.layout.objects.size() + 1)}) {
    MaskPassResult other = f.g.masks;
    other.centre_hits[100] = {surface, 1u << 30, 0.25f, 0.25f, 1.0f};
    ShadeOptions o;
    o.sampling = Sampling::kAdaptive;
    EXPECT_EQ(render::Shade(f.g.layout, f.g.lights, o, textures, &other).status().code(), StatusCode::kInvalidArgument);
  }
}

TEST(AdaptiveSampling, SameBytesForAnyThreadCount) {
  const Fixture f;
  TextureCache textures;
  const ShadeResult one = f.Shade(Sampling::kAdaptive, 4, 1, &f.g.masks, textures);
  for (int threads : {2, 3}) {
    const ShadeResult more = f.Shade(Sampling::kAdaptive, 4, threads, &f.g.masks, textures);
    EXPECT_EQ(more.image.pixels, one.image.pixels) << threads << " threads";
    EXPECT_EQ(more.rays, one.rays);
  }
}

TEST(AdaptiveSampling, NeedsTheMaskPassOfTheLayout) {
  const Fixture f;
  TextureCache textures;
  ShadeOptions o;
  o.sampling = Sampling::kAdaptive;
  EXPECT_EQ(Shade(f.g.layout, f.g.lights, o, textures).status().code(), StatusCode::kInvalidArgument);
  const MaskPassResult other_size = FlatMasks(64, 48);
  EXPECT_EQ(Shade(f.g.layout, f.g.lights, o, textures, &other_size).status().code(), StatusCode::kInvalidArgument);
}

TEST(AdaptiveSampling, SameDatasetForAnyShardSizeAndThreadCount) {
  solid::testing::TempDir dir;
  LayoutParams params = LoadPreset("more-objects").value();
  params.width = 96;
  params.height = 72;
  const auto sampler = LayoutSampler::Create(params, testing::ProceduralLibrary()).value();
  auto options = [&](const char* name, int64_t shard_size, int jobs) {
    RenderOptions o;
    o.out = dir.path() / name;
    o.seed = 3;
    o.images = 6;
    o.shard_size = shard_size;
    o.jobs = jobs;
    o.queries = false;
    o.shading.samples_per_pixel = 2;
    o.shading.sampling = Sampling::kAdaptive;
    return o;
  };
  ASSERT_OK(RenderDataset(*sampler, options("a", 6, 1)).status());
  ASSERT_OK(RenderDataset(*sampler, options("b", 4, 2)).status());
  const auto a = testing::DigestDataset(dir.path() / "a").value();
  EXPECT_EQ(a.images.size(), 6u);
  EXPECT_EQ(a, testing::DigestDataset(dir.path() / "b").value());
}

// A w x h film whose every pixel is flat on one surface (instance 0, 2 m away, facing
// the camera), with a checkerboard texture of base colours 0.2 and 0.8 and lighting
// `lighting(x, y)`: radiance is lighting times base colour.
struct GuidedFilm {
  Film film;
  FlatGuides guides;
  Vec3f Lighting(int x, int y) const {
    const size_t p = static_cast<size_t>(y) * film.width + x;
    const Vec3f a = guides.albedo[p];
    return {film.rgb[3 * p] / a.x, film.rgb[3 * p + 1] / a.y, film.rgb[3 * p + 2] / a.z};
  }
};

template <typename Lighting>
GuidedFilm OneSurface(int w, int h, Lighting lighting) {
  GuidedFilm f;
  const size_t pixels = static_cast<size_t>(w) * h;
  f.film.width = w;
  f.film.height = h;
  f.film.rgb.resize(3 * pixels);
  f.film.covered.assign(pixels, 1);
  f.guides.surface.assign(pixels, 0);
  f.guides.depth.assign(pixels, 2.0f);
  f.guides.normal.assign(pixels, Vec3f{0, 0, 1});
  f.guides.albedo.resize(pixels);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = static_cast<size_t>(y) * w + x;
      const float a = (x + y) % 2 ? 0.8f : 0.2f;
      f.guides.albedo[p] = {a, a, a};
      const Vec3f l = lighting(x, y);
      f.film.rgb[3 * p] = l.x * a;
      f.film.rgb[3 * p + 1] = l.y * a;
      f.film.rgb[3 * p + 2] = l.z * a;
    }
  }
  return f;
}

TEST(FlatLightingFilter, AveragesLightingOverTheBoxAndKeepsTheTexture) {
  std::mt19937 gen(7);
  std::uniform_real_distribution<float> noise(0.5f, 1.5f);
  std::vector<Vec3f> lighting(40 * 30);
  for (Vec3f& l : lighting) l = {noise(gen), noise(gen), noise(gen)};
  GuidedFilm f = OneSurface(40, 30, [&](int x, int y) { return lighting[y * 40 + x]; });
  const GuidedFilm before = f;
  FilterFlatLighting(f.guides, 1, &f.film);
  double variance_before = 0, variance_after = 0;
  int n = 0;
  constexpr int r = kFlatFilterRadius;
  constexpr float box = (2 * r + 1) * (2 * r + 1);
  for (int y = r; y < 30 - r; ++y) {
    for (int x = r; x < 40 - r; ++x) {
      Vec3f mean;
      for (int dy = -r; dy <= r; ++dy) {
        for (int dx = -r; dx <= r; ++dx) mean = mean + before.Lighting(x + dx, y + dy) * (1.0f / box);
      }
      // Radiance over the pixel's own base colour: the texture is kept, the lighting averaged.
      EXPECT_NEAR(f.Lighting(x, y).x, mean.x, 1e-5f) << x << "," << y;
      EXPECT_NEAR(f.Lighting(x, y).z, mean.z, 1e-5f) << x << "," << y;
      variance_before += (before.Lighting(x, y).y - 1) * (before.Lighting(x, y).y - 1);
      variance_after += (f.Lighting(x, y).y - 1) * (f.Lighting(x, y).y - 1);
      ++n;
    }
  }
  // Independent noise over the box: its share of the variance, give or take the sample's spread.
  EXPECT_LT(variance_after, variance_before / (0.6 * box)) << variance_before / n << " " << variance_after / n;
  // At the image's border the box is cut: the corner averages its (r + 1) x (r + 1).
  Vec3f corner;
  for (int y = 0; y <= r; ++y) {
    for (int x = 0; x <= r; ++x) corner = corner + before.Lighting(x, y) * (1.0f / ((r + 1) * (r + 1)));
  }
  EXPECT_NEAR(f.Lighting(0, 0).x, corner.x, 1e-5f);
}

TEST(FlatLightingFilter, StaysOnItsSurface) {
  // Left half: instance 0 lit 1. Right half: instance 1 lit 3. Rows 0-9 are 10% nearer
  // than rows 10-19 (a depth step), and rows 20-29 face another way (a crease).
  GuidedFilm f = OneSurface(40, 30, [](int x, int y) {
    const float l = (x < 20 ? 1.0f : 3.0f) * (y < 10 ? 2.0f : y < 20 ? 1.0f : 0.5f);
    return Vec3f{l, l, l};
  });
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 40; ++x) {
      const size_t p = static_cast<size_t>(y) * 40 + x;
      f.guides.surface[p] = x < 20 ? 0 : 1;
      if (y < 10) f.guides.depth[p] = 1.8f;
      if (y >= 20) f.guides.normal[p] = Vec3f{0.5f, 0, 0.866f};  // 30 degrees
    }
  }
  const GuidedFilm before = f;
  FilterFlatLighting(f.guides, 2, &f.film);
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 40; ++x) {
      EXPECT_NEAR(f.Lighting(x, y).y, before.Lighting(x, y).y, 1e-5f) << x << "," << y;
    }
  }
}

TEST(FlatLightingFilter, LeavesEdgesBackgroundAndDarkTexelsAloneAndOutOfTheMean) {
  GuidedFilm f = OneSurface(20, 20, [](int, int) { return Vec3f{1, 1, 1}; });
  const size_t edge = 5 * 20 + 5, dark = 12 * 20 + 12;
  f.guides.surface[edge] = kNoSurface;
  f.film.rgb[3 * edge] = 100;  // an edge pixel's radiance, which a mean must not take
  f.guides.albedo[dark] = {0.5f, 0.0f, 0.5f};
  f.film.rgb[3 * dark] = 50;
  const GuidedFilm before = f;
  FilterFlatLighting(f.guides, 1, &f.film);
  for (size_t c = 0; c < 3; ++c) {
    EXPECT_EQ(f.film.rgb[3 * edge + c], before.film.rgb[3 * edge + c]);
    EXPECT_EQ(f.film.rgb[3 * dark + c], before.film.rgb[3 * dark + c]);
  }
  for (int y = 0; y < 20; ++y) {
    for (int x = 0; x < 20; ++x) {
      const size_t p = static_cast<size_t>(y) * 20 + x;
      if (p == edge || p == dark) continue;
      EXPECT_NEAR(f.Lighting(x, y).x, 1.0f, 1e-5f) << x << "," << y;
    }
  }
}

TEST(FlatLightingFilter, SameBytesForAnyThreadCount) {
  std::mt19937 gen(3);
  std::uniform_real_distribution<float> noise(0.0f, 2.0f);
  GuidedFilm one = OneSurface(37, 23, [&](int, int) { return Vec3f{noise(gen), noise(gen), noise(gen)}; });
  GuidedFilm three = one;
  FilterFlatLighting(one.guides, 1, &one.film);
  FilterFlatLighting(three.guides, 3, &three.film);
  EXPECT_EQ(one.film.rgb, three.film.rgb);
}

// The filter as its definition reads (FilterFlatLighting in shading.h), one pixel at a
// time, in the order of its sums: the filter's vectors of pixels must give these bits.
Film FilteredByDefinition(const FlatGuides& g, Film film) {
  const int w = film.width, h = film.height;
  const size_t pixels = static_cast<size_t>(w) * h;
  std::vector<uint8_t> usable(pixels);
  std::vector<Vec3f> lighting(pixels), across(pixels);
  for (size_t p = 0; p < pixels; ++p) {
    const Vec3f a = g.albedo[p];
    usable[p] = g.surface[p] != kNoSurface && a.x > 1e-3f && a.y > 1e-3f && a.z > 1e-3f;
    if (usable[p]) lighting[p] = {film.rgb[3 * p] / a.x, film.rgb[3 * p + 1] / a.y, film.rgb[3 * p + 2] / a.z};
  }
  auto mean = [&](const std::vector<Vec3f>& in, size_t p, int k, int length, ptrdiff_t step) {
    Vec3f sum;
    int n = 0;
    for (int d = -kFlatFilterRadius; d <= kFlatFilterRadius; ++d) {
      if (k + d < 0 || k + d >= length) continue;
      const auto q = static_cast<size_t>(static_cast<ptrdiff_t>(p) + d * step);
      const bool same = d == 0 || (usable[q] && g.surface[q] == g.surface[p] &&
                                   std::fabs(g.depth[q] - g.depth[p]) <=
                                       0.02f * static_cast<float>(std::abs(d)) * g.depth[p] &&
                                   Dot(g.normal[q], g.normal[p]) >= 0.906f);
      if (!same) continue;
      sum = sum + in[q];
      ++n;
    }
    return sum * (1.0f / static_cast<float>(n));
  };
  for (size_t p = 0; p < pixels; ++p) {
    if (usable[p]) across[p] = mean(lighting, p, static_cast<int>(p % w), w, 1);
  }
  for (size_t p = 0; p < pixels; ++p) {
    if (!usable[p]) continue;
    const Vec3f radiance = mean(across, p, static_cast<int>(p / w), h, w) * g.albedo[p];
    film.rgb[3 * p] = radiance.x, film.rgb[3 * p + 1] = radiance.y, film.rgb[3 * p + 2] = radiance.z;
  }
  return film;
}

// Random surfaces, depths within and beyond the 2% step, normals within and beyond 25
// degrees, dark texels and edges, on widths that leave rows partly to the scalar path.
TEST(FlatLightingFilter, SameBitsAsItsDefinitionOnRandomSurfaces) {
  std::mt19937 gen(11);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (const int w : {37, 64, 5}) {
    const int h = 29;
    GuidedFilm f = OneSurface(w, h, [&](int, int) { return Vec3f{2 * unit(gen), 2 * unit(gen), 2 * unit(gen)}; });
    for (size_t p = 0; p < f.guides.surface.size(); ++p) {
      const float r = unit(gen);
      f.guides.surface[p] = r < 0.1f ? kNoSurface : r < 0.5f ? 1 : 2;
      f.guides.depth[p] = 2.0f * (1 + 0.03f * unit(gen));
      f.guides.normal[p] = unit(gen) < 0.2f ? Vec3f{0.5f, 0, 0.866f} : Vec3f{0, 0.1f * unit(gen), 0.995f};
      if (unit(gen) < 0.05f) f.guides.albedo[p].y = 0;
    }
    const Film expected = FilteredByDefinition(f.guides, f.film);
    FilterFlatLighting(f.guides, 2, &f.film);
    EXPECT_EQ(f.film.rgb, expected.rgb) << w << "x" << h;
  }
}

double Psnr(const Image8& a, const Image8& b) {
  double sum = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    const double d = static_cast<double>(a.pixels[i]) - b.pixels[i];
    sum += d * d;
  }
  return 10 * std::log10(255.0 * 255.0 * static_cast<double>(a.pixels.size()) / sum);
}

TEST(AdaptiveSampling, ErrorAgainstAHighSppReferenceStaysNearUniform) {
  const Fixture f;
  TextureCache textures;
  const Image8 reference = f.Shade(Sampling::kUniform, 64, 2, nullptr, textures).image;
  const double uniform = Psnr(f.Shade(Sampling::kUniform, 4, 2, nullptr, textures).image, reference);
  const double adaptive = Psnr(f.Shade(Sampling::kAdaptive, 4, 2, &f.g.masks, textures).image, reference);
  RecordProperty("uniform_psnr_db", std::to_string(uniform));
  RecordProperty("adaptive_psnr_db", std::to_string(adaptive));
  // When written: uniform 32.68 dB, adaptive 32.88 dB (a 96x72 image is mostly edges and
  // texture detail, where adaptive sampling samples as uniform does; at 640x480 the margin
  // is 1.5 dB: bench/render_quality_bench). The floor: adaptive at least uniform.
  EXPECT_GT(uniform, 31.0);
  EXPECT_GT(adaptive, uniform) << "uniform " << uniform << " dB";
}

}  // namespace
}  // namespace solid::render
