// How much the embedded procedural models look like real ShapeNet models to the layout
// sampler and the mask pass (issue 18): over views drawn as the sampler draws them
// (the random-placement preset, 640x480 unless told otherwise), per visible, untruncated
// instance:
//   fill      visible pixels / visible box area
//   aspect    visible box width / height
//   area@5m   full-mask pixels of the model scaled to a largest extent of 1 m and seen
//             from 5 m (n_f * (d / 5)^2 / s^2)
// and per model: thinness = smallest / largest bounding-box extent. Printed as
// quartiles for each set side by side, then the preset's proxy metrics on each set.
//
//   asset_likeness_bench [--real DIR] [--procedural DIR] [--layouts 300] [--preset random-placement]
//                        [--resolution 640x480] [--jobs 2]
//
// Without --real it converts ../shared/testdata/real/shapenet (the shared probe of six
// models) into a temporary directory; without --procedural, the embedded default
// (64 models, 8 rooms, seed 1). A third set, "matched", holds 64 procedural models of
// only the real set's categories (chair, table, car, airplane, trash bin for the probe).
// Six models are a probe, not a distribution.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <map>
#include <tuple>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "solid/convert/convert.h"
#include "solid/formats/metrics.h"
#include "solid/render/assets.h"
#include "solid/render/params.h"
#include "solid/render/sample.h"

namespace {

namespace fs = std::filesystem;
using namespace solid;
using namespace solid::render;

struct SetStats {
  std::string name;
  std::vector<double> fill, aspect, area, thinness;
  ProxyMetrics metrics;
  int64_t instances = 0, truncated = 0;
};

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double x = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<size_t>(x);
  const double f = x - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

Result<SetStats> Measure(const std::string& name, const fs::path& dir, const LayoutParams& params, int layouts,
                         int jobs, uint64_t seed) {
  SOLID_ASSIGN_OR_RETURN(std::shared_ptr<AssetLibrary> library, AssetLibrary::Open(dir, dir));
  SetStats stats;
  stats.name = name;
  for (size_t i = 0; i < library->models().size(); ++i) {
    SOLID_ASSIGN_OR_RETURN(std::shared_ptr<const LoadedAsset> model, library->Model(i));
    const Vec3 e = model->half_extents();
    stats.thinness.push_back(std::min({e.x, e.y, e.z}) / std::max({e.x, e.y, e.z}));
  }
  SOLID_ASSIGN_OR_RETURN(std::unique_ptr<LayoutSampler> sampler, LayoutSampler::Create(params, library));
  std::vector<std::vector<InstanceRecord>> per_layout(static_cast<size_t>(layouts));
  std::vector<Status> errors(static_cast<size_t>(layouts), Status::Ok());
  std::atomic<int> next{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < jobs; ++t) {
    pool.emplace_back([&] {
      for (int i; (i = next++) < layouts;) {
        Result<GeneratedLayout> g = GenerateLayout(*sampler, seed, i);
        if (!g.ok()) {
          errors[static_cast<size_t>(i)] = g.status();
          continue;
        }
        for (InstanceRecord& r : g->masks.instances) {
          if (r.visible_area > 0) per_layout[static_cast<size_t>(i)].push_back(std::move(r));
        }
      }
    });
  }
  for (std::thread& t : pool) t.join();
  for (const Status& s : errors) SOLID_RETURN_IF_ERROR(s);
  MetricsAccumulator metrics;
  for (const std::vector<InstanceRecord>& instances : per_layout) {
    metrics.AddImage(instances);
    for (const InstanceRecord& r : instances) {
      ++stats.instances;
      // A box cut by the frame says nothing about the shape.
      if (r.truncation > 0) {
        ++stats.truncated;
        continue;
      }
      stats.fill.push_back(static_cast<double>(r.visible_area) / static_cast<double>(r.visible_box.w * r.visible_box.h));
      stats.aspect.push_back(static_cast<double>(r.visible_box.w) / static_cast<double>(r.visible_box.h));
      const double at_5m = r.camera_distance / 5 / r.object_scale;
      stats.area.push_back(static_cast<double>(r.full_area) * at_5m * at_5m);
    }
  }
  stats.metrics = metrics.Finish();
  return stats;
}

// families: empty for the default mix.
Result<fs::path> Convert(const fs::path& dir, bool procedural, const std::vector<convert::ShapeFamily>& families = {}) {
  convert::ConvertOptions options;
  options.jobs = 2;
  options.out = dir;
  if (procedural) {
    options.procedural.shapes.families = families;
  } else {
    options.source = convert::Source::kShapeNet;
    options.root = fs::path(SOLID_SOURCE_DIR) / "../shared/testdata/real/shapenet";
  }
  Result<convert::ConvertReport> report = convert::Convert(options);
  SOLID_RETURN_IF_ERROR(report.status());
  if (report->failed > 0) return InternalError(fmt::format("{}: {} assets failed", dir.string(), report->failed));
  return dir;
}

int Run(int argc, char** argv) {
  CLI::App app{"Likeness of the procedural models to real ShapeNet models, as the sampler sees them"};
  std::string real, procedural, preset = "random-placement", resolution = "640x480";
  int layouts = 300, jobs = 2;
  uint64_t seed = 1;
  app.add_option("--real", real, "Assets of real models (default: convert the shared ShapeNet probe)");
  app.add_option("--procedural", procedural, "Procedural assets (default: convert the embedded default)");
  app.add_option("--preset", preset, "Layout preset")->capture_default_str();
  app.add_option("--layouts", layouts, "Layouts per set")->capture_default_str();
  app.add_option("--resolution", resolution, "WxH")->capture_default_str();
  app.add_option("--jobs", jobs, "Layouts in parallel")->capture_default_str();
  app.add_option("--seed", seed, "Dataset seed")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  int width = 0, height = 0;
  if (std::sscanf(resolution.c_str(), "%dx%d", &width, &height) != 2 || width <= 0 || height <= 0) {
    fmt::print(stderr, "--resolution: expected WxH, got {}\n", resolution);
    return 2;
  }
  auto params = LoadPreset(preset);
  if (!params.ok()) {
    fmt::print(stderr, "{}\n", params.status().ToString());
    return 2;
  }
  params->width = width;
  params->height = height;
  const fs::path temp = fs::temp_directory_path() / fmt::format("solid-likeness-{}", ::getpid());
  std::vector<std::pair<std::string, fs::path>> sets;
  for (const auto& [name, given, is_procedural] :
       {std::tuple{"real", real, false}, std::tuple{"procedural", procedural, true}}) {
    if (!given.empty()) {
      sets.emplace_back(name, given);
      continue;
    }
    Result<fs::path> dir = Convert(temp / name, is_procedural);
    if (!dir.ok()) {
      fmt::print(stderr, "{} assets: {}\n", name, dir.status().ToString());
      fs::remove_all(temp);
      return 1;
    }
    sets.emplace_back(name, *dir);
  }
  // The procedural families of the real set's categories (by synset), so that the
  // likeness of like with like is measured too.
  {
    auto real_library = AssetLibrary::Open(sets[0].second, sets[0].second);
    std::vector<convert::ShapeFamily> families;
    if (real_library.ok()) {
      for (const AssetEntry& e : (*real_library)->models()) {
        const std::string synset = e.key.substr(0, e.key.find('/'));
        for (int f = 0; f < convert::kShapeFamilyCount; ++f) {
          const auto family = static_cast<convert::ShapeFamily>(f);
          if (convert::ShapeFamilySynset(family) == synset &&
              std::find(families.begin(), families.end(), family) == families.end()) {
            families.push_back(family);
          }
        }
      }
    }
    if (!families.empty()) {
      Result<fs::path> dir = Convert(temp / "matched", true, families);
      if (!dir.ok()) {
        fmt::print(stderr, "matched assets: {}\n", dir.status().ToString());
        fs::remove_all(temp);
        return 1;
      }
      std::string names;
      for (const convert::ShapeFamily f : families) names += (names.empty() ? "" : ",") + std::string(convert::ShapeFamilyName(f));
      fmt::print("matched: the procedural families {} (the real set's categories)\n", names);
      sets.emplace_back("matched", *dir);
    }
  }
  std::vector<SetStats> measured;
  for (const auto& [name, dir] : sets) {
    Result<SetStats> s = Measure(name, dir, *params, layouts, jobs, seed);
    if (!s.ok()) {
      fmt::print(stderr, "{}: {}\n", name, s.status().ToString());
      fs::remove_all(temp);
      return 1;
    }
    measured.push_back(std::move(s).value());
  }
  fs::remove_all(temp);

  fmt::print("{} layouts of {} at {}x{} per set; quartiles (25% / median / 75%)\n", layouts, preset, width, height);
  fmt::print("{:<12}", "metric");
  for (const SetStats& s : measured) fmt::print(" {:>26}", s.name);
  fmt::print("  medians vs {}\n", measured[0].name);
  const auto row = [&](const char* label, std::vector<double> SetStats::*field, const char* format) {
    fmt::print("{:<12}", label);
    for (const SetStats& s : measured) {
      const std::vector<double>& v = s.*field;
      fmt::print(" {:>26}", fmt::format(fmt::runtime(format), Quantile(v, 0.25), Quantile(v, 0.5), Quantile(v, 0.75)));
    }
    const double a = Quantile(measured[0].*field, 0.5);
    for (size_t k = 1; k < measured.size(); ++k) {
      const double b = Quantile(measured[k].*field, 0.5);
      fmt::print(" {:>+7.1f}%", a > 0 ? 100 * (b - a) / a : 0.0);
    }
    fmt::print("\n");
  };
  row("fill", &SetStats::fill, "{:.2f} / {:.2f} / {:.2f}");
  row("aspect", &SetStats::aspect, "{:.2f} / {:.2f} / {:.2f}");
  row("thinness", &SetStats::thinness, "{:.2f} / {:.2f} / {:.2f}");
  row("area@5m px", &SetStats::area, "{:.0f} / {:.0f} / {:.0f}");
  fmt::print("{:<12}", "models");
  for (const SetStats& s : measured) fmt::print(" {:>26}", s.thinness.size());
  fmt::print("\n{:<12}", "instances");
  for (const SetStats& s : measured) fmt::print(" {:>26}", fmt::format("{} ({} truncated)", s.instances, s.truncated));
  fmt::print("\n\n{} proxy metrics (95% half-widths)\n", preset);
  for (const SetStats& s : measured) {
    const ProxyMetrics& m = s.metrics;
    fmt::print("{:<12} count {:.2f} +- {:.2f}  occlusion {:.1f}% +- {:.1f}  s/m/l {:.1f} / {:.1f} / {:.1f}%\n", s.name,
               m.objects_per_image.mean, m.objects_per_image.ci95, 100 * m.occlusion.mean, 100 * m.occlusion.ci95,
               100 * m.small.mean, 100 * m.medium.mean, 100 * m.large.mean);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return Run(argc, argv); }
