// COCO RLE throughput on 640x480 object masks, next to the cost of keeping the
// raw mask (one byte per pixel) as a baseline. Bytes are mask bytes (640*480
// per mask, 4 per pixel for id images); items are masks or id images.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "solid/formats/rle.h"

namespace {

namespace rle = solid::rle;

constexpr uint32_t kHeight = 480;
constexpr uint32_t kWidth = 640;
constexpr size_t kPixels = size_t{kHeight} * kWidth;
constexpr int kMaskCount = 48;

using Rng = std::mt19937_64;

double Uniform(Rng& rng, double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }

// Object radius in pixels, log-uniform so that small, medium and large COCO
// objects (from ~15 px to ~half the image) are all represented.
double RandomRadius(Rng& rng) { return std::exp(Uniform(rng, std::log(4.0), std::log(230.0))); }

template <typename Inside>
void Paint(std::vector<uint8_t>& mask, Inside inside) {
  for (uint32_t y = 0; y < kHeight; ++y) {
    for (uint32_t x = 0; x < kWidth; ++x) {
      if (inside(x + 0.5, y + 0.5)) mask[size_t{y} * kWidth + x] = 1;
    }
  }
}

void PaintEllipse(Rng& rng, std::vector<uint8_t>& mask, double cx, double cy, double radius) {
  const double rx = radius * Uniform(rng, 0.5, 1.5), ry = radius * Uniform(rng, 0.5, 1.5);
  const double angle = Uniform(rng, 0, std::numbers::pi);
  const double c = std::cos(angle), s = std::sin(angle);
  Paint(mask, [&](double x, double y) {
    const double u = ((x - cx) * c + (y - cy) * s) / rx, v = (-(x - cx) * s + (y - cy) * c) / ry;
    return u * u + v * v <= 1.0;
  });
}

// A star-shaped polygon with jittered radii: the outline of a segmented object.
void PaintPolygon(Rng& rng, std::vector<uint8_t>& mask, double cx, double cy, double radius) {
  const int vertices = static_cast<int>(Uniform(rng, 5, 24));
  std::vector<double> px, py;
  for (int i = 0; i < vertices; ++i) {
    const double angle = 2 * std::numbers::pi * i / vertices, r = radius * Uniform(rng, 0.4, 1.2);
    px.push_back(cx + r * std::cos(angle));
    py.push_back(cy + r * std::sin(angle));
  }
  Paint(mask, [&](double x, double y) {
    bool inside = false;
    for (int i = 0, j = vertices - 1; i < vertices; j = i++) {
      if ((py[i] > y) != (py[j] > y) && x < (px[j] - px[i]) * (y - py[i]) / (py[j] - py[i]) + px[i]) inside = !inside;
    }
    return inside;
  });
}

// A union of overlapping circles: irregular, sometimes non-convex objects.
void PaintBlob(Rng& rng, std::vector<uint8_t>& mask, double cx, double cy, double radius) {
  const int circles = static_cast<int>(Uniform(rng, 2, 7));
  for (int i = 0; i < circles; ++i) {
    const double x0 = cx + Uniform(rng, -radius, radius) * 0.6, y0 = cy + Uniform(rng, -radius, radius) * 0.6;
    const double r = radius * Uniform(rng, 0.3, 0.7);
    Paint(mask, [&](double x, double y) { return (x - x0) * (x - x0) + (y - y0) * (y - y0) <= r * r; });
  }
}

void PaintRandomObject(Rng& rng, std::vector<uint8_t>& mask, int kind) {
  const double radius = RandomRadius(rng);
  const double cx = Uniform(rng, 0, kWidth), cy = Uniform(rng, 0, kHeight);
  switch (kind % 3) {
    case 0: PaintEllipse(rng, mask, cx, cy, radius); break;
    case 1: PaintPolygon(rng, mask, cx, cy, radius); break;
    default: PaintBlob(rng, mask, cx, cy, radius); break;
  }
}

struct Corpus {
  std::vector<std::vector<uint8_t>> masks;
  std::vector<rle::Rle> rles;
  std::vector<std::string> strings;
  std::vector<uint32_t> id_image;  // ~15 objects occluding each other over background 0
};

const Corpus& GetCorpus() {
  static const Corpus corpus = [] {
    Corpus c;
    Rng rng(20240601);
    for (int i = 0; i < kMaskCount; ++i) {
      std::vector<uint8_t> mask(kPixels, 0);
      PaintRandomObject(rng, mask, i);
      c.rles.push_back(rle::EncodeRowMajor(mask, kHeight, kWidth));
      c.strings.push_back(rle::ToString(c.rles.back()));
      c.masks.push_back(std::move(mask));
    }
    c.id_image.assign(kPixels, 0);
    for (uint32_t id = 1; id <= 15; ++id) {
      std::vector<uint8_t> mask(kPixels, 0);
      PaintRandomObject(rng, mask, static_cast<int>(id));
      for (size_t i = 0; i < kPixels; ++i) {
        if (mask[i] != 0) c.id_image[i] = id;
      }
    }
    return c;
  }();
  return corpus;
}

void ReportMasks(benchmark::State& state, size_t bytes_per_item) {
  state.SetItemsProcessed(state.iterations());
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes_per_item));
}

void BM_Encode(benchmark::State& state) {
  const Corpus& corpus = GetCorpus();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(rle::EncodeRowMajor(corpus.masks[i], kHeight, kWidth));
    i = (i + 1) % corpus.masks.size();
  }
  ReportMasks(state, kPixels);
}
BENCHMARK(BM_Encode);

void BM_Decode(benchmark::State& state) {
  const Corpus& corpus = GetCorpus();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(rle::DecodeRowMajor(corpus.rles[i]));
    i = (i + 1) % corpus.rles.size();
  }
  ReportMasks(state, kPixels);
}
BENCHMARK(BM_Decode);

void BM_ToString(benchmark::State& state) {
  const Corpus& corpus = GetCorpus();
  size_t i = 0;
  size_t chars = 0;
  for (const std::string& s : corpus.strings) chars += s.size();
  for (auto _ : state) {
    benchmark::DoNotOptimize(rle::ToString(corpus.rles[i]));
    i = (i + 1) % corpus.rles.size();
  }
  ReportMasks(state, kPixels);
  state.counters["chars_per_mask"] = static_cast<double>(chars) / static_cast<double>(corpus.strings.size());
}
BENCHMARK(BM_ToString);

void BM_FromString(benchmark::State& state) {
  const Corpus& corpus = GetCorpus();
  size_t i = 0;
  for (auto _ : state) {
    auto parsed = rle::FromString(corpus.strings[i], kHeight, kWidth);
    if (!parsed.ok()) state.SkipWithError(parsed.status().ToString().c_str());
    benchmark::DoNotOptimize(parsed);
    i = (i + 1) % corpus.strings.size();
  }
  ReportMasks(state, kPixels);
}
BENCHMARK(BM_FromString);

// Baseline: keeping the raw mask, one byte per pixel. Storing and loading are
// each this one copy into a buffer of its own, to compare with Encode and Decode.
void BM_BaselineRawCopy(benchmark::State& state) {
  const Corpus& corpus = GetCorpus();
  size_t i = 0;
  for (auto _ : state) {
    std::vector<uint8_t> copy(kPixels);
    std::memcpy(copy.data(), corpus.masks[i].data(), kPixels);
    benchmark::DoNotOptimize(copy);
    i = (i + 1) % corpus.masks.size();
  }
  ReportMasks(state, kPixels);
}
BENCHMARK(BM_BaselineRawCopy);

void BM_EncodeIdImage(benchmark::State& state) {
  const Corpus& corpus = GetCorpus();
  for (auto _ : state) benchmark::DoNotOptimize(rle::EncodeIdImageRowMajor(corpus.id_image, kHeight, kWidth));
  ReportMasks(state, kPixels * sizeof(uint32_t));
}
BENCHMARK(BM_EncodeIdImage);

// What the one-pass encoder replaces: one mask per id, each encoded on its own.
void BM_EncodeIdImagePerIdMasks(benchmark::State& state) {
  const Corpus& corpus = GetCorpus();
  std::vector<uint8_t> mask(kPixels);
  for (auto _ : state) {
    for (uint32_t id = 0; id <= 15; ++id) {
      for (size_t i = 0; i < kPixels; ++i) mask[i] = corpus.id_image[i] == id;
      benchmark::DoNotOptimize(rle::EncodeRowMajor(mask, kHeight, kWidth));
    }
  }
  ReportMasks(state, kPixels * sizeof(uint32_t));
}
BENCHMARK(BM_EncodeIdImagePerIdMasks);

}  // namespace

BENCHMARK_MAIN();
