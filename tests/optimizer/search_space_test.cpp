// The search-space file: located errors for unknown keys and bad bounds, the default fit
// knobs, and the encoding of params as points (transforms and their inverses).
#include "solid/optimizer/search_space.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "formats/test_util.h"
#include "solid/formats/json_schema.h"

namespace solid::optimizer {
namespace {

using ::testing::HasSubstr;

Result<SearchSpace> Parse(std::string_view text) {
  SOLID_ASSIGN_OR_RETURN(nlohmann::json document, json::ParseJson(text, "space.json"));
  return SearchSpace::Parse(document, text, "space.json");
}

render::LayoutParams Preset(std::string_view name) {
  Result<render::LayoutParams> p = render::LoadPreset(name);
  EXPECT_TRUE(p.ok()) << p.status().ToString();
  return p.ok() ? *p : render::LayoutParams{};
}

TEST(SearchSpace, ParsesEveryTransform) {
  Result<SearchSpace> space = Parse(R"({
  "start": {"preset": "more-objects"},
  "free": {
    "objects.attempts": {"transform": "range", "low": [5, 40], "width": [0, 8], "step": 2},
    "camera.height_m": {"transform": "upper", "bounds": [1, 3]},
    "placement.occlude_prob": {"bounds": [0, 1]},
    "objects.scale.p": {"transform": "simplex"}
  }
})");
  ASSERT_OK(space.status());
  EXPECT_EQ(space->start_preset(), "more-objects");
  Result<std::vector<Dimension>> dims = space->Dimensions(Preset("more-objects"));
  ASSERT_OK(dims.status());
  std::vector<std::string> names;
  for (const Dimension& d : *dims) names.push_back(d.name);
  // A file's knobs come in name order.
  EXPECT_THAT(names, ::testing::ElementsAre("camera.height_m.hi", "objects.attempts.low", "objects.attempts.width",
                                            "objects.scale.p[0]", "objects.scale.p[1]", "placement.occlude_prob"));
  EXPECT_EQ((*dims)[1].step, 2);
  EXPECT_DOUBLE_EQ((*dims)[0].step, 0.2 * 2);  // a fifth of the bounds' width by default
}

TEST(SearchSpace, UnknownKeysAreErrorsWithTheirLocation) {
  Result<SearchSpace> space = Parse(R"({
  "free": {
    "placement.occlude_prob": {"bounds": [0, 1]},
    "placement.oclude_prob": {"bounds": [0, 1]}
  }
})");
  ASSERT_FALSE(space.ok());
  EXPECT_THAT(space.status().message(), HasSubstr("space.json:4: /free/placement.oclude_prob"));

  space = Parse(R"({"free": {"placement.occlude_prob": {"bonds": [0, 1]}}})");
  ASSERT_FALSE(space.ok());
  EXPECT_THAT(space.status().message(), HasSubstr("/free/placement.occlude_prob"));

  space = Parse(R"({"free": {}, "strat": {}})");
  ASSERT_FALSE(space.ok());
  EXPECT_THAT(space.status().message(), HasSubstr("strat"));
}

TEST(SearchSpace, StringsLongerThanTheLimitAreRefused) {
  solid::testing::TempDir dir;
  const std::filesystem::path path = dir.path() / "space.json";
  std::ofstream(path) << R"({"start": {"params": ")" << std::string(json::kMaxConfigStringBytes + 1, 'p')
                      << R"("}, "free": {}})";
  Result<SearchSpace> space = SearchSpace::Load(path);
  ASSERT_FALSE(space.ok());
  EXPECT_EQ(space.status().code(), StatusCode::kLimitExceeded) << space.status().ToString();
  EXPECT_THAT(space.status().message(), HasSubstr(path.string() + ":1:"));
  EXPECT_THAT(space.status().message(), HasSubstr("limit of 4096 bytes"));
}

TEST(SearchSpace, BadBoundsAndTransformsAreErrors) {
  Result<SearchSpace> space = Parse(R"({
  "free": {
    "placement.cluster_margin_m": {"bounds": [2, 1]}
  }
})");
  ASSERT_FALSE(space.ok());
  EXPECT_THAT(space.status().message(), HasSubstr("space.json:3: /free/placement.cluster_margin_m/bounds"));

  space = Parse(R"({"free": {"objects.scale.p": {"transform": "simplex"}}})");
  ASSERT_OK(space.status());
  Result<std::vector<Dimension>> dims = space->Dimensions(Preset("random-placement"));  // a uniform law
  ASSERT_FALSE(dims.ok());
  EXPECT_THAT(dims.status().message(), HasSubstr("objects.scale.p: a simplex needs a mixture"));
}

TEST(SearchSpace, FitKnobsFollowTheMethod) {
  const render::LayoutParams start = Preset("more-objects");
  SearchSpace space = SearchSpace::FitKnobs(start);
  std::vector<std::string> knobs;
  for (const FreeKnob& k : space.knobs()) knobs.push_back(k.name);
  EXPECT_THAT(knobs, ::testing::UnorderedElementsAre("objects.attempts", "placement.occlude_prob",
                                                     "placement.cluster_margin_m", "camera.ring_m", "camera.height_m",
                                                     "objects.scale.p", "objects.scale.range_m"));
  // Intervals move whole, a mixture's ranges together: one dimension each.
  Result<std::vector<Dimension>> dims = space.Dimensions(start);
  ASSERT_OK(dims.status());
  std::vector<std::string> names;
  for (const Dimension& d : *dims) names.push_back(d.name);
  EXPECT_THAT(names, ::testing::UnorderedElementsAre("objects.attempts.shift", "placement.occlude_prob",
                                                     "placement.cluster_margin_m", "camera.ring_m.shift",
                                                     "camera.height_m.hi", "objects.scale.p[0]", "objects.scale.p[1]",
                                                     "objects.scale.range_m.top"));
  // A uniform law keeps its range's two ends apart: they set the small and the large share.
  Result<std::vector<Dimension>> uniform = SearchSpace::FitKnobs(Preset("random-placement")).Dimensions(Preset("random-placement"));
  ASSERT_OK(uniform.status());
  EXPECT_EQ(uniform->size(), 7u);
  ASSERT_OK(space.Free("placement.depth_by_size_prob", start));
  ASSERT_OK(space.Fix("objects.scale.range_m"));
  ASSERT_OK(space.Free("placement.cluster_prob", start));
  EXPECT_FALSE(space.Free("placement.nope", start).ok());
  EXPECT_THAT(space.Fix("camera.fov").message(), HasSubstr("unknown knob \"camera.fov\""));
}

TEST(SearchSpace, DecodeInvertsEncode) {
  for (const std::string name : {"random-placement", "more-objects"}) {
    const render::LayoutParams start = Preset(name);
    const SearchSpace space = SearchSpace::FitKnobs(start);
    Result<render::LayoutParams> back = space.Decode(start, space.Encode(start));
    ASSERT_OK(back.status());
    EXPECT_NEAR(back->attempts.hi, start.attempts.hi, 1e-12) << name;
    EXPECT_NEAR(back->attempts.lo, start.attempts.lo, 1e-12) << name;
    EXPECT_NEAR(back->camera_height_m.hi, start.camera_height_m.hi, 1e-12) << name;
    ASSERT_EQ(back->scale.buckets.size(), start.scale.buckets.size());
    for (size_t i = 0; i < start.scale.buckets.size(); ++i) {
      EXPECT_NEAR(back->scale.buckets[i].probability, start.scale.buckets[i].probability, 1e-12) << name;
      EXPECT_NEAR(back->scale.buckets[i].size_m.lo, start.scale.buckets[i].size_m.lo, 1e-12) << name;
      EXPECT_NEAR(back->scale.buckets[i].size_m.hi, start.scale.buckets[i].size_m.hi, 1e-12) << name;
    }
  }
}

TEST(SearchSpace, ShiftKeepsTheWidthAndScaleKeepsTheProportions) {
  const render::LayoutParams start = Preset("more-objects");
  Result<SearchSpace> space = Parse(R"({"free": {
    "objects.attempts": {"transform": "shift", "bounds": [1, 60]},
    "objects.scale.range_m": {"transform": "scale", "bounds": [1, 6]}
  }})");
  ASSERT_OK(space.status());
  // Knobs in name order: attempts, then the scale.
  Result<render::LayoutParams> p = space->Decode(start, std::vector<double>{30, 4.5});
  ASSERT_OK(p.status());
  EXPECT_DOUBLE_EQ(p->attempts.lo, 30);
  EXPECT_DOUBLE_EQ(p->attempts.hi, 30 + (start.attempts.hi - start.attempts.lo));
  ASSERT_EQ(p->scale.buckets.size(), start.scale.buckets.size());
  const double factor = 4.5 / start.scale.buckets.back().size_m.hi;
  for (size_t i = 0; i < start.scale.buckets.size(); ++i) {
    EXPECT_DOUBLE_EQ(p->scale.buckets[i].size_m.lo, start.scale.buckets[i].size_m.lo * factor) << i;
    EXPECT_DOUBLE_EQ(p->scale.buckets[i].size_m.hi, start.scale.buckets[i].size_m.hi * factor) << i;
    EXPECT_EQ(p->scale.buckets[i].probability, start.scale.buckets[i].probability) << i;
  }
  EXPECT_THAT(space->Encode(*p), ::testing::ElementsAre(30, 4.5));

  // "scale" is for size ranges, "shift" for intervals.
  space = Parse(R"({"free": {"objects.attempts": {"transform": "scale", "bounds": [1, 6]}}})");
  EXPECT_FALSE(space.ok());
}

TEST(SearchSpace, EveryCornerOfTheBoxDecodesToValidParams) {
  const render::LayoutParams start = Preset("more-objects");
  const SearchSpace space = SearchSpace::FitKnobs(start);
  Result<std::vector<Dimension>> dims = space.Dimensions(start);
  ASSERT_OK(dims.status());
  for (int corner = 0; corner < 2; ++corner) {
    std::vector<double> x;
    for (const Dimension& d : *dims) x.push_back(corner ? d.hi : d.lo);
    Result<render::LayoutParams> p = space.Decode(start, x);
    ASSERT_OK(p.status());
    EXPECT_LE(p->camera_ring_m.hi, 6.0);
  }
}

}  // namespace
}  // namespace solid::optimizer
