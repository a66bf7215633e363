// Each preset moves the proxy metrics the way the paper's Table 1 shows (solid-method.md
// 1.3 and 1.4), on the procedural models and the default procedural rooms. Every row changes one thing from the row
// before, so each check compares a row with its predecessor; a direction counts only
// when the gap exceeds both estimates' 95% half-widths together. The runs are
// deterministic (fixed seed), so these are exact regressions of a statistical claim.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <tuple>

#include "fixtures/shared_testdata.h"
#include "render/test_assets.h"
#include "solid/convert/convert.h"
#include "solid/render/params.h"
#include "solid/render/sample.h"

namespace solid::render {
namespace {

// Enough for the smallest difference claimed, scenenet-background's occlusion over rotation's
// (36.5% against 29.7% over 3,000 layouts of the default assets), to clear the two 95% CIs
// (about 2 points each here) in most draws.
constexpr int64_t kLayouts = 200;

// The embedded default's rooms (`solid convert procedural`: 8 rooms, seed 1), converted
// once per process, so that the rooms rows run on the rooms every user starts with.
struct DefaultRooms {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("solid-default-rooms-" + std::to_string(::getpid()));
  DefaultRooms() {
    convert::ConvertOptions options;
    options.jobs = 2;
    options.out = path;
    options.procedural = {.models = 0, .rooms = 8, .seed = 1};
    const auto report = convert::Convert(options);
    if (!report.ok() || report->failed != 0) std::abort();
  }
  ~DefaultRooms() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

std::map<std::string, SampleReport> SampleEveryPreset() {
  static const DefaultRooms rooms;
  auto library = AssetLibrary::Open(testing::ProceduralAssetsDir(), rooms.path).value();
  std::map<std::string, SampleReport> out;
  for (const std::string& name : PresetNames()) {
    // Rendered at 320x240 and classed as at the presets' 640x480, where Table 1's areas are:
    // halving leaves the layouts the same, and the masks cost a quarter.
    LayoutParams params = LoadPreset(name).value();
    std::tie(params.scale_width, params.scale_height) = ScaleClassResolution(params);
    params.width /= 2;
    params.height /= 2;
    auto sampler = LayoutSampler::Create(params, library).value();
    SampleOptions options;
    options.seed = 2024;
    options.layouts = kLayouts;
    options.jobs = 2;
    out.emplace(name, RunSample(*sampler, options).value());
  }
  return out;
}

// `higher` exceeds `lower` by more than their 95% half-widths together.
::testing::AssertionResult ClearlyAbove(const Estimate& higher, const Estimate& lower) {
  if (higher.mean - lower.mean > higher.ci95 + lower.ci95) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << higher.mean << " +- " << higher.ci95 << " is not clearly above "
                                       << lower.mean << " +- " << lower.ci95;
}

// Views whose camera elevation in the object's frame is beyond +-30 degrees: z-only
// rotations under eye-level cameras leave almost none, rotations about all axes many.
double ShareOfSteepViews(const ViewpointHistogram& h) {
  int64_t steep = 0, all = 0;
  for (int e = 0; e < h.elevation_bins; ++e) {
    const double centre = -90.0 + 180.0 * (e + 0.5) / h.elevation_bins;
    for (int a = 0; a < h.azimuth_bins; ++a) {
      const int64_t n = h.counts[static_cast<size_t>(e) * h.azimuth_bins + a];
      all += n;
      if (centre < -30 || centre > 30) steep += n;
    }
  }
  return all == 0 ? 0.0 : static_cast<double>(steep) / static_cast<double>(all);
}

// One test: ctest runs each test in its own process, and the six samples are the cost.
TEST(PresetDirection, EachRowMovesTheMetricsAsTableOneShows) {
  const std::map<std::string, SampleReport> reports = SampleEveryPreset();
  auto Row = [&](const std::string& name) -> const SampleReport& { return reports.at(name); };
  for (const std::string& name : PresetNames()) {
    EXPECT_EQ(Row(name).metrics.images, kLayouts) << name;
    EXPECT_EQ(Row(name).failed_layouts, 0) << name;
  }
  // occlusion: occlusion 19% -> 32%, count 8.73 -> 7.73.
  EXPECT_TRUE(ClearlyAbove(Row("occlusion").metrics.occlusion, Row("random-placement").metrics.occlusion));
  EXPECT_TRUE(
      ClearlyAbove(Row("random-placement").metrics.objects_per_image, Row("occlusion").metrics.objects_per_image));
  // scale-distribution: small 23% -> 32%, medium 48% -> 37%.
  EXPECT_TRUE(ClearlyAbove(Row("scale-distribution").metrics.small, Row("occlusion").metrics.small));
  // Counted at 640x480 (Table 1's areas), the procedural shapes' medium share falls by only
  // about 3 points here (43.8% to 40.5% over 200 layouts), within the CIs: the direction
  // alone is checked.
  EXPECT_LT(Row("scale-distribution").metrics.medium.mean, Row("occlusion").metrics.medium.mean);
  // rotation: more object viewpoints under the same eye-level cameras.
  EXPECT_LT(ShareOfSteepViews(Row("scale-distribution").viewpoints), 0.05);
  EXPECT_GT(ShareOfSteepViews(Row("rotation").viewpoints), 0.3);
  // scenenet-background: Table 1 has occlusion 33% -> 37% from SceneNet's shells; the
  // procedural rooms' pillars, wing and half walls, platforms and L/U/T corners stand
  // between camera and objects as theirs do.
  EXPECT_TRUE(ClearlyAbove(Row("scenenet-background").metrics.occlusion, Row("rotation").metrics.occlusion));
  // more-objects: 8.72 -> 13.72 once objects may float.
  EXPECT_TRUE(ClearlyAbove(Row("more-objects").metrics.objects_per_image,
                           Row("scenenet-background").metrics.objects_per_image));
}

// The same row on the SceneNet RGB-D layout of the shared data (bathroom11), with the
// procedural models. Its floor is one rectangle walled on three sides: no wall stands
// between a camera and objects on that floor, and the shower alcove, the one recess,
// has no floor for either. So the shell cannot occlude there: 200 layouts measure
// 33.5% +- 1.9 against rotation's 33.8% +- 1.9 (34.3 and 33.9 at 640x480). Only "no
// lower" is claimed of it, over enough layouts for that to mean something; the strict
// direction is left to rooms with structure (the test above).
TEST(PresetDirectionOnSharedData, SceneNetBackgroundIsNoLowerOnTheSharedLayout) {
  SOLID_SHARED_TESTDATA_OR_SKIP(scenenet, "real/scenenet-rgbd");
  const std::filesystem::path rooms =
      std::filesystem::temp_directory_path() / ("solid-direction-rooms-" + std::to_string(::getpid()));
  convert::ConvertOptions convert_options;
  convert_options.jobs = 2;
  convert_options.source = convert::Source::kSceneNet;
  convert_options.root = scenenet;
  convert_options.out = rooms;
  ASSERT_EQ(convert::Convert(convert_options).value().failed, 0);
  auto library = AssetLibrary::Open(testing::ProceduralAssetsDir(), rooms).value();
  std::map<std::string, SampleReport> reports;
  for (const std::string name : {"rotation", "scenenet-background"}) {
    LayoutParams params = LoadPreset(name).value();  // at 320x240: occlusion is a ratio of areas
    params.width /= 2;
    params.height /= 2;
    auto sampler = LayoutSampler::Create(params, library).value();
    SampleOptions options;
    options.seed = 2024;
    options.layouts = 200;
    options.jobs = 2;
    reports.emplace(name, RunSample(*sampler, options).value());
    EXPECT_EQ(reports.at(name).failed_layouts, 0) << name;
  }
  std::filesystem::remove_all(rooms);
  const Estimate& rooms_row = reports.at("scenenet-background").metrics.occlusion;
  EXPECT_GE(rooms_row.mean + rooms_row.ci95, reports.at("rotation").metrics.occlusion.mean);
}

}  // namespace
}  // namespace solid::render
