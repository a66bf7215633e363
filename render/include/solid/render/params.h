// Layout parameters: every knob of the layout sampler and the mask pass
// (docs solid-method.md 4.1), their JSON form (schemas/params.schema.json) and the
// six presets of the paper's Table 1 (schemas/presets/*.json).
//
// JSON form: nested objects named like the knobs ("camera": {"ring_m": [3.6, 6.0]}).
// A params file may start from a preset with "preset": "occlusion" and override
// any knob; keys it omits keep the preset's value (or the 4.1 default without a
// preset). Unknown keys, wrong types and values out of range are errors that name
// the file, the line and the JSON Pointer of the value.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/status.h"

namespace solid::render {

// A closed interval [lo, hi].
struct Interval {
  double lo = 0, hi = 0;
  friend bool operator==(const Interval&, const Interval&) = default;
};

enum class SceneKind {
  kWhiteCube,  // 12 x 12 m grey floor inside a 12 x 12 x 24 m grey cube whose top face is the ceiling
  kRooms,      // room shells (walls, floors, ceilings) of the rooms directory, rescaled to room_size_m
};
enum class RotationAxes { kZ, kXyz };
enum class Support { kFloor, kFloating };
enum class OcclusionTest {
  kRayObb,  // the half-line from the camera through the centre crosses a placed object's box
  kBox2d,   // the centre projects inside a placed object's projected 2D box
};
enum class OccludeSide { kAny, kFront, kBehind };

struct ScaleBucket {
  Interval size_m;
  double probability = 0;
  friend bool operator==(const ScaleBucket&, const ScaleBucket&) = default;
};

// The law of s, the largest local bounding-box extent of a placed object, metres.
// Uniform is a mixture of one bucket with probability 1.
struct ScaleLaw {
  bool mixture = true;  // false: "uniform" over buckets[0].size_m
  std::vector<ScaleBucket> buckets = {{{0.1, 1.0}, 0.7}, {{1.0, 2.0}, 0.1}, {{2.0, 3.0}, 0.2}};
  friend bool operator==(const ScaleLaw&, const ScaleLaw&) = default;
};

struct LayoutParams {
  // scene
  SceneKind scene = SceneKind::kRooms;
  std::array<double, 3> room_size_m = {12, 12, 6};  // rooms are scaled non-uniformly to exactly this

  // grid: candidate object centres are lattice points over
  // [-extent_x/2, extent_x/2] x [-extent_y/2, extent_y/2] x [0, extent_z]
  int grid_points_per_axis = 144;
  std::array<double, 3> grid_extent_m = {12, 12, 12};

  // camera
  Interval camera_ring_m = {3.6, 6.0};    // horizontal distance of the camera column from (0, 0)
  Interval camera_height_m = {0.1, 2.0};  // z; the lower bound is also >= floor + 0.001
  Interval camera_look_xy_m = {-2, 2};    // look-at x and y
  Interval camera_look_z_m = {0.1, 2.1};  // look-at z, absolute
  double camera_hfov_deg = 39.6;
  double camera_near_m = 0.1;
  double camera_clearance_m = 4.0;  // rooms: redraw when a wall is this close along a test ray
  int camera_clearance_rays = 10;   // per image axis, corners included
  int camera_max_draws = 1000;

  // objects
  Interval attempts = {20, 25};  // N = floor(U(lo, hi + 1)): U{lo..hi} for integers, relaxed to reals
  double reuse_prob = 0.5;       // repeat the previous attempt's model
  int max_pose_tries = 5;        // rotation and size redraws per attempt
  ScaleLaw scale;
  RotationAxes rotation_axes = RotationAxes::kXyz;
  Support support = Support::kFloating;

  // placement
  double min_hdist_m = 2.0;     // horizontal camera distance of the centre
  double frustum_inset = 0.9;   // the centre projects inside this share of each image axis
  double cluster_prob = 1.0;    // near an earlier object ...
  double cluster_margin_m = 1.0;  // ... within its half diagonal plus this
  double occlude_prob = 0.7;    // in front of or behind an earlier object
  double depth_by_size_prob = 0.5;  // within the occlusion branch: larger objects farther away
  OcclusionTest occlusion_test = OcclusionTest::kRayObb;
  OccludeSide occlude_side = OccludeSide::kAny;
  int max_proposals = 4000;  // rejection-sampling budget of one pose try (see layout.h)

  // sampling
  int max_scene_restarts = 20;  // an empty layout or image restarts the scene on a derived stream

  // render
  int width = 640, height = 480;
  int min_visible_pixels = 1;  // an object with fewer visible pixels is not counted or annotated
  // COCO's scale classes counted as at this resolution (0 x 0: at width x height): the
  // areas are scaled by the pixel-count ratio before the 32^2 / 96^2 thresholds, so a
  // dataset rendered at 320x240 can be classed as Table 1's 640x480 areas (solid-method.md
  // 4.2, "Resolution"). Written to JSON only when set.
  int scale_width = 0, scale_height = 0;

  friend bool operator==(const LayoutParams&, const LayoutParams&) = default;
};

// Parses a params document (already parsed JSON; `text` is the source text, used
// only to turn JSON Pointers into line numbers in messages, and may be empty).
// `source` names the document in messages ("params.json", "preset occlusion"). A document
// that breaks the schema or a rule is bad input: kParseError, one line per problem.
Result<LayoutParams> ParseParams(const nlohmann::json& document, std::string_view text, std::string_view source);

// Reads and parses a params file (untrusted: size and depth limits apply).
Result<LayoutParams> LoadParamsFile(const std::filesystem::path& path);

// The embedded preset `name` (see PresetNames); kNotFound lists the valid names.
Result<LayoutParams> LoadPreset(std::string_view name);

// "random-placement", "occlusion", "scale-distribution", "rotation",
// "scenenet-background", "more-objects", in Table 1 order.
const std::vector<std::string>& PresetNames();

// Every knob, explicitly, in the JSON form: ParseParams(ParamsToJson(p)) == p.
// Used for manifests and optimizer outputs, and hashed for provenance.
nlohmann::json ParamsToJson(const LayoutParams& params);

// The resolution at which COCO's scale classes are counted: scale_classes_at when set,
// else the render resolution.
std::pair<int, int> ScaleClassResolution(const LayoutParams& params);

// How many times more pixels the scale-class resolution has than `width` x `height`: an
// area measured at that size is classed as area * this (MetricsAccumulator, SetInstanceMasks).
double ScaleClassAreaScale(const LayoutParams& params, int width, int height);

// "640x480", or "640x480 (scale_classes_at; rendered at 320x240)": what reports print.
std::string ScaleClassDescription(const LayoutParams& params);

// Where a command's params come from: a params file or a preset (exactly one), with the
// render resolution and the scale-class resolution optionally overridden. Shared by
// sample, render and optimize, so that the three read params alike.
struct ParamsSource {
  std::filesystem::path params;  // a params file
  std::string preset;            // a preset name (PresetNames)
  std::string resolution;        // "WIDTHxHEIGHT"; empty: the params'
  std::string scale_classes_at;  // "WIDTHxHEIGHT"; empty: the params' render.scale_classes_at
};

// The params of `source`. OptionError "params" when neither or both of params and preset
// are given, "resolution" or "scale_classes_at" when malformed; a params file's own errors
// as LoadParamsFile, an unknown preset as LoadPreset.
Result<LayoutParams> ResolveParams(const ParamsSource& source);

// "WIDTHxHEIGHT", each side within the range the params schema allows for a resolution;
// otherwise OptionError(field, ...).
Result<std::pair<int, int>> ParseResolution(std::string_view field, std::string_view text);

// Checks the semantic rules the schema cannot express (intervals ordered, bucket
// probabilities summing to 1, a camera ring that fits the grid, ...). `source`
// prefixes messages; each message names the knob.
Status CheckParams(const LayoutParams& params, std::string_view source);

}  // namespace solid::render
