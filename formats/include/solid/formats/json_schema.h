// JSON parsing with limits, and a JSON Schema (draft 2020-12 subset) validator.
//
// The JSON Schemas in schemas/ are the single source of truth for our JSON files: a key the
// schema does not know is an error with its location, and a keyword outside the subset is
// refused by Compile, never skipped. Debian 12's valijson 1.0 stops at draft 7 (it ignores
// prefixItems) and is slower: docs/dependencies.md has the figures, and bench/ the program.
#pragma once

#include <cstddef>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "solid/formats/status.h"

namespace solid::json {

namespace internal {
struct CompiledSchema;
}  // namespace internal

struct ParseLimits {
  size_t max_bytes = size_t{64} << 20;
  // Containers nested deeper than this are refused before they are built, so that no
  // recursive walk over a parsed value (comparison, dump, validation) can exhaust the stack.
  int max_depth = 64;
  // Bytes of one decoded string or object key.
  size_t max_string_length = size_t{1} << 20;
};

// Longest string or key in the small JSON files people and tools write (params files,
// search spaces, dataset manifests): nothing in their schemas needs more.
inline constexpr size_t kMaxConfigStringBytes = 4096;

// Parses untrusted JSON text. Errors read "name:line:column: message" (column counts code
// points, both 1-based). Syntax errors and duplicate object keys are kParseError, broken
// limits kLimitExceeded.
Result<nlohmann::json> ParseJson(std::string_view text, std::string_view name,
                                 const ParseLimits& limits = {});

// For each JSON Pointer (RFC 6901), the 1-based line in `text` where the value it names starts
// (for an object member: where its key starts), or 0 when it names nothing there. Best effort:
// `text` should be what the instance was parsed from; malformed text gives 0s, not errors.
std::vector<size_t> FindPointerLines(std::string_view text, const std::vector<std::string>& pointers);

struct Violation {
  std::string pointer;  // JSON Pointer into the instance, e.g. "/objects/scale/0"; "" is the root
  std::string message;  // e.g. "unknown key \"min_objets\" (did you mean \"min_objects\"?)"
};

class Schema {
 public:
  // Supported keywords: type, enum, const, properties, required, additionalProperties,
  // patternProperties, items, prefixItems, minItems, maxItems, uniqueItems, minimum, maximum,
  // exclusiveMinimum, exclusiveMaximum, multipleOf, minLength, maxLength, pattern,
  // minProperties, maxProperties, allOf, anyOf, oneOf, not, if/then/else, dependentRequired,
  // $defs, and $ref to a JSON Pointer within the same document ("#", "#/$defs/point").
  // Annotations ($schema at the root, which must name draft 2020-12, $id at the root, title,
  // description, default, examples, $comment, deprecated, readOnly, writeOnly) are accepted
  // and have no effect. Anything else is kInvalidArgument, naming where it is in the schema.
  static Result<Schema> Compile(const nlohmann::json& schema, std::string_view name);

  // Every violation. Collection stops after kMaxViolations, with a final violation saying so,
  // so that a huge bad instance cannot exhaust memory.
  std::vector<Violation> Validate(const nlohmann::json& instance) const;

  // OK, or kParseError (the document does not follow its format) whose message has one line
  // per violation, at most kMaxReportedViolations of them:
  //   "manifest.json: /seed: does not match pattern ^0x[0-9a-f]{16}$"
  // Given the text the instance was parsed from, each line also has the line number:
  //   "params.json:14: /objects/min_objets: unknown key \"min_objets\" (did you mean ...?)"
  Status Check(const nlohmann::json& instance, std::string_view instance_name,
               std::string_view instance_text = {}) const;

  static constexpr size_t kMaxViolations = 1000;
  static constexpr size_t kMaxReportedViolations = 20;
  // libstdc++'s std::regex matcher recurses once per character matched (about half a KiB of
  // stack each for a repeated group), so a long untrusted string would overflow the stack:
  // a string or key longer than this is a violation instead of being matched against a
  // pattern or patternProperties.
  static constexpr size_t kMaxPatternSubjectBytes = 1024;

 private:
  explicit Schema(std::shared_ptr<const internal::CompiledSchema> compiled)
      : compiled_(std::move(compiled)) {}

  // Shared and immutable: copies are cheap and Validate may run on several threads at once.
  std::shared_ptr<const internal::CompiledSchema> compiled_;
};

}  // namespace solid::json
