#include "solid/render/params.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <span>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "solid/formats/files.h"
#include "solid/formats/json_schema.h"
#include "solid/formats/records.h"
#include "solid/formats/schemas.h"

namespace solid::render {
namespace {

constexpr uint64_t kMaxParamsBytes = uint64_t{1} << 20;
// A params document nests six containers deep (root, objects, scale, buckets, a bucket, its
// range); anything much deeper is not a params file.
constexpr int kMaxParamsDepth = 16;
constexpr size_t kMaxReportedProblems = 5;
constexpr double kProbabilitySumTolerance = 1e-9;
// As "maxItems" of objects.scale.buckets in the schema.
constexpr size_t kMaxScaleBuckets = 64;

// The enum values' names in the JSON form, as the schema's "enum"s spell them.
template <typename E>
using EnumNames = std::span<const std::pair<E, std::string_view>>;

constexpr std::pair<SceneKind, std::string_view> kSceneKinds[] = {{SceneKind::kWhiteCube, "white_cube"},
                                                                  {SceneKind::kRooms, "rooms"}};
constexpr std::pair<RotationAxes, std::string_view> kRotationAxes[] = {{RotationAxes::kZ, "z"},
                                                                       {RotationAxes::kXyz, "xyz"}};
constexpr std::pair<Support, std::string_view> kSupports[] = {{Support::kFloor, "floor"},
                                                              {Support::kFloating, "floating"}};
constexpr std::pair<OcclusionTest, std::string_view> kOcclusionTests[] = {{OcclusionTest::kRayObb, "ray_obb"},
                                                                          {OcclusionTest::kBox2d, "box2d"}};
constexpr std::pair<OccludeSide, std::string_view> kOccludeSides[] = {
    {OccludeSide::kAny, "any"}, {OccludeSide::kFront, "front"}, {OccludeSide::kBehind, "behind"}};

EnumNames<SceneKind> NamesOf(SceneKind) { return kSceneKinds; }
EnumNames<RotationAxes> NamesOf(RotationAxes) { return kRotationAxes; }
EnumNames<Support> NamesOf(Support) { return kSupports; }
EnumNames<OcclusionTest> NamesOf(OcclusionTest) { return kOcclusionTests; }
EnumNames<OccludeSide> NamesOf(OccludeSide) { return kOccludeSides; }

template <typename E>
std::optional<std::string_view> NameOf(E value) {
  for (const auto& [e, name] : NamesOf(value)) {
    if (e == value) return name;
  }
  return std::nullopt;  // a value cast from an integer outside the enum
}

// The range of a knob's values (of each end of an interval, of each element of an array). The
// numbers repeat schemas/params.schema.json, so that params passing CheckParams also pass the
// schema and ParamsToJson's output always parses back.
struct Bounds {
  double min = 0, max = 0;
  bool exclusive_min = false, exclusive_max = false;
};
constexpr Bounds kProbability{0, 1};
constexpr Bounds kNonNegativeM{0, 1000};
constexpr Bounds kPositiveM{0, 1000, true};
constexpr Bounds kSignedM{-1000, 1000};

// Marks a knob that is absent from the JSON form while it is zero (its default means "as
// another knob": scale_classes_at follows the resolution).
struct UnsetIsZero {};
constexpr UnsetIsZero kUnsetIsZero;

// Every knob once, by its JSON Pointer, so that reading, writing and checking cannot drift
// apart. `Params` is LayoutParams or const LayoutParams.
template <typename Params, typename Visitor>
void ForEachKnob(Params& p, Visitor&& visit) {
  visit("/scene/kind", p.scene);
  visit("/scene/room_size_m", p.room_size_m, kPositiveM);
  visit("/grid/points_per_axis", p.grid_points_per_axis, Bounds{2, 1024});
  visit("/grid/extent_m", p.grid_extent_m, kPositiveM);
  visit("/camera/ring_m", p.camera_ring_m, kNonNegativeM);
  visit("/camera/height_m", p.camera_height_m, kNonNegativeM);
  visit("/camera/look_xy_m", p.camera_look_xy_m, kSignedM);
  visit("/camera/look_z_m", p.camera_look_z_m, kSignedM);
  visit("/camera/hfov_deg", p.camera_hfov_deg, Bounds{1, 179, true, true});
  visit("/camera/near_m", p.camera_near_m, kPositiveM);
  visit("/camera/clearance_m", p.camera_clearance_m, kNonNegativeM);
  visit("/camera/clearance_rays", p.camera_clearance_rays, Bounds{2, 1024});
  visit("/camera/max_draws", p.camera_max_draws, Bounds{1, 1e7});
  visit("/objects/attempts", p.attempts, Bounds{0, kMaxInstancesPerImage});
  visit("/objects/reuse_prob", p.reuse_prob, kProbability);
  visit("/objects/max_pose_tries", p.max_pose_tries, Bounds{1, 1000});
  visit("/objects/scale", p.scale);
  visit("/objects/rotation_axes", p.rotation_axes);
  visit("/objects/support", p.support);
  visit("/placement/min_hdist_m", p.min_hdist_m, kNonNegativeM);
  visit("/placement/frustum_inset", p.frustum_inset, Bounds{0, 1, true});
  visit("/placement/cluster_prob", p.cluster_prob, kProbability);
  visit("/placement/cluster_margin_m", p.cluster_margin_m, kNonNegativeM);
  visit("/placement/occlude_prob", p.occlude_prob, kProbability);
  visit("/placement/depth_by_size_prob", p.depth_by_size_prob, kProbability);
  visit("/placement/occlusion_test", p.occlusion_test);
  visit("/placement/occlude_side", p.occlude_side);
  visit("/placement/max_proposals", p.max_proposals, Bounds{1, 1e7});
  visit("/sampling/max_scene_restarts", p.max_scene_restarts, Bounds{0, 100000});
  visit("/render/resolution", std::tie(p.width, p.height), Bounds{16, 8192});
  visit("/render/min_visible_pixels", p.min_visible_pixels, Bounds{1, 8192.0 * 8192.0});
  visit("/render/scale_classes_at", std::tie(p.scale_width, p.scale_height), Bounds{16, 8192}, kUnsetIsZero);
}

nlohmann::json IntervalToJson(const Interval& v) { return nlohmann::json::array({v.lo, v.hi}); }

Interval IntervalFromJson(const nlohmann::json& v) { return {v[0].get<double>(), v[1].get<double>()}; }

// Sets the knobs present in a document that passed the schema, so types and ranges hold.
struct Reader {
  const nlohmann::json& document;

  template <typename T, typename... Ignored>
  void operator()(std::string_view pointer, T&& value, const Ignored&...) const {
    const nlohmann::json::json_pointer at{std::string(pointer)};
    if (document.contains(at)) Read(document.at(at), value);
  }

  static void Read(const nlohmann::json& v, double& out) { out = v.get<double>(); }
  static void Read(const nlohmann::json& v, int& out) { out = v.get<int>(); }
  static void Read(const nlohmann::json& v, Interval& out) { out = IntervalFromJson(v); }
  static void Read(const nlohmann::json& v, std::array<double, 3>& out) {
    for (size_t i = 0; i < out.size(); ++i) out[i] = v[i].get<double>();
  }
  static void Read(const nlohmann::json& v, std::tuple<int&, int&>& out) {
    std::get<0>(out) = v[0].get<int>();
    std::get<1>(out) = v[1].get<int>();
  }
  template <typename E>
    requires std::is_enum_v<E>
  static void Read(const nlohmann::json& v, E& out) {
    const std::string name = v.get<std::string>();
    const auto names = NamesOf(out);
    const auto it = std::find_if(names.begin(), names.end(), [&](const auto& entry) { return entry.second == name; });
    // The schema's "enum" and NamesOf list the same names.
    SOLID_CHECK(it != names.end());
    out = it->first;
  }
  // A law replaces the base's law as a whole: mixing a uniform range with mixture buckets
  // would make no sense.
  static void Read(const nlohmann::json& v, ScaleLaw& out) {
    out.mixture = v.at("law").get<std::string>() == "mixture";
    out.buckets.clear();
    if (!out.mixture) {
      out.buckets.push_back({IntervalFromJson(v.at("range_m")), 1.0});
      return;
    }
    for (const nlohmann::json& bucket : v.at("buckets")) {
      out.buckets.push_back({IntervalFromJson(bucket.at("range_m")), bucket.at("p").get<double>()});
    }
  }
};

struct Writer {
  nlohmann::json& out;

  template <typename T, typename... Ignored>
  void operator()(std::string_view pointer, const T& value, const Ignored&...) const {
    out[nlohmann::json::json_pointer(std::string(pointer))] = ToJson(value);
  }

  void operator()(std::string_view pointer, const std::tuple<const int&, const int&>& value, const Bounds&,
                  UnsetIsZero) const {
    if (std::get<0>(value) != 0 || std::get<1>(value) != 0) (*this)(pointer, value);
  }

  static nlohmann::json ToJson(double v) { return v; }
  static nlohmann::json ToJson(int v) { return v; }
  static nlohmann::json ToJson(const Interval& v) { return IntervalToJson(v); }
  static nlohmann::json ToJson(const std::array<double, 3>& v) { return v; }
  static nlohmann::json ToJson(const std::tuple<const int&, const int&>& v) {
    return nlohmann::json::array({std::get<0>(v), std::get<1>(v)});
  }
  // A value cast from an integer outside the enum has no name; null makes ParseParams refuse it.
  template <typename E>
    requires std::is_enum_v<E>
  static nlohmann::json ToJson(E v) {
    const std::optional<std::string_view> name = NameOf(v);
    return name ? nlohmann::json(*name) : nlohmann::json(nullptr);
  }
  static nlohmann::json ToJson(const ScaleLaw& law) {
    if (law.mixture) {
      nlohmann::json buckets = nlohmann::json::array();
      for (const ScaleBucket& b : law.buckets) {
        buckets.push_back(nlohmann::json{{"range_m", IntervalToJson(b.size_m)}, {"p", b.probability}});
      }
      return {{"law", "mixture"}, {"buckets", std::move(buckets)}};
    }
    nlohmann::json uniform = {{"law", "uniform"}};
    if (!law.buckets.empty()) uniform["range_m"] = IntervalToJson(law.buckets[0].size_m);
    return uniform;
  }
};

// Bounds print as written in the schema (1e7 as 10000000); values print exactly.
std::string FormatBound(double v) { return fmt::format("{:.15g}", v); }

// The semantic rules, as violations located by JSON Pointer.
struct Checker {
  std::vector<json::Violation>& problems;

  void Add(std::string pointer, std::string message) const {
    problems.push_back({std::move(pointer), std::move(message)});
  }

  // `what` prefixes the value in messages ("lower bound ").
  template <typename T>
  void InBounds(std::string_view pointer, std::string_view what, T value, const Bounds& b) const {
    const double v = static_cast<double>(value);
    std::string problem;
    // Written so that NaN fails every comparison.
    if (!std::isfinite(v)) {
      problem = "is not a finite number";
    } else if (b.exclusive_min ? !(v > b.min) : !(v >= b.min)) {
      problem = (b.exclusive_min ? "is not greater than " : "is less than the minimum ") + FormatBound(b.min);
    } else if (b.exclusive_max ? !(v < b.max) : !(v <= b.max)) {
      problem = (b.exclusive_max ? "is not less than " : "is greater than the maximum ") + FormatBound(b.max);
    }
    if (!problem.empty()) Add(std::string(pointer), fmt::format("{}{} {}", what, value, problem));
  }

  void CheckInterval(std::string_view pointer, const Interval& v, const Bounds& b) const {
    InBounds(pointer, "lower bound ", v.lo, b);
    InBounds(pointer, "upper bound ", v.hi, b);
    if (v.lo > v.hi) Add(std::string(pointer), fmt::format("lower bound {} exceeds upper bound {}", v.lo, v.hi));
  }

  void operator()(std::string_view pointer, double v, const Bounds& b) const { InBounds(pointer, "", v, b); }
  void operator()(std::string_view pointer, int v, const Bounds& b) const { InBounds(pointer, "", v, b); }
  void operator()(std::string_view pointer, const Interval& v, const Bounds& b) const { CheckInterval(pointer, v, b); }
  void operator()(std::string_view pointer, const std::array<double, 3>& v, const Bounds& b) const {
    for (size_t i = 0; i < v.size(); ++i) InBounds(fmt::format("{}/{}", pointer, i), "", v[i], b);
  }
  void operator()(std::string_view pointer, const std::tuple<const int&, const int&>& v, const Bounds& b) const {
    InBounds(fmt::format("{}/0", pointer), "", std::get<0>(v), b);
    InBounds(fmt::format("{}/1", pointer), "", std::get<1>(v), b);
  }
  void operator()(std::string_view pointer, const std::tuple<const int&, const int&>& v, const Bounds& b,
                  UnsetIsZero) const {
    if (std::get<0>(v) != 0 || std::get<1>(v) != 0) (*this)(pointer, v, b);
  }
  template <typename E>
    requires std::is_enum_v<E>
  void operator()(std::string_view pointer, E v) const {
    if (!NameOf(v)) {
      Add(std::string(pointer), fmt::format("{} is not a valid value", static_cast<std::underlying_type_t<E>>(v)));
    }
  }
  void operator()(std::string_view pointer, const ScaleLaw& law) const {
    if (!law.mixture) {
      if (law.buckets.size() != 1 || law.buckets[0].probability != 1) {
        std::vector<double> probabilities;
        for (const ScaleBucket& bucket : law.buckets) probabilities.push_back(bucket.probability);
        Add(std::string(pointer), fmt::format("a uniform law is one bucket with probability 1, not {} bucket(s) "
                                              "with probabilities [{}]",
                                              law.buckets.size(), fmt::join(probabilities, ", ")));
        return;
      }
      CheckInterval(fmt::format("{}/range_m", pointer), law.buckets[0].size_m, kPositiveM);
      return;
    }
    const std::string buckets = fmt::format("{}/buckets", pointer);
    if (law.buckets.empty() || law.buckets.size() > kMaxScaleBuckets) {
      Add(buckets, fmt::format("a mixture has 1 to {} buckets, not {}", kMaxScaleBuckets, law.buckets.size()));
      return;
    }
    double sum = 0;
    std::vector<double> probabilities;
    for (size_t i = 0; i < law.buckets.size(); ++i) {
      const ScaleBucket& bucket = law.buckets[i];
      CheckInterval(fmt::format("{}/{}/range_m", buckets, i), bucket.size_m, kPositiveM);
      InBounds(fmt::format("{}/{}/p", buckets, i), "", bucket.probability, kProbability);
      sum += bucket.probability;
      probabilities.push_back(bucket.probability);
    }
    if (!(std::abs(sum - 1) <= kProbabilitySumTolerance)) {
      Add(buckets, fmt::format("bucket probabilities {} sum to {}, not 1", fmt::join(probabilities, " + "), sum));
    }
  }
};

std::vector<json::Violation> FindProblems(const LayoutParams& params) {
  std::vector<json::Violation> problems;
  ForEachKnob(params, Checker{problems});
  // The camera column is a lattice column, so the ring must fit inside the grid.
  const double half_grid = std::min(params.grid_extent_m[0], params.grid_extent_m[1]) / 2;
  if (params.camera_ring_m.hi > half_grid) {
    problems.push_back({"/camera/ring_m", fmt::format("upper bound {} exceeds half the smaller horizontal "
                                                      "grid.extent_m ({}), so no lattice column is that far",
                                                      params.camera_ring_m.hi, half_grid)});
  }
  return problems;
}

// "/objects/scale/buckets/1/p" -> "objects.scale.buckets[1].p", the form messages name knobs in.
std::string KnobName(std::string_view pointer) {
  std::string name;
  size_t start = 1;
  while (start <= pointer.size()) {
    const size_t end = std::min(pointer.find('/', start), pointer.size());
    const std::string_view token = pointer.substr(start, end - start);
    if (!token.empty() && std::all_of(token.begin(), token.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      name += fmt::format("[{}]", token);
    } else {
      if (!name.empty()) name += '.';
      name += token;
    }
    start = end + 1;
  }
  return name;
}

enum class Naming { kPointer, kKnob };

// One line per problem, "<source>:<line>: <where>: <message>", the line only where `text`
// has the value. `code`: kParseError for a params file or preset (bad input, exit 3 like
// every other file over a limit), kInvalidArgument for params a caller built.
Status Report(std::string_view source, std::string_view text, const std::vector<json::Violation>& problems,
              Naming naming, StatusCode code) {
  const size_t reported = std::min(problems.size(), kMaxReportedProblems);
  std::vector<std::string> pointers;
  for (size_t i = 0; i < reported; ++i) pointers.push_back(problems[i].pointer);
  const std::vector<size_t> lines =
      text.empty() ? std::vector<size_t>(reported, 0) : json::FindPointerLines(text, pointers);
  std::string message;
  for (size_t i = 0; i < reported; ++i) {
    if (i > 0) message += '\n';
    message += source;
    if (lines[i] != 0) message += fmt::format(":{}", lines[i]);
    if (!problems[i].pointer.empty()) {
      message += ": " + (naming == Naming::kKnob ? KnobName(problems[i].pointer) : problems[i].pointer);
    }
    message += ": " + problems[i].message;
  }
  if (problems.size() > reported) message += fmt::format("\n{}: ... and {} more", source, problems.size() - reported);
  return Status(code, std::move(message));
}

Result<json::Schema> CompileParamsSchema() {
  constexpr std::string_view kName = "schemas/params.schema.json";
  SOLID_ASSIGN_OR_RETURN(std::string_view text, schemas::Get("params.schema.json"));
  SOLID_ASSIGN_OR_RETURN(nlohmann::json document, json::ParseJson(text, kName));
  return json::Schema::Compile(document, kName);
}

Result<const json::Schema*> ParamsSchema() {
  // Compiled once; initialisation of a function-local static is thread-safe, and Schema is
  // immutable afterwards.
  static const Result<json::Schema> schema = CompileParamsSchema();
  if (!schema.ok()) return schema.status();
  return &schema.value();
}

}  // namespace

const std::vector<std::string>& PresetNames() {
  static const std::vector<std::string> names = {"random-placement",    "occlusion",   "scale-distribution",
                                                 "rotation",            "scenenet-background", "more-objects"};
  return names;
}

Result<LayoutParams> ParseParams(const nlohmann::json& document, std::string_view text, std::string_view source) {
  SOLID_ASSIGN_OR_RETURN(const json::Schema* schema, ParamsSchema());
  const std::vector<json::Violation> violations = schema->Validate(document);
  if (!violations.empty()) return Report(source, text, violations, Naming::kPointer, StatusCode::kParseError);
  // The schema guarantees presence and types from here on.
  LayoutParams params;
  if (const auto preset = document.find("preset"); preset != document.end()) {
    SOLID_ASSIGN_OR_RETURN(params, LoadPreset(preset->get<std::string>()));
  }
  ForEachKnob(params, Reader{document});
  const std::vector<json::Violation> problems = FindProblems(params);
  if (!problems.empty()) return Report(source, text, problems, Naming::kKnob, StatusCode::kParseError);
  return params;
}

Result<LayoutParams> LoadParamsFile(const std::filesystem::path& path) {
  const std::string source = path.string();
  SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, files::ReadFile(path, kMaxParamsBytes));
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  json::ParseLimits limits;
  limits.max_bytes = kMaxParamsBytes;
  limits.max_depth = kMaxParamsDepth;
  limits.max_string_length = json::kMaxConfigStringBytes;
  SOLID_ASSIGN_OR_RETURN(nlohmann::json document, json::ParseJson(text, source, limits));
  return ParseParams(document, text, source);
}

Result<LayoutParams> LoadPreset(std::string_view name) {
  const std::vector<std::string>& names = PresetNames();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    return NotFoundError(fmt::format("unknown preset \"{}\"; the presets are {}", name, fmt::join(names, ", ")));
  }
  const std::string source = fmt::format("preset {}", name);
  SOLID_ASSIGN_OR_RETURN(std::string_view text, schemas::Get(fmt::format("presets/{}.json", name)));
  SOLID_ASSIGN_OR_RETURN(nlohmann::json document, json::ParseJson(text, source));
  return ParseParams(document, text, source);
}

nlohmann::json ParamsToJson(const LayoutParams& params) {
  nlohmann::json out = nlohmann::json::object();
  ForEachKnob(params, Writer{out});
  return out;
}

std::pair<int, int> ScaleClassResolution(const LayoutParams& params) {
  if (params.scale_width > 0 && params.scale_height > 0) return {params.scale_width, params.scale_height};
  return {params.width, params.height};
}

double ScaleClassAreaScale(const LayoutParams& params, int width, int height) {
  const auto [w, h] = ScaleClassResolution(params);
  return static_cast<double>(w) * h / (static_cast<double>(width) * height);
}

std::string ScaleClassDescription(const LayoutParams& params) {
  const auto [w, h] = ScaleClassResolution(params);
  if (w == params.width && h == params.height) return fmt::format("{}x{}", w, h);
  return fmt::format("{}x{} (scale_classes_at; rendered at {}x{})", w, h, params.width, params.height);
}

Status CheckParams(const LayoutParams& params, std::string_view source) {
  const std::vector<json::Violation> problems = FindProblems(params);
  if (problems.empty()) return Status::Ok();
  return Report(source, {}, problems, Naming::kKnob, StatusCode::kInvalidArgument);
}

Result<std::pair<int, int>> ParseResolution(std::string_view field, std::string_view text) {
  SOLID_ASSIGN_OR_RETURN(const auto side,
                         schemas::IntegerRange("params.schema.json", "/properties/render/properties/resolution/items"));
  const std::string copy(text);
  int w = 0, h = 0;
  char x = 0, rest = 0;
  if (std::sscanf(copy.c_str(), "%d%c%d%c", &w, &x, &h, &rest) != 3 || x != 'x' || w < side.first ||
      h < side.first || w > side.second || h > side.second) {
    return OptionError(field, fmt::format("{}: expected WIDTHxHEIGHT, each {}..{}", text, side.first, side.second));
  }
  return std::pair{w, h};
}

Result<LayoutParams> ResolveParams(const ParamsSource& source) {
  if (source.params.empty() == source.preset.empty()) {
    return OptionError("params", source.params.empty() ? "give a params file or a preset"
                                                       : "give a params file or a preset, not both");
  }
  SOLID_ASSIGN_OR_RETURN(LayoutParams params, !source.params.empty() ? LoadParamsFile(source.params)
                                                                      : LoadPreset(source.preset));
  if (!source.resolution.empty()) {
    SOLID_ASSIGN_OR_RETURN(std::tie(params.width, params.height), ParseResolution("resolution", source.resolution));
  }
  if (!source.scale_classes_at.empty()) {
    SOLID_ASSIGN_OR_RETURN(std::tie(params.scale_width, params.scale_height),
                           ParseResolution("scale_classes_at", source.scale_classes_at));
  }
  return params;
}

}  // namespace solid::render
