#include "solid/optimizer/search_space.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>

#include "solid/formats/files.h"
#include "solid/formats/json_schema.h"
#include "solid/formats/schemas.h"

namespace solid::optimizer {
namespace {

using render::Interval;
using render::LayoutParams;

constexpr uint64_t kMaxSpaceBytes = uint64_t{1} << 20;
constexpr int kMaxSpaceDepth = 16;
// Without a "step", the initial step is this share of a dimension's bounds: large enough
// that the first simplex moves the discrete layouts, small enough to stay near the start.
constexpr double kDefaultStepShare = 0.2;

enum class Kind { kScalar, kInterval, kScaleP, kScaleRange };

struct KnobInfo {
  std::string_view name;
  Kind kind;
  double LayoutParams::*scalar = nullptr;
  Interval LayoutParams::*interval = nullptr;
};

constexpr KnobInfo kKnobs[] = {
    {"objects.attempts", Kind::kInterval, nullptr, &LayoutParams::attempts},
    {"camera.ring_m", Kind::kInterval, nullptr, &LayoutParams::camera_ring_m},
    {"camera.height_m", Kind::kInterval, nullptr, &LayoutParams::camera_height_m},
    {"camera.look_z_m", Kind::kInterval, nullptr, &LayoutParams::camera_look_z_m},
    {"objects.reuse_prob", Kind::kScalar, &LayoutParams::reuse_prob},
    {"placement.min_hdist_m", Kind::kScalar, &LayoutParams::min_hdist_m},
    {"placement.frustum_inset", Kind::kScalar, &LayoutParams::frustum_inset},
    {"placement.cluster_prob", Kind::kScalar, &LayoutParams::cluster_prob},
    {"placement.cluster_margin_m", Kind::kScalar, &LayoutParams::cluster_margin_m},
    {"placement.occlude_prob", Kind::kScalar, &LayoutParams::occlude_prob},
    {"placement.depth_by_size_prob", Kind::kScalar, &LayoutParams::depth_by_size_prob},
    {"objects.scale.p", Kind::kScaleP},
    {"objects.scale.range_m", Kind::kScaleRange},
};

const KnobInfo* FindKnob(std::string_view name) {
  for (const KnobInfo& k : kKnobs) {
    if (k.name == name) return &k;
  }
  return nullptr;
}

// Default transform and bounds of each knob, chosen wide enough for every Table-1 row
// and narrow enough that the sampler still works (a camera ring inside the grid, a
// camera inside the room).
FreeKnob DefaultKnob(const KnobInfo& info, const LayoutParams& start) {
  FreeKnob k;
  k.name = std::string(info.name);
  const std::string_view n = info.name;
  if (n == "objects.attempts") {
    k = {k.name, Transform::kRange, {1, 60}, {0, 10}};
  } else if (n == "camera.ring_m") {
    k = {k.name, Transform::kRange, {1.0, 5.5}, {0, 4}};
  } else if (n == "camera.height_m") {
    const Interval h = start.camera_height_m;
    double top = 1.5 * h.hi;
    if (start.scene == render::SceneKind::kRooms) top = std::min(top, start.room_size_m[2] - 0.1);
    const double bottom = std::min(std::max(h.lo + 0.1, 0.5 * h.hi), top);
    k = {k.name, Transform::kUpper, {bottom, top}};
  } else if (n == "camera.look_z_m") {
    k = {k.name, Transform::kRange, {0, 3}, {0, 3}};
  } else if (n == "placement.cluster_margin_m") {
    k = {k.name, Transform::kValue, {0, 4}};
  } else if (n == "placement.min_hdist_m") {
    k = {k.name, Transform::kValue, {0, 5}};
  } else if (n == "placement.frustum_inset") {
    k = {k.name, Transform::kValue, {0.5, 1}};
  } else if (n == "objects.scale.p") {
    k = {k.name, Transform::kSimplex};
  } else if (n == "objects.scale.range_m") {
    k = {k.name, Transform::kRange, {0.05, 3}, {0.05, 3}};
  } else {
    k = {k.name, Transform::kValue, {0, 1}};  // the probabilities
  }
  return k;
}

std::string_view TransformName(Transform t) {
  switch (t) {
    case Transform::kValue: return "value";
    case Transform::kRange: return "range";
    case Transform::kUpper: return "upper";
    case Transform::kLower: return "lower";
    case Transform::kShift: return "shift";
    case Transform::kScale: return "scale";
    case Transform::kSimplex: return "simplex";
  }
  return "?";
}

Result<json::Schema> CompileSpaceSchema() {
  constexpr std::string_view kName = "schemas/search-space.schema.json";
  SOLID_ASSIGN_OR_RETURN(std::string_view text, schemas::Get("search-space.schema.json"));
  SOLID_ASSIGN_OR_RETURN(nlohmann::json document, json::ParseJson(text, kName));
  return json::Schema::Compile(document, kName);
}

Result<const json::Schema*> SpaceSchema() {
  static const Result<json::Schema> schema = CompileSpaceSchema();
  if (!schema.ok()) return schema.status();
  return &schema.value();
}

Interval BoundsFromJson(const nlohmann::json& v) { return {v[0].get<double>(), v[1].get<double>()}; }

double Clamp(double v, double lo, double hi) { return std::min(std::max(v, lo), hi); }

}  // namespace

const std::vector<std::string>& SearchSpace::KnobNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const KnobInfo& k : kKnobs) out.emplace_back(k.name);
    return out;
  }();
  return names;
}

SearchSpace SearchSpace::FitKnobs(const LayoutParams& start) {
  SearchSpace space;
  const bool mixture = start.scale.mixture && start.scale.buckets.size() >= 2;
  // In order of how directly each moves a metric (scale shares, count, occlusion, then the
  // camera): Sbplx works through the dimensions in this order at first.
  for (std::string_view name : {"objects.scale.range_m", "objects.scale.p", "objects.attempts", "placement.occlude_prob",
                                "placement.cluster_margin_m", "camera.ring_m", "camera.height_m"}) {
    if (name == "objects.scale.p" && !mixture) continue;
    FreeKnob k = DefaultKnob(*FindKnob(name), start);
    // Intervals move whole and a mixture's ranges together: four metrics (the shares sum
    // to one) need few dimensions, and each dimension costs two evaluations per Jacobian.
    // depth_by_size_prob acts only through occlude_prob, which is free. With every bound
    // freed alone (16 dimensions) one Table-1 row of six fitted within a minute; with
    // these 7 or 8 five do (README, "Table 1 on the embedded procedural assets").
    if (name == "objects.attempts") {
      k = {k.name, Transform::kShift, {1, 50}};
    } else if (name == "camera.ring_m") {
      k = {k.name, Transform::kShift, {1, 5.5}};
    } else if (name == "objects.scale.range_m" && mixture) {
      const double top = start.scale.buckets.back().size_m.hi;
      k = {k.name, Transform::kScale, {0.5 * top, 2 * top}};
    }
    space.knobs_.push_back(std::move(k));
  }
  return space;
}

Status SearchSpace::Free(std::string_view knob, const LayoutParams& start) {
  const KnobInfo* info = FindKnob(knob);
  if (!info) {
    return InvalidArgumentError(
        fmt::format("unknown knob \"{}\"; the knobs that can be freed are {}", knob, fmt::join(KnobNames(), ", ")));
  }
  SOLID_RETURN_IF_ERROR(Fix(knob));
  knobs_.push_back(DefaultKnob(*info, start));
  return Status::Ok();
}

Status SearchSpace::Fix(std::string_view knob) {
  if (!FindKnob(knob)) {
    return InvalidArgumentError(
        fmt::format("unknown knob \"{}\"; the knobs that can be fixed are {}", knob, fmt::join(KnobNames(), ", ")));
  }
  std::erase_if(knobs_, [&](const FreeKnob& k) { return k.name == knob; });
  return Status::Ok();
}

Result<SearchSpace> SearchSpace::Parse(const nlohmann::json& document, std::string_view text, std::string_view source) {
  SOLID_ASSIGN_OR_RETURN(const json::Schema* schema, SpaceSchema());
  SOLID_RETURN_IF_ERROR(schema->Check(document, source, text));
  // The schema guarantees presence and types from here on.
  SearchSpace space;
  if (const auto start = document.find("start"); start != document.end()) {
    if (start->contains("preset")) space.start_preset_ = start->at("preset").get<std::string>();
    if (start->contains("params")) space.start_params_ = start->at("params").get<std::string>();
  }
  std::vector<json::Violation> problems;
  for (const auto& [name, spec] : document.at("free").items()) {
    const std::string pointer = "/free/" + name;
    FreeKnob k;
    k.name = name;
    const std::string transform = spec.value("transform", "value");
    if (transform == "range") {
      k.transform = Transform::kRange;
      k.bounds = BoundsFromJson(spec.at("low"));
      k.width = BoundsFromJson(spec.at("width"));
    } else if (transform == "simplex") {
      k.transform = Transform::kSimplex;
    } else {
      k.transform = transform == "upper"   ? Transform::kUpper
                    : transform == "lower" ? Transform::kLower
                    : transform == "shift" ? Transform::kShift
                    : transform == "scale" ? Transform::kScale
                                           : Transform::kValue;
      k.bounds = BoundsFromJson(spec.at("bounds"));
    }
    k.step = spec.value("step", 0.0);
    auto check = [&](const Interval& b, std::string_view key) {
      if (!(std::isfinite(b.lo) && std::isfinite(b.hi) && b.lo < b.hi)) {
        problems.push_back({fmt::format("{}/{}", pointer, key),
                            fmt::format("bounds [{}, {}] must be finite with min < max", b.lo, b.hi)});
      }
    };
    if (k.transform == Transform::kRange) {
      check(k.bounds, "low");
      check(k.width, "width");
      if (k.width.lo < 0) problems.push_back({pointer + "/width", "a width cannot be negative"});
    } else if (k.transform != Transform::kSimplex) {
      check(k.bounds, "bounds");
    }
    space.knobs_.push_back(std::move(k));
  }
  if (problems.empty()) return space;
  std::vector<std::string> pointers;
  for (const json::Violation& v : problems) pointers.push_back(v.pointer);
  const std::vector<size_t> lines =
      text.empty() ? std::vector<size_t>(pointers.size(), 0) : json::FindPointerLines(text, pointers);
  std::string message;
  for (size_t i = 0; i < problems.size(); ++i) {
    if (i > 0) message += '\n';
    message += std::string(source);
    if (lines[i] != 0) message += fmt::format(":{}", lines[i]);
    message += fmt::format(": {}: {}", problems[i].pointer, problems[i].message);
  }
  return InvalidArgumentError(std::move(message));
}

Result<SearchSpace> SearchSpace::Load(const std::filesystem::path& path) {
  const std::string source = path.string();
  SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, files::ReadFile(path, kMaxSpaceBytes));
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  json::ParseLimits limits;
  limits.max_bytes = kMaxSpaceBytes;
  limits.max_depth = kMaxSpaceDepth;
  limits.max_string_length = json::kMaxConfigStringBytes;
  SOLID_ASSIGN_OR_RETURN(nlohmann::json document, json::ParseJson(text, source, limits));
  SOLID_ASSIGN_OR_RETURN(SearchSpace space, Parse(document, text, source));
  if (space.start_params_ && space.start_params_->is_relative()) {
    space.start_params_ = path.parent_path() / *space.start_params_;
  }
  return space;
}

Result<std::vector<Dimension>> SearchSpace::Dimensions(const LayoutParams& start) const {
  std::vector<Dimension> dims;
  auto add = [&](std::string name, const Interval& b, double step) {
    dims.push_back({std::move(name), b.lo, b.hi, step > 0 ? step : kDefaultStepShare * (b.hi - b.lo)});
  };
  for (const FreeKnob& k : knobs_) {
    const KnobInfo* info = FindKnob(k.name);
    SOLID_CHECK(info != nullptr);  // Parse, Free and FitKnobs admit known names only
    const bool fits = [&] {
      switch (info->kind) {
        case Kind::kScalar: return k.transform == Transform::kValue;
        case Kind::kInterval:
          return k.transform == Transform::kRange || k.transform == Transform::kUpper ||
                 k.transform == Transform::kLower || k.transform == Transform::kShift;
        case Kind::kScaleP: return k.transform == Transform::kSimplex;
        case Kind::kScaleRange: return k.transform == Transform::kRange || k.transform == Transform::kScale;
      }
      return false;
    }();
    if (!fits) {
      return InvalidArgumentError(
          fmt::format("search space: {}: transform \"{}\" does not fit this knob", k.name, TransformName(k.transform)));
    }
    switch (info->kind) {
      case Kind::kScalar: add(k.name, k.bounds, k.step); break;
      case Kind::kInterval:
        if (k.transform == Transform::kRange) {
          add(k.name + ".low", k.bounds, k.step);
          add(k.name + ".width", k.width, k.step);
        } else if (k.transform == Transform::kShift) {
          add(k.name + ".shift", k.bounds, k.step);
        } else {
          add(k.name + (k.transform == Transform::kUpper ? ".hi" : ".lo"), k.bounds, k.step);
        }
        break;
      case Kind::kScaleP:
        if (!start.scale.mixture || start.scale.buckets.size() < 2) {
          return InvalidArgumentError(fmt::format(
              "search space: {}: a simplex needs a mixture scale law with at least 2 buckets; the start has a {} law "
              "with {} bucket(s)",
              k.name, start.scale.mixture ? "mixture" : "uniform", start.scale.buckets.size()));
        }
        for (size_t i = 0; i + 1 < start.scale.buckets.size(); ++i) add(fmt::format("{}[{}]", k.name, i), {0, 1}, k.step);
        break;
      case Kind::kScaleRange:
        if (k.transform == Transform::kScale) {
          add(k.name + ".top", k.bounds, k.step);
          break;
        }
        for (size_t i = 0; i < start.scale.buckets.size(); ++i) {
          add(fmt::format("{}[{}].low", k.name, i), k.bounds, k.step);
          add(fmt::format("{}[{}].width", k.name, i), k.width, k.step);
        }
        break;
    }
  }
  return dims;
}

std::vector<double> SearchSpace::Encode(const LayoutParams& p) const {
  std::vector<double> x;
  for (const FreeKnob& k : knobs_) {
    const KnobInfo* info = FindKnob(k.name);
    switch (info->kind) {
      case Kind::kScalar: x.push_back(Clamp(p.*(info->scalar), k.bounds.lo, k.bounds.hi)); break;
      case Kind::kInterval: {
        const Interval v = p.*(info->interval);
        if (k.transform == Transform::kRange) {
          x.push_back(Clamp(v.lo, k.bounds.lo, k.bounds.hi));
          x.push_back(Clamp(v.hi - v.lo, k.width.lo, k.width.hi));
        } else if (k.transform == Transform::kShift) {
          x.push_back(Clamp(v.lo, k.bounds.lo, k.bounds.hi));
        } else {
          x.push_back(Clamp(k.transform == Transform::kUpper ? v.hi : v.lo, k.bounds.lo, k.bounds.hi));
        }
        break;
      }
      case Kind::kScaleP: {
        double rest = 1;
        for (size_t i = 0; i + 1 < p.scale.buckets.size(); ++i) {
          const double pi = p.scale.buckets[i].probability;
          x.push_back(rest > 0 ? Clamp(pi / rest, 0, 1) : 0);
          rest -= pi;
        }
        break;
      }
      case Kind::kScaleRange:
        if (k.transform == Transform::kScale) {
          x.push_back(Clamp(p.scale.buckets.back().size_m.hi, k.bounds.lo, k.bounds.hi));
          break;
        }
        for (const render::ScaleBucket& b : p.scale.buckets) {
          x.push_back(Clamp(b.size_m.lo, k.bounds.lo, k.bounds.hi));
          x.push_back(Clamp(b.size_m.hi - b.size_m.lo, k.width.lo, k.width.hi));
        }
        break;
    }
  }
  return x;
}

Result<LayoutParams> SearchSpace::Decode(const LayoutParams& base, std::span<const double> x) const {
  LayoutParams p = base;
  size_t at = 0;
  auto next = [&] {
    SOLID_CHECK(at < x.size());
    return x[at++];
  };
  for (const FreeKnob& k : knobs_) {
    const KnobInfo* info = FindKnob(k.name);
    switch (info->kind) {
      case Kind::kScalar: p.*(info->scalar) = next(); break;
      case Kind::kInterval: {
        Interval& v = p.*(info->interval);
        if (k.transform == Transform::kRange) {
          v.lo = next();
          v.hi = v.lo + next();
        } else if (k.transform == Transform::kShift) {
          const double width = v.hi - v.lo;
          v.lo = next();
          v.hi = v.lo + width;
        } else if (k.transform == Transform::kUpper) {
          v.hi = std::max(next(), v.lo);
        } else {
          v.lo = std::min(next(), v.hi);
        }
        break;
      }
      case Kind::kScaleP: {
        double rest = 1;
        for (size_t i = 0; i + 1 < p.scale.buckets.size(); ++i) {
          p.scale.buckets[i].probability = rest * next();
          rest -= p.scale.buckets[i].probability;
        }
        p.scale.buckets.back().probability = std::max(0.0, rest);
        break;
      }
      case Kind::kScaleRange:
        if (k.transform == Transform::kScale) {
          const double factor = next() / p.scale.buckets.back().size_m.hi;
          for (render::ScaleBucket& b : p.scale.buckets) b.size_m = {b.size_m.lo * factor, b.size_m.hi * factor};
          break;
        }
        for (render::ScaleBucket& b : p.scale.buckets) {
          b.size_m.lo = next();
          b.size_m.hi = b.size_m.lo + next();
        }
        break;
    }
  }
  SOLID_CHECK(at == x.size());
  // The camera column is a lattice column: a ring reaching past the grid is clipped to it
  // rather than refused, so that the whole box of the space decodes to valid params.
  const double half_grid = std::min(p.grid_extent_m[0], p.grid_extent_m[1]) / 2;
  p.camera_ring_m.hi = std::min(p.camera_ring_m.hi, half_grid);
  p.camera_ring_m.lo = std::min(p.camera_ring_m.lo, p.camera_ring_m.hi);
  SOLID_RETURN_IF_ERROR(render::CheckParams(p, "search space point"));
  return p;
}

}  // namespace solid::optimizer
