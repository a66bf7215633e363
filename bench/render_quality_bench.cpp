// Image quality of the shading settings as numbers (issue 22): a fixed set of layouts of
// one preset at 640x480 is shaded at a high sample count as the reference, then at each
// setting, and each setting gets PSNR and SSIM against the reference next to its time
// per image. The reference is our own renderer at --reference-spp uniform samples, so the
// numbers measure sampling noise and aliasing, not the lighting model.
//
// PSNR: over the 8-bit sRGB RGB values of every pixel of every layout (one MSE, pooled).
// SSIM: Wang et al. 2004 (IEEE TIP 13(4)), on BT.601 luma of the 8-bit images, 11x11
// Gaussian window (sigma 1.5), K1 = 0.01, K2 = 0.03, L = 255, the mean over every window
// inside the image, averaged over layouts. Debian has no C or C++ SSIM library (only
// pyssim), so it is computed here.
// Time: shading only (Shade: scene build, textures, tracing, tone curve), CPU time of the
// process per image (every thread's), and wall time; the mask pass, which shading reuses,
// is timed by `solid render` and bench/render_vs_blender.sh.
//
// References are cached in --reference-dir (PNG, lossless) when given, keyed by preset,
// seed, layout and spp: delete them when the lighting model changes.
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "solid/convert/convert.h"
#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"
#include "solid/render/sample.h"
#include "solid/render/shade.h"

namespace {

using namespace solid;
using namespace solid::render;
namespace fs = std::filesystem;

double CpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + t.tv_usec * 1e-6; };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

double SquaredError(const Image8& a, const Image8& b) {
  double sum = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    const double d = static_cast<double>(a.pixels[i]) - b.pixels[i];
    sum += d * d;
  }
  return sum;
}

std::vector<float> Luma(const Image8& image) {
  std::vector<float> y(static_cast<size_t>(image.width) * image.height);
  for (size_t i = 0; i < y.size(); ++i) {
    const uint8_t* p = &image.pixels[3 * i];
    y[i] = 0.299f * p[0] + 0.587f * p[1] + 0.114f * p[2];
  }
  return y;
}

// Separable 11x11 Gaussian (sigma 1.5) over the windows that fit in the image.
std::vector<double> Blur(const std::vector<double>& in, int w, int h, int* ow, int* oh) {
  constexpr int kRadius = 5;
  double kernel[2 * kRadius + 1], total = 0;
  for (int k = -kRadius; k <= kRadius; ++k) total += kernel[k + kRadius] = std::exp(-k * k / (2 * 1.5 * 1.5));
  for (double& k : kernel) k /= total;
  *ow = w - 2 * kRadius;
  *oh = h - 2 * kRadius;
  std::vector<double> rows(static_cast<size_t>(*ow) * h), out(static_cast<size_t>(*ow) * *oh);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < *ow; ++x) {
      double s = 0;
      for (int k = 0; k <= 2 * kRadius; ++k) s += kernel[k] * in[static_cast<size_t>(y) * w + x + k];
      rows[static_cast<size_t>(y) * *ow + x] = s;
    }
  }
  for (int y = 0; y < *oh; ++y) {
    for (int x = 0; x < *ow; ++x) {
      double s = 0;
      for (int k = 0; k <= 2 * kRadius; ++k) s += kernel[k] * rows[static_cast<size_t>(y + k) * *ow + x];
      out[static_cast<size_t>(y) * *ow + x] = s;
    }
  }
  return out;
}

double Ssim(const Image8& a, const Image8& b) {
  const int w = static_cast<int>(a.width), h = static_cast<int>(a.height);
  const std::vector<float> ya = Luma(a), yb = Luma(b);
  std::vector<double> x(ya.begin(), ya.end()), y(yb.begin(), yb.end()), xx(x.size()), yy(x.size()), xy(x.size());
  for (size_t i = 0; i < x.size(); ++i) xx[i] = x[i] * x[i], yy[i] = y[i] * y[i], xy[i] = x[i] * y[i];
  int ow = 0, oh = 0;
  const auto mx = Blur(x, w, h, &ow, &oh), my = Blur(y, w, h, &ow, &oh), sxx = Blur(xx, w, h, &ow, &oh),
             syy = Blur(yy, w, h, &ow, &oh), sxy = Blur(xy, w, h, &ow, &oh);
  const double c1 = (0.01 * 255) * (0.01 * 255), c2 = (0.03 * 255) * (0.03 * 255);
  double sum = 0;
  for (size_t i = 0; i < mx.size(); ++i) {
    const double vx = sxx[i] - mx[i] * mx[i], vy = syy[i] - my[i] * my[i], cxy = sxy[i] - mx[i] * my[i];
    sum += (2 * mx[i] * my[i] + c1) * (2 * cxy + c2) / ((mx[i] * mx[i] + my[i] * my[i] + c1) * (vx + vy + c2));
  }
  return sum / static_cast<double>(mx.size());
}

struct Setting {
  std::string name;
  ShadeOptions options;
};

struct Scene {
  GeneratedLayout generated;
  Image8 reference;
};

Result<Image8> Reference(const Scene& scene, const fs::path& cache, const std::string& key, int spp, int threads,
                         TextureCache& textures) {
  const fs::path path = cache.empty() ? fs::path() : cache / (key + ".png");
  if (!path.empty() && fs::exists(path)) {
    SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, files::ReadFile(path, uint64_t{1} << 30));
    return DecodeImage(bytes, ImageFormat::kPng);
  }
  ShadeOptions options;
  options.samples_per_pixel = spp;
  options.threads = threads;
  options.sampling = Sampling::kUniform;
  SOLID_ASSIGN_OR_RETURN(ShadeResult shaded, Shade(scene.generated.layout, scene.generated.lights, options, textures));
  if (!path.empty()) {
    SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> png, EncodeImage(shaded.image, ImageFormat::kPng));
    SOLID_RETURN_IF_ERROR(files::WriteFileAtomically(path, png));
  }
  return shaded.image;
}

Status Run(const fs::path& assets, const std::string& preset, int layouts, int reference_spp, int threads,
           const fs::path& cache, const fs::path& out, const std::vector<Setting>& settings) {
  SOLID_ASSIGN_OR_RETURN(std::shared_ptr<AssetLibrary> library, AssetLibrary::Open(assets, assets));
  SOLID_ASSIGN_OR_RETURN(LayoutParams params, LoadPreset(preset));
  params.width = 640;
  params.height = 480;
  SOLID_ASSIGN_OR_RETURN(auto sampler, LayoutSampler::Create(params, library));
  TextureCache textures;
  if (!cache.empty()) fs::create_directories(cache);
  if (!out.empty()) fs::create_directories(out);
  std::vector<Scene> scenes;
  // The first `layouts` usable layouts of seed 1, as `solid render --seed 1` draws them.
  for (int64_t i = 0; static_cast<int>(scenes.size()) < layouts && i < 10 * layouts; ++i) {
    Result<GeneratedLayout> g = GenerateLayout(*sampler, 1, i, MaskPassOptions{threads});
    if (!g.ok() && g.status().code() == StatusCode::kLimitExceeded) continue;
    SOLID_RETURN_IF_ERROR(g.status());
    Scene scene{std::move(g).value(), {}};
    const std::string key = fmt::format("{}-640x480-seed1-{:03}-{}spp", preset, i, reference_spp);
    SOLID_ASSIGN_OR_RETURN(scene.reference, Reference(scene, cache, key, reference_spp, threads, textures));
    scenes.push_back(std::move(scene));
  }
  fmt::print("{} layouts of {} at 640x480 (seed 1), reference {} spp uniform; {} thread(s) per image\n",
             scenes.size(), preset, reference_spp, threads);
  fmt::print("{:<24} {:>10} {:>11} {:>10} {:>8} {:>8}\n", "setting", "cpu ms/img", "wall ms/img", "rays/pixel", "PSNR dB",
             "SSIM");
  for (const Setting& setting : settings) {
    double squared = 0, ssim = 0, wall_ms = 0, rays = 0;
    size_t values = 0;
    const double cpu0 = CpuSeconds();
    for (size_t i = 0; i < scenes.size(); ++i) {
      ShadeOptions options = setting.options;
      options.threads = threads;
      const auto start = std::chrono::steady_clock::now();
      SOLID_ASSIGN_OR_RETURN(ShadeResult shaded,
                             Shade(scenes[i].generated.layout, scenes[i].generated.lights, options, textures,
                                   &scenes[i].generated.masks));
      wall_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      rays += static_cast<double>(shaded.rays);
      squared += SquaredError(shaded.image, scenes[i].reference);
      values += shaded.image.pixels.size();
      ssim += Ssim(shaded.image, scenes[i].reference);
      if (!out.empty()) {
        SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> png, EncodeImage(shaded.image, ImageFormat::kPng));
        SOLID_RETURN_IF_ERROR(files::WriteFileAtomically(out / fmt::format("{}-{:02}.png", setting.name, i), png));
      }
    }
    const double cpu_ms = (CpuSeconds() - cpu0) * 1000 / static_cast<double>(scenes.size());
    const double mse = squared / static_cast<double>(values);
    fmt::print("{:<24} {:>10.1f} {:>11.1f} {:>10.2f} {:>8.2f} {:>8.4f}\n", setting.name, cpu_ms,
               wall_ms / static_cast<double>(scenes.size()), rays / static_cast<double>(values / 3),
               10 * std::log10(255.0 * 255.0 / mse), ssim / static_cast<double>(scenes.size()));
    std::fflush(stdout);
  }
  return Status::Ok();
}

// "uniform:4" (spp samples of everything per pixel, `solid render`'s default) or
// "adaptive:6" (mask-driven, shade.h Sampling::kAdaptive).
Result<Setting> ParseSetting(const std::string& text) {
  const size_t colon = text.find(':');
  Setting s{text, {}};
  if (colon == std::string::npos) return InvalidArgumentError(fmt::format("--setting {}: expected MODE:SPP", text));
  const std::string mode = text.substr(0, colon);
  if (mode == "uniform") {
    s.options.sampling = Sampling::kUniform;
  } else if (mode == "adaptive") {
    s.options.sampling = Sampling::kAdaptive;
  } else {
    return InvalidArgumentError(fmt::format("--setting {}: mode is uniform or adaptive", text));
  }
  s.options.samples_per_pixel = std::stoi(text.substr(colon + 1));
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Image quality (PSNR, SSIM against a high-spp reference) and time per image of shading settings"};
  fs::path assets, cache, out;
  std::string preset = "more-objects";
  int layouts = 8, reference_spp = 256, threads = 1;
  std::vector<std::string> setting_names = {"uniform:1",  "uniform:2",  "uniform:4",  "uniform:8",
                                            "adaptive:2", "adaptive:4", "adaptive:6", "adaptive:8"};
  app.add_option("--assets", assets,
                 "assets directory (default: `solid convert procedural --models 64 --rooms 8 --seed 1`, generated)");
  app.add_option("--preset", preset, "preset of the layouts")->capture_default_str();
  app.add_option("--layouts", layouts, "layouts (the first usable ones of seed 1)")->capture_default_str();
  app.add_option("--reference-spp", reference_spp, "samples per pixel of the reference")->capture_default_str();
  app.add_option("--threads", threads, "threads per image")->capture_default_str();
  app.add_option("--reference-dir", cache, "cache the references here");
  app.add_option("--setting", setting_names, "settings to measure, MODE:SPP (uniform or adaptive)")
      ->capture_default_str();
  app.add_option("--out", out, "write every setting's images here as PNG");
  CLI11_PARSE(app, argc, argv);
  std::vector<Setting> settings;
  for (const std::string& name : setting_names) {
    Result<Setting> s = ParseSetting(name);
    if (!s.ok()) {
      fmt::print(stderr, "render_quality_bench: {}\n", s.status().ToString());
      return 2;
    }
    settings.push_back(*s);
  }
  fs::path generated;
  if (assets.empty()) {
    generated = fs::temp_directory_path() / fmt::format("solid-quality-bench-{}", ::getpid());
    convert::ConvertOptions options;
    options.jobs = threads;
    options.out = generated;
    options.procedural = {64, 8, 1};
    const auto report = convert::Convert(options);
    if (!report.ok()) {
      fmt::print(stderr, "procedural assets: {}\n", report.status().ToString());
      return 1;
    }
    assets = generated;
  }
  const Status status = Run(assets, preset, layouts, reference_spp, threads, cache, out, settings);
  if (!generated.empty()) fs::remove_all(generated);
  if (!status.ok()) {
    fmt::print(stderr, "render_quality_bench: {}\n", status.ToString());
    return 1;
  }
  return 0;
}
