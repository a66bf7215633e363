// The search space of `solid optimize`: which layout knobs are free, their bounds and
// transforms (schemas/search-space.schema.json).
//
// A free knob becomes one or more real dimensions:
//   value    a scalar knob within bounds                          ("placement.occlude_prob")
//   range    an interval [lo, hi] as (low, width), hi = low + width ("objects.attempts.low", ".width")
//   upper    an interval's hi alone, lower its lo alone             ("camera.height_m.hi")
//   shift    an interval moved as a whole, its width kept; the dimension is its lo
//            ("objects.attempts.shift")
//   scale    every bucket's size range multiplied by one factor; the dimension is the last
//            bucket's hi, in metres ("objects.scale.range_m.top")
//   simplex  a mixture's k bucket probabilities as k - 1 stick-breaking fractions in [0, 1]
//            ("objects.scale.p[0]", ...): p_1 = v_1, p_2 = (1 - v_1) v_2, ..., p_k the rest
// Integer counts (objects.attempts) are already reals in LayoutParams: N = floor(U(lo, hi + 1)).
#pragma once

#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/status.h"
#include "solid/render/params.h"

namespace solid::optimizer {

enum class Transform { kValue, kRange, kUpper, kLower, kShift, kScale, kSimplex };

struct FreeKnob {
  std::string name;  // dotted, as in params.schema.json: "camera.ring_m"
  Transform transform = Transform::kValue;
  render::Interval bounds;  // value, upper, lower, scale: of the value; range, shift: of the low end
  render::Interval width;   // range only
  double step = 0;          // initial step in the knob's units; 0: a fifth of each dimension's bounds
};

// One real dimension of the search, in the knob's units.
struct Dimension {
  std::string name;  // "objects.attempts.low", "objects.scale.p[1]", "objects.scale.range_m[2].width"
  double lo = 0, hi = 0;
  double step = 0;
};

class SearchSpace {
 public:
  SearchSpace() = default;

  // The fit knobs of solid-method.md 4.3 with their default bounds for `start`: attempts
  // and the camera ring shifted whole, occlude_prob, cluster_margin_m,
  // the upper camera height (within half to one and a half times the start's, and inside
  // the room: the row's regime), and the scale law: a mixture's bucket probabilities with
  // its ranges scaled together, or a uniform law's range: seven or eight dimensions
  // (depth_by_size_prob acts only through occlude_prob; Free adds it).
  static SearchSpace FitKnobs(const render::LayoutParams& start);

  // Parses a search-space document. Unknown keys, wrong types and inconsistent bounds are
  // kInvalidArgument naming `source`, the line (when `text` is given) and the JSON Pointer.
  static Result<SearchSpace> Parse(const nlohmann::json& document, std::string_view text, std::string_view source);
  // Reads and parses a search-space file (size and depth limits apply); a relative
  // start.params path is resolved against the file's directory.
  static Result<SearchSpace> Load(const std::filesystem::path& path);

  // Every knob name Free and search-space files accept.
  static const std::vector<std::string>& KnobNames();

  // Frees `knob` with its default transform and bounds for `start`, replacing any earlier
  // definition; kInvalidArgument for an unknown name (the message lists the valid ones).
  Status Free(std::string_view knob, const render::LayoutParams& start);
  // Fixes `knob` at the start's value; kInvalidArgument for an unknown name.
  Status Fix(std::string_view knob);

  // The dimensions for `start` (a simplex has as many as the start's buckets less one);
  // kInvalidArgument when a knob does not fit the start (a simplex over a uniform law).
  Result<std::vector<Dimension>> Dimensions(const render::LayoutParams& start) const;
  // `params` as a point of the space, each coordinate clamped to its dimension's bounds.
  // Precondition: Dimensions(params) succeeds.
  std::vector<double> Encode(const render::LayoutParams& params) const;
  // `base` with the free knobs set from `x` (one value per dimension of Dimensions(base));
  // the result passes render::CheckParams or the error names the knob.
  Result<render::LayoutParams> Decode(const render::LayoutParams& base, std::span<const double> x) const;

  const std::vector<FreeKnob>& knobs() const { return knobs_; }
  // From the file's "start", if any.
  const std::optional<std::string>& start_preset() const { return start_preset_; }
  const std::optional<std::filesystem::path>& start_params() const { return start_params_; }

 private:
  std::vector<FreeKnob> knobs_;
  std::optional<std::string> start_preset_;
  std::optional<std::filesystem::path> start_params_;
};

}  // namespace solid::optimizer
