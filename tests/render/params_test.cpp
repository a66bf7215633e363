// Layout parameters: the six presets of solid-method 4.2, the JSON form and its round trip,
// and located errors for unknown keys, wrong types, out-of-range values and broken rules.
#include "solid/render/params.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <string>

#include "formats/test_util.h"
#include "solid/formats/json_schema.h"
#include "solid/formats/schemas.h"

namespace solid::render {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

Result<LayoutParams> Parse(std::string_view text) {
  SOLID_ASSIGN_OR_RETURN(nlohmann::json document, json::ParseJson(text, "params.json"));
  return ParseParams(document, text, "params.json");
}

LayoutParams Preset(std::string_view name) {
  Result<LayoutParams> params = LoadPreset(name);
  EXPECT_TRUE(params.ok()) << params.status().ToString();
  return params.ok() ? *params : LayoutParams{};
}

nlohmann::json EmbeddedJson(std::string_view path) {
  Result<std::string_view> text = schemas::Get(path);
  EXPECT_TRUE(text.ok()) << text.status().ToString();
  if (!text.ok()) return {};
  Result<nlohmann::json> document = json::ParseJson(*text, path);
  EXPECT_TRUE(document.ok()) << document.status().ToString();
  return document.ok() ? *document : nlohmann::json();
}

// Knob pointer -> value; the scale law counts as one knob, as in solid-method 4.1.
std::map<std::string, nlohmann::json> Knobs(const LayoutParams& params) {
  std::map<std::string, nlohmann::json> knobs;
  const nlohmann::json document = ParamsToJson(params);
  for (const auto& [section, members] : document.items()) {
    for (const auto& [key, value] : members.items()) knobs["/" + section + "/" + key] = value;
  }
  return knobs;
}

std::set<std::string> DifferingKnobs(const LayoutParams& a, const LayoutParams& b) {
  const std::map<std::string, nlohmann::json> ka = Knobs(a), kb = Knobs(b);
  std::set<std::string> differing;
  for (const auto& [pointer, value] : ka) {
    if (!kb.contains(pointer) || kb.at(pointer) != value) differing.insert(pointer);
  }
  for (const auto& [pointer, value] : kb) {
    if (!ka.contains(pointer)) differing.insert(pointer);
  }
  return differing;
}

const ScaleLaw kUniform04To2{false, {{{0.4, 2.0}, 1.0}}};
const ScaleLaw kPaperMixture{true, {{{0.1, 1.0}, 0.7}, {{1.0, 2.0}, 0.1}, {{2.0, 3.0}, 0.2}}};

TEST(Presets, NamesMatchTheEmbeddedFilesAndTheSchemaEnum) {
  EXPECT_THAT(PresetNames(), ::testing::ElementsAre("random-placement", "occlusion", "scale-distribution", "rotation",
                                                    "scenenet-background", "more-objects"));
  std::vector<std::string> embedded;
  for (std::string_view path : schemas::Names()) {
    if (path.starts_with("presets/")) embedded.emplace_back(path);
  }
  std::vector<std::string> expected;
  for (const std::string& name : PresetNames()) expected.push_back("presets/" + name + ".json");
  EXPECT_THAT(embedded, ::testing::UnorderedElementsAreArray(expected));
  const nlohmann::json schema = EmbeddedJson("params.schema.json");
  EXPECT_EQ(schema["properties"]["preset"]["enum"], nlohmann::json(PresetNames()));
}

TEST(Presets, EveryPresetLoadsAndRoundTripsExactlyThroughJson) {
  for (const std::string& name : PresetNames()) {
    SCOPED_TRACE(name);
    const LayoutParams preset = Preset(name);
    EXPECT_OK(CheckParams(preset, name));
    Result<LayoutParams> again = ParseParams(ParamsToJson(preset), "", "round trip");
    ASSERT_TRUE(again.ok()) << again.status().ToString();
    EXPECT_EQ(*again, preset);
    Result<LayoutParams> from_text = Parse(ParamsToJson(preset).dump(2));
    ASSERT_TRUE(from_text.ok()) << from_text.status().ToString();
    EXPECT_EQ(*from_text, preset);
  }
}

TEST(Presets, EachFileSetsEveryKnobExplicitlyAndNamesNoPreset) {
  for (const std::string& name : PresetNames()) {
    SCOPED_TRACE(name);
    nlohmann::json file = EmbeddedJson("presets/" + name + ".json");
    ASSERT_TRUE(file.contains("$comment"));
    EXPECT_THAT(file["$comment"].get<std::string>(), HasSubstr("Table 1 row"));
    EXPECT_FALSE(file.contains("preset"));
    file.erase("$comment");
    // Equal as JSON values: every knob ParamsToJson writes is in the file, and nothing else.
    EXPECT_EQ(file, ParamsToJson(Preset(name)));
  }
}

TEST(Presets, FollowTheRandomPlacementRowOfTable42) {
  const LayoutParams p = Preset("random-placement");
  EXPECT_EQ(p.scene, SceneKind::kWhiteCube);
  EXPECT_EQ(p.support, Support::kFloor);
  EXPECT_EQ(p.scale, kUniform04To2);
  EXPECT_EQ(p.rotation_axes, RotationAxes::kZ);
  EXPECT_EQ(p.occlude_prob, 0.0);
  EXPECT_EQ(p.cluster_prob, 0.0);
  EXPECT_EQ(p.camera_height_m, (Interval{0.1, 5.0}));
  EXPECT_EQ(p.camera_look_z_m, (Interval{0.0, 2.0}));
  EXPECT_EQ(p.attempts, (Interval{9, 9}));
  EXPECT_EQ(p.width, 640);
  EXPECT_EQ(p.height, 480);
}

TEST(Presets, FollowTheMoreObjectsRowOfTable42) {
  const LayoutParams p = Preset("more-objects");
  EXPECT_EQ(p.scene, SceneKind::kRooms);
  EXPECT_EQ(p.support, Support::kFloating);
  EXPECT_EQ(p.scale, kPaperMixture);
  EXPECT_EQ(p.rotation_axes, RotationAxes::kXyz);
  EXPECT_EQ(p.occlude_prob, 0.7);
  EXPECT_EQ(p.cluster_prob, 1.0);
  EXPECT_EQ(p.camera_height_m, (Interval{0.1, 2.0}));
  EXPECT_EQ(p.camera_look_z_m, (Interval{0.1, 2.1}));
  EXPECT_EQ(p.attempts, (Interval{20, 25}));
  EXPECT_EQ(p.width, 640);
  EXPECT_EQ(p.height, 480);
}

// Each Table 1 row keeps everything from the row before and changes one thing (4.2 in bold).
// solid-method.md 4.2, "Resolution": Table 1's scale shares are areas at 640x480.
TEST(Presets, EveryPresetRendersAndCountsScaleClassesAt640x480) {
  for (const std::string& name : PresetNames()) {
    SCOPED_TRACE(name);
    const LayoutParams p = Preset(name);
    EXPECT_EQ(std::pair(p.width, p.height), std::pair(640, 480));
    EXPECT_EQ(ScaleClassResolution(p), std::pair(640, 480));
    EXPECT_EQ(ScaleClassAreaScale(p, p.width, p.height), 1.0);
    EXPECT_FALSE(ParamsToJson(p).contains(nlohmann::json::json_pointer("/render/scale_classes_at")));
  }
}

TEST(ScaleClassesAt, FollowsTheResolutionUnlessSetAndRoundTrips) {
  Result<LayoutParams> p = Parse(R"({"preset": "occlusion", "render": {"resolution": [320, 240]}})");
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  EXPECT_EQ(ScaleClassResolution(*p), std::pair(320, 240));
  EXPECT_EQ(ScaleClassDescription(*p), "320x240");

  p = Parse(R"({"preset": "occlusion", "render": {"resolution": [320, 240], "scale_classes_at": [640, 480]}})");
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  EXPECT_EQ(ScaleClassResolution(*p), std::pair(640, 480));
  // A 320x240 area counts four times: 256 pixels there are COCO's 32^2 at 640x480.
  EXPECT_EQ(ScaleClassAreaScale(*p, 320, 240), 4.0);
  EXPECT_EQ(ScaleClassAreaScale(*p, 160, 120), 16.0);
  EXPECT_EQ(ScaleClassDescription(*p), "640x480 (scale_classes_at; rendered at 320x240)");
  const nlohmann::json j = ParamsToJson(*p);
  EXPECT_EQ(j["render"]["scale_classes_at"], nlohmann::json::array({640, 480}));
  Result<LayoutParams> again = ParseParams(j, "", "round trip");
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  EXPECT_EQ(*again, *p);

  Result<LayoutParams> bad = Parse(R"({"preset": "occlusion", "render": {"scale_classes_at": [8, 480]}})");
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.status().message(), HasSubstr("/render/scale_classes_at/0"));
}

TEST(Presets, ConsecutiveRowsDifferExactlyInTheKnobsTable42Changes) {
  const std::vector<std::pair<std::string, std::set<std::string>>> rows = {
      {"random-placement", {}},
      {"occlusion", {"/placement/occlude_prob", "/placement/cluster_prob", "/camera/height_m", "/camera/look_z_m"}},
      {"scale-distribution", {"/objects/scale"}},
      {"rotation", {"/objects/rotation_axes"}},
      {"scenenet-background", {"/scene/kind"}},
      {"more-objects", {"/objects/support", "/objects/attempts"}},
  };
  for (size_t i = 1; i < rows.size(); ++i) {
    SCOPED_TRACE(rows[i - 1].first + " -> " + rows[i].first);
    EXPECT_EQ(DifferingKnobs(Preset(rows[i - 1].first), Preset(rows[i].first)), rows[i].second);
  }
}

TEST(Presets, KeepThe41DefaultsOfEveryKnobTable42DoesNotName) {
  const LayoutParams defaults;
  const std::set<std::string> table_knobs = {
      "/scene/kind", "/objects/support", "/objects/scale", "/objects/rotation_axes", "/placement/occlude_prob",
      "/placement/cluster_prob", "/camera/height_m", "/camera/look_z_m", "/objects/attempts", "/render/resolution"};
  for (const std::string& name : PresetNames()) {
    SCOPED_TRACE(name);
    for (const std::string& knob : DifferingKnobs(Preset(name), defaults)) {
      EXPECT_TRUE(table_knobs.contains(knob)) << knob;
    }
  }
}

TEST(ParamsSchema, DefaultsMatchTheLayoutParamsDefaults) {
  const nlohmann::json schema = EmbeddedJson("params.schema.json");
  const std::map<std::string, nlohmann::json> defaults = Knobs(LayoutParams{});
  size_t documented = 0;
  for (const auto& [section, section_schema] : schema["properties"].items()) {
    if (!section_schema.contains("properties")) continue;
    for (const auto& [key, knob_schema] : section_schema["properties"].items()) {
      const std::string pointer = "/" + section + "/" + key;
      SCOPED_TRACE(pointer);
      if (pointer == "/render/scale_classes_at") {
        // Absent by default: the classes then follow the resolution, whatever it is set to.
        EXPECT_FALSE(defaults.contains(pointer));
        EXPECT_FALSE(knob_schema.contains("default"));
        continue;
      }
      ASSERT_TRUE(defaults.contains(pointer));
      ASSERT_TRUE(knob_schema.contains("default"));
      EXPECT_TRUE(knob_schema.contains("description"));
      EXPECT_EQ(knob_schema["default"], defaults.at(pointer));
      ++documented;
    }
  }
  EXPECT_EQ(documented, defaults.size());
}

TEST(ParseParams, EmptyDocumentGivesThe41Defaults) {
  Result<LayoutParams> params = Parse("{}");
  ASSERT_TRUE(params.ok()) << params.status().ToString();
  EXPECT_EQ(*params, LayoutParams{});
}

TEST(ParseParams, PresetWithOverridesKeepsThePresetsOtherValues) {
  Result<LayoutParams> params = Parse(R"({
    "preset": "occlusion",
    "placement": {"occlude_prob": 0.25},
    "camera": {"ring_m": [4, 5.5]},
    "objects": {"scale": {"law": "mixture", "buckets": [{"range_m": [0.2, 0.5], "p": 1}]}},
    "render": {"resolution": [640, 480]}
  })");
  ASSERT_TRUE(params.ok()) << params.status().ToString();
  LayoutParams expected = Preset("occlusion");
  expected.occlude_prob = 0.25;
  expected.camera_ring_m = {4, 5.5};
  expected.scale = {true, {{{0.2, 0.5}, 1.0}}};
  expected.width = 640;
  expected.height = 480;
  EXPECT_EQ(*params, expected);
  // Untouched knobs of the same sections still come from the preset, not the defaults.
  EXPECT_EQ(params->cluster_prob, 1.0);
  EXPECT_EQ(params->camera_height_m, (Interval{0.1, 2.0}));
  EXPECT_EQ(params->support, Support::kFloor);
}

TEST(ParseParams, AScaleLawReplacesThePresetsLawAsAWhole) {
  Result<LayoutParams> params =
      Parse(R"({"preset": "more-objects", "objects": {"scale": {"law": "uniform", "range_m": [0.5, 1]}}})");
  ASSERT_TRUE(params.ok()) << params.status().ToString();
  EXPECT_EQ(params->scale, (ScaleLaw{false, {{{0.5, 1.0}, 1.0}}}));
}

TEST(ParseParams, DoublesRoundTripBitForBitThroughText) {
  LayoutParams p;
  p.camera_ring_m = {0.1 + 0.2, 1.0 / 3.0 + 5};
  p.occlude_prob = std::nextafter(0.7, 1.0);
  p.scale.buckets = {{{0.1, 1.0}, 0.1}, {{1.0, 2.0}, 0.2}, {{2.0, 3.0}, 0.7}};
  p.attempts = {9.5, 11.25};
  ASSERT_OK(CheckParams(p, "p"));
  Result<LayoutParams> again = Parse(ParamsToJson(p).dump());
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  EXPECT_EQ(*again, p);
}

TEST(ParseParams, UnknownKeyIsAnErrorWithItsPointerAndLine) {
  Result<LayoutParams> params = Parse(R"({
  "camera": {
    "ring": [3.6, 6.0]
  }
})");
  ASSERT_FALSE(params.ok());
  EXPECT_EQ(params.status().code(), StatusCode::kParseError);
  EXPECT_THAT(params.status().message(), HasSubstr("params.json:3: /camera/ring: unknown key \"ring\""));
  EXPECT_THAT(params.status().message(), HasSubstr("ring_m"));  // the suggestion
}

TEST(ParseParams, UnknownTopLevelSectionIsAnError) {
  Result<LayoutParams> params = Parse(R"({"lights": {}})");
  ASSERT_FALSE(params.ok());
  EXPECT_THAT(params.status().message(), HasSubstr("params.json:1: /lights: unknown key \"lights\""));
}

TEST(ParseParams, WrongTypeIsAnErrorNamingTheKnob) {
  Result<LayoutParams> params = Parse("{\n\"grid\": {\"points_per_axis\": \"many\"}}");
  ASSERT_FALSE(params.ok());
  EXPECT_EQ(params.status().code(), StatusCode::kParseError);
  EXPECT_THAT(params.status().message(), HasSubstr("params.json:2: /grid/points_per_axis: expected integer"));
}

TEST(ParseParams, OutOfRangeValuesAreErrorsNamingTheKnob) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"camera": {"hfov_deg": 179}})", "/camera/hfov_deg"},
      {R"({"camera": {"near_m": 0}})", "/camera/near_m"},
      {R"({"camera": {"height_m": [-1, 2]}})", "/camera/height_m/0"},
      {R"({"placement": {"occlude_prob": 1.5}})", "/placement/occlude_prob"},
      {R"({"placement": {"max_proposals": 0}})", "/placement/max_proposals"},
      {R"({"placement": {"max_proposals": 10000001}})", "/placement/max_proposals"},
      {R"({"grid": {"points_per_axis": 1}})", "/grid/points_per_axis"},
      {R"({"grid": {"points_per_axis": 1025}})", "/grid/points_per_axis"},
      {R"({"render": {"resolution": [8, 240]}})", "/render/resolution/0"},
      {R"({"render": {"resolution": [320, 240, 3]}})", "/render/resolution"},
      {R"({"objects": {"attempts": [-1, 5]}})", "/objects/attempts/0"},
      {R"({"objects": {"max_pose_tries": 2.5}})", "/objects/max_pose_tries"},
      {R"({"objects": {"rotation_axes": "xy"}})", "/objects/rotation_axes"},
      {R"({"objects": {"scale": {"law": "uniform", "range_m": [0, 1]}}})", "/objects/scale/range_m/0"},
      {R"({"objects": {"scale": {"law": "mixture", "buckets": [{"range_m": [1, 2], "p": -0.5}]}}})",
       "/objects/scale/buckets/0/p"},
  };
  for (const auto& [text, pointer] : cases) {
    SCOPED_TRACE(text);
    Result<LayoutParams> params = Parse(text);
    ASSERT_FALSE(params.ok());
    EXPECT_EQ(params.status().code(), StatusCode::kParseError);
    EXPECT_THAT(params.status().message(), HasSubstr("params.json:1: " + pointer + ": "));
  }
}

TEST(ParseParams, ScaleLawMustNotMixUniformAndMixtureKeys) {
  Result<LayoutParams> params = Parse(R"({"objects": {"scale": {"law": "uniform", "range_m": [1, 2],
      "buckets": [{"range_m": [1, 2], "p": 1}]}}})");
  ASSERT_FALSE(params.ok());
  EXPECT_THAT(params.status().message(), HasSubstr("/objects/scale/buckets: no value is allowed here"));
  Result<LayoutParams> missing = Parse(R"({"objects": {"scale": {"law": "mixture"}}})");
  ASSERT_FALSE(missing.ok());
  EXPECT_THAT(missing.status().message(), HasSubstr("/objects/scale: missing required key \"buckets\""));
}

TEST(ParseParams, MixtureProbabilitiesNotSummingToOneAreAnErrorSayingWhich) {
  Result<LayoutParams> params = Parse(R"({"objects": {"scale": {"law": "mixture",
  "buckets": [{"range_m": [0.1, 1], "p": 0.7}, {"range_m": [1, 2], "p": 0.1}, {"range_m": [2, 3], "p": 0.1}]}}})");
  ASSERT_FALSE(params.ok());
  EXPECT_EQ(params.status().code(), StatusCode::kParseError);
  EXPECT_THAT(params.status().message(),
              HasSubstr("params.json:2: objects.scale.buckets: bucket probabilities 0.7 + 0.1 + 0.1 sum to"));
  EXPECT_THAT(params.status().message(), HasSubstr(", not 1"));
}

TEST(ParseParams, ReversedIntervalIsAnErrorNamingTheKnob) {
  Result<LayoutParams> params = Parse("{\"camera\": {\n  \"height_m\": [2, 1]}}");
  ASSERT_FALSE(params.ok());
  EXPECT_EQ(params.status().message(), "params.json:2: camera.height_m: lower bound 2 exceeds upper bound 1");
}

TEST(ParseParams, CameraRingOutsideTheGridIsAnError) {
  Result<LayoutParams> params = Parse(R"({"grid": {"extent_m": [8, 10, 12]}})");
  ASSERT_FALSE(params.ok());
  EXPECT_THAT(params.status().message(),
              HasSubstr("params.json: camera.ring_m: upper bound 6 exceeds half the smaller horizontal "
                        "grid.extent_m (4)"));
}

TEST(ParseParams, UnknownPresetNameListsTheValidNames) {
  Result<LayoutParams> params = Parse(R"({"preset": "occlusions"})");
  ASSERT_FALSE(params.ok());
  EXPECT_THAT(params.status().message(), HasSubstr("params.json:1: /preset: \"occlusions\" is not one of"));
  for (const std::string& name : PresetNames()) EXPECT_THAT(params.status().message(), HasSubstr(name));
}

TEST(ParseParams, ReportsOnlyTheFirstFewViolations) {
  std::string text = "{\n";
  for (int i = 0; i < 10; ++i) text += "\"unknown" + std::to_string(i) + "\": 1,\n";
  text += "\"scene\": {}\n}";
  Result<LayoutParams> params = Parse(text);
  ASSERT_FALSE(params.ok());
  EXPECT_THAT(params.status().message(), HasSubstr("params.json:2: /unknown0: unknown key"));
  EXPECT_THAT(params.status().message(), HasSubstr("params.json: ... and 5 more"));
  EXPECT_THAT(params.status().message(), Not(HasSubstr("unknown9")));
}

TEST(LoadPreset, UnknownNameIsNotFoundAndListsTheValidNames) {
  Result<LayoutParams> params = LoadPreset("white-cube");
  ASSERT_FALSE(params.ok());
  EXPECT_EQ(params.status().code(), StatusCode::kNotFound);
  EXPECT_THAT(params.status().message(), HasSubstr("unknown preset \"white-cube\""));
  for (const std::string& name : PresetNames()) EXPECT_THAT(params.status().message(), HasSubstr(name));
}

TEST(LoadParamsFile, ReadsAPresetWithOverridesFromDisk) {
  testing::TempDir dir;
  const std::filesystem::path path = dir.path() / "indoor.json";
  std::ofstream(path) << R"({"preset": "scenenet-background", "objects": {"attempts": [12, 14]}})";
  Result<LayoutParams> params = LoadParamsFile(path);
  ASSERT_TRUE(params.ok()) << params.status().ToString();
  LayoutParams expected = Preset("scenenet-background");
  expected.attempts = {12, 14};
  EXPECT_EQ(*params, expected);
}

TEST(LoadParamsFile, ErrorsNameTheFileAndLine) {
  testing::TempDir dir;
  const std::filesystem::path path = dir.path() / "indoor.json";
  std::ofstream(path) << "{\n  \"objects\": {\n    \"min_objets\": 3\n  }\n}\n";
  Result<LayoutParams> params = LoadParamsFile(path);
  ASSERT_FALSE(params.ok());
  EXPECT_THAT(params.status().message(), HasSubstr(path.string() + ":3: /objects/min_objets: unknown key"));
}

TEST(LoadParamsFile, MissingFileNamesThePath) {
  testing::TempDir dir;
  const std::filesystem::path path = dir.path() / "absent.json";
  Result<LayoutParams> params = LoadParamsFile(path);
  ASSERT_FALSE(params.ok());
  EXPECT_EQ(params.status().code(), StatusCode::kNotFound);
  EXPECT_THAT(params.status().message(), HasSubstr(path.string()));
}

TEST(LoadParamsFile, FileOverOneMebibyteIsRefused) {
  testing::TempDir dir;
  const std::filesystem::path path = dir.path() / "huge.json";
  std::ofstream(path) << "{\"$comment\": \"" << std::string(size_t{1} << 20, 'x') << "\"}";
  Result<LayoutParams> params = LoadParamsFile(path);
  ASSERT_FALSE(params.ok());
  EXPECT_EQ(params.status().code(), StatusCode::kLimitExceeded);
  EXPECT_THAT(params.status().message(), HasSubstr(path.string()));
}

TEST(LoadParamsFile, SyntaxErrorNamesTheFileAndLine) {
  testing::TempDir dir;
  const std::filesystem::path path = dir.path() / "broken.json";
  std::ofstream(path) << "{\n  \"scene\": {\"kind\": \"rooms\",}\n}\n";
  Result<LayoutParams> params = LoadParamsFile(path);
  ASSERT_FALSE(params.ok());
  EXPECT_EQ(params.status().code(), StatusCode::kParseError);
  EXPECT_THAT(params.status().message(), HasSubstr(path.string() + ":2:"));
}

TEST(CheckParams, AcceptsTheDefaults) { EXPECT_OK(CheckParams(LayoutParams{}, "defaults")); }

TEST(CheckParams, NamesTheKnobOfEachBrokenRule) {
  const std::vector<std::pair<std::function<void(LayoutParams&)>, std::string>> cases = {
      {[](LayoutParams& p) { p.camera_ring_m = {7, 6}; }, "p: camera.ring_m: lower bound 7 exceeds upper bound 6"},
      {[](LayoutParams& p) { p.camera_ring_m = {3, 6.5}; }, "p: camera.ring_m: upper bound 6.5 exceeds half"},
      {[](LayoutParams& p) { p.camera_height_m = {-0.5, 2}; },
       "p: camera.height_m: lower bound -0.5 is less than the minimum 0"},
      {[](LayoutParams& p) { p.attempts = {-1, 3}; }, "p: objects.attempts: lower bound -1 is less than the minimum 0"},
      {[](LayoutParams& p) { p.camera_near_m = 0; }, "p: camera.near_m: 0 is not greater than 0"},
      {[](LayoutParams& p) { p.camera_hfov_deg = std::numeric_limits<double>::quiet_NaN(); },
       "p: camera.hfov_deg: nan is not a finite number"},
      {[](LayoutParams& p) { p.grid_extent_m[2] = 0; }, "p: grid.extent_m[2]: 0 is not greater than 0"},
      {[](LayoutParams& p) { p.max_proposals = 0; }, "p: placement.max_proposals: 0 is less than the minimum 1"},
      {[](LayoutParams& p) { p.width = 10000; }, "p: render.resolution[0]: 10000 is greater than the maximum 8192"},
      {[](LayoutParams& p) { p.support = static_cast<Support>(7); }, "p: objects.support: 7 is not a valid value"},
      {[](LayoutParams& p) { p.scale.buckets[1].probability = -0.1; },
       "p: objects.scale.buckets[1].p: -0.1 is less than the minimum 0"},
      {[](LayoutParams& p) { p.scale.buckets[2].size_m = {0, 3}; },
       "p: objects.scale.buckets[2].range_m: lower bound 0 is not greater than 0"},
      {[](LayoutParams& p) { p.scale.buckets[0].probability = 0.6; },
       "p: objects.scale.buckets: bucket probabilities 0.6 + 0.1 + 0.2 sum to"},
      {[](LayoutParams& p) { p.scale.buckets.clear(); },
       "p: objects.scale.buckets: a mixture has 1 to 64 buckets, not 0"},
      {[](LayoutParams& p) { p.scale.mixture = false; },
       "p: objects.scale: a uniform law is one bucket with probability 1, not 3 bucket(s)"},
      {[](LayoutParams& p) { p.scale = {false, {{{0.4, 2.0}, 0.5}}}; },
       "p: objects.scale: a uniform law is one bucket with probability 1"},
      {[](LayoutParams& p) { p.scale = {false, {{{2.0, 0.4}, 1.0}}}; },
       "p: objects.scale.range_m: lower bound 2 exceeds upper bound 0.4"},
  };
  for (const auto& [mutate, message] : cases) {
    SCOPED_TRACE(message);
    LayoutParams params;
    mutate(params);
    const Status status = CheckParams(params, "p");
    ASSERT_FALSE(status.ok());
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(status.message(), HasSubstr(message));
  }
}

TEST(CheckParams, MixtureProbabilitiesWithinOneBillionthOfOnePass) {
  LayoutParams params;
  params.scale.buckets[0].probability = 0.7 + 5e-10;
  EXPECT_OK(CheckParams(params, "p"));
  params.scale.buckets[0].probability = 0.7 + 2e-9;
  EXPECT_FALSE(CheckParams(params, "p").ok());
}

// The bounds of CheckParams repeat the schema's: at each bound both accept, just past it both
// refuse, so ParamsToJson's output parses back exactly when CheckParams passes.
TEST(CheckParams, AgreesWithTheSchemaAtTheBounds) {
  const std::vector<std::function<void(LayoutParams&)>> accepted = {
      [](LayoutParams& p) { p.camera_hfov_deg = std::nextafter(179.0, 0.0); },
      [](LayoutParams& p) { p.camera_hfov_deg = std::nextafter(1.0, 2.0); },
      [](LayoutParams& p) { p.frustum_inset = 1; },
      [](LayoutParams& p) { p.grid_points_per_axis = 2; },
      [](LayoutParams& p) { p.grid_points_per_axis = 1024; },
      [](LayoutParams& p) {
        p.width = 16;
        p.height = 8192;
      },
      [](LayoutParams& p) { p.max_proposals = 10000000; },
      [](LayoutParams& p) { p.max_scene_restarts = 0; },
      [](LayoutParams& p) { p.min_visible_pixels = 8192 * 8192; },
      [](LayoutParams& p) { p.camera_look_z_m = {-1000, 1000}; },
      [](LayoutParams& p) { p.attempts = {0, 0}; },
      [](LayoutParams& p) { p.camera_clearance_rays = 2; },
  };
  const std::vector<std::function<void(LayoutParams&)>> refused = {
      [](LayoutParams& p) { p.camera_hfov_deg = 179; },
      [](LayoutParams& p) { p.camera_hfov_deg = 1; },
      [](LayoutParams& p) { p.frustum_inset = 0; },
      [](LayoutParams& p) { p.grid_points_per_axis = 1; },
      [](LayoutParams& p) { p.grid_points_per_axis = 1025; },
      [](LayoutParams& p) { p.height = 15; },
      [](LayoutParams& p) { p.max_proposals = 10000001; },
      [](LayoutParams& p) { p.max_scene_restarts = -1; },
      [](LayoutParams& p) { p.min_visible_pixels = 0; },
      [](LayoutParams& p) { p.camera_look_z_m = {-1000.5, 1000}; },
      [](LayoutParams& p) { p.attempts = {0, 10000.5}; },
      [](LayoutParams& p) { p.camera_clearance_rays = 1; },
      [](LayoutParams& p) { p.reuse_prob = std::nextafter(1.0, 2.0); },
      [](LayoutParams& p) { p.room_size_m[1] = 0; },
  };
  for (size_t i = 0; i < accepted.size(); ++i) {
    SCOPED_TRACE("accepted case " + std::to_string(i));
    LayoutParams params;
    accepted[i](params);
    EXPECT_OK(CheckParams(params, "p"));
    Result<LayoutParams> again = ParseParams(ParamsToJson(params), "", "p");
    ASSERT_TRUE(again.ok()) << again.status().ToString();
    EXPECT_EQ(*again, params);
  }
  for (size_t i = 0; i < refused.size(); ++i) {
    SCOPED_TRACE("refused case " + std::to_string(i));
    LayoutParams params;
    refused[i](params);
    EXPECT_FALSE(CheckParams(params, "p").ok());
    Result<LayoutParams> again = ParseParams(ParamsToJson(params), "", "p");
    ASSERT_FALSE(again.ok());
    EXPECT_THAT(again.status().message(), HasSubstr("p: /"));  // refused by the schema itself
  }
}

TEST(ResolveParams, AppliesTheOverridesToTheFileOrPresetAndNamesWrongFields) {
  testing::TempDir dir;
  Result<LayoutParams> p = ResolveParams({.preset = "occlusion", .resolution = "320x240", .scale_classes_at = "640x480"});
  ASSERT_OK(p.status());
  LayoutParams expected = LoadPreset("occlusion").value();
  expected.width = 320;
  expected.height = 240;
  expected.scale_width = 640;
  expected.scale_height = 480;
  EXPECT_EQ(*p, expected);

  const std::filesystem::path file = dir.path() / "params.json";
  std::ofstream(file) << R"({"preset": "rotation", "render": {"resolution": [160, 120]}})";
  p = ResolveParams({.params = file});
  ASSERT_OK(p.status());
  EXPECT_EQ(p->width, 160);
  EXPECT_EQ(p->scene, LoadPreset("rotation")->scene);

  EXPECT_EQ(ResolveParams({}).status().option(), "params");
  EXPECT_EQ(ResolveParams({.params = file, .preset = "occlusion"}).status().option(), "params");
  EXPECT_EQ(ResolveParams({.preset = "nope"}).status().code(), StatusCode::kNotFound) << "as --preset nope, exit 3";
  const Status resolution = ResolveParams({.preset = "occlusion", .resolution = "8193x48"}).status();
  EXPECT_EQ(resolution.option(), "resolution");
  EXPECT_EQ(resolution.message(), "resolution: 8193x48: expected WIDTHxHEIGHT, each 16..8192");
  EXPECT_EQ(ResolveParams({.preset = "occlusion", .scale_classes_at = "640x"}).status().option(), "scale_classes_at");
}

}  // namespace
}  // namespace solid::render
