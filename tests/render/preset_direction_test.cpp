// Each preset moves the proxy metrics the way the paper's Table 1 shows (solid-method.md
// 1.3 and 1.4), on the procedural assets. Every row changes one thing from the row
// before, so each check compares a row with its predecessor; a direction counts only
// when the gap exceeds both estimates' 95% half-widths together. The runs are
// deterministic (fixed seed), so these are exact regressions of a statistical claim.
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <tuple>

#include "render/test_assets.h"
#include "solid/render/params.h"
#include "solid/render/sample.h"

namespace solid::render {
namespace {

constexpr int64_t kLayouts = 80;

std::map<std::string, SampleReport> SampleEveryPreset() {
  std::map<std::string, SampleReport> out;
  for (const std::string& name : PresetNames()) {
    // Rendered at 320x240 and classed as at the presets' 640x480, where Table 1's areas are:
    // halving leaves the layouts the same, and the masks cost a quarter. (At 160x120 the
    // medium share moves by 3 points: too coarse for the scale-distribution row.)
    LayoutParams params = LoadPreset(name).value();
    std::tie(params.scale_width, params.scale_height) = ScaleClassResolution(params);
    params.width /= 2;
    params.height /= 2;
    auto sampler = LayoutSampler::Create(params, testing::ProceduralLibrary()).value();
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
  // scenenet-background: Table 1 has occlusion 33% -> 37% from SceneNet's cluttered shells.
  // The procedural rooms are empty boxes, rescaled to the same 12 x 12 m as the white cube,
  // so on them this row moves nothing; only that it is no worse is checked.
  EXPECT_GE(Row("scenenet-background").metrics.occlusion.mean + Row("scenenet-background").metrics.occlusion.ci95,
            Row("rotation").metrics.occlusion.mean);
  // more-objects: 8.72 -> 13.72 once objects may float.
  EXPECT_TRUE(ClearlyAbove(Row("more-objects").metrics.objects_per_image,
                           Row("scenenet-background").metrics.objects_per_image));
}

}  // namespace
}  // namespace solid::render
