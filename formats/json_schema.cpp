// GCC 12.2 with sanitizers warns falsely inside libstdc++'s std::regex and std::function
// (GCC bug 105562); the pragma covers only the library headers, not our code below. Clang
// has no such warning (and -Werror refuses an unknown one).
#pragma GCC diagnostic push
#if !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include "solid/formats/json_schema.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <regex>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>
#pragma GCC diagnostic pop

namespace solid::json {

using nlohmann::json;

namespace {

// ---------------------------------------------------------------------------------------------
// Text helpers

size_t CountCodePoints(std::string_view utf8) {
  return static_cast<size_t>(std::count_if(
      utf8.begin(), utf8.end(), [](char c) { return (static_cast<unsigned char>(c) & 0xC0) != 0x80; }));
}

struct LineColumn {
  size_t line;
  size_t column;
};

LineColumn LineColumnAt(std::string_view text, size_t offset) {
  offset = std::min(offset, text.size());
  const std::string_view before = text.substr(0, offset);
  const size_t line = 1 + static_cast<size_t>(std::count(before.begin(), before.end(), '\n'));
  const size_t line_start = before.find_last_of('\n');
  const std::string_view on_line =
      line_start == std::string_view::npos ? before : before.substr(line_start + 1);
  return {line, 1 + CountCodePoints(on_line)};
}

std::string Truncated(std::string text, size_t max_bytes = 80) {
  if (text.size() <= max_bytes) return text;
  size_t cut = max_bytes;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;  // keep UTF-8 whole
  text.resize(cut);
  return text + "...";
}

// Never throws on invalid UTF-8, which a programmatically built value may hold.
std::string Dump(const json& value) { return value.dump(-1, ' ', false, json::error_handler_t::replace); }

std::string Quoted(std::string_view text) { return Truncated(Dump(json(text))); }

// JSON Schema's integer: any number with a zero fractional part, 1.0 included.
bool IsIntegral(const json& number) {
  if (number.is_number_integer()) return true;
  const double x = number.get<double>();
  return std::isfinite(x) && std::floor(x) == x;
}

std::string_view TypeName(const json& value) {
  switch (value.type()) {
    case json::value_t::null: return "null";
    case json::value_t::boolean: return "boolean";
    case json::value_t::object: return "object";
    case json::value_t::array: return "array";
    case json::value_t::string: return "string";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned: return "integer";
    case json::value_t::number_float: return IsIntegral(value) ? "integer" : "number";
    case json::value_t::binary: return "binary";
    case json::value_t::discarded: return "discarded";
  }
  return "unknown";
}

// An instance value for a message: scalars as JSON text, containers only by type, because
// dumping recurses and an instance built in memory may be nested arbitrarily deep.
std::string Describe(const json& value) {
  if (value.is_object()) return "an object";
  if (value.is_array()) return "an array";
  return Truncated(Dump(value));
}

// A value from a schema (const, enum), which is trusted: containers are shown too.
std::string DescribeSchemaValue(const json& value) { return Truncated(Dump(value)); }

void AppendPointerToken(std::string& pointer, std::string_view token) {
  pointer += '/';
  for (char c : token) {
    if (c == '~') {
      pointer += "~0";
    } else if (c == '/') {
      pointer += "~1";
    } else {
      pointer += c;
    }
  }
}

std::string ChildPointer(std::string_view parent, std::string_view token) {
  std::string pointer(parent);
  AppendPointerToken(pointer, token);
  return pointer;
}

// Optimal string alignment distance: a swap of two neighbours ("widht") costs one edit.
size_t EditDistance(std::string_view a, std::string_view b) {
  std::vector<size_t> before_previous(b.size() + 1), previous(b.size() + 1), current(b.size() + 1);
  std::iota(previous.begin(), previous.end(), size_t{0});
  for (size_t i = 1; i <= a.size(); ++i) {
    current[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t substitution = a[i - 1] == b[j - 1] ? 0 : 1;
      current[j] = std::min({previous[j] + 1, current[j - 1] + 1, previous[j - 1] + substitution});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        current[j] = std::min(current[j], before_previous[j - 2] + 1);
      }
    }
    std::swap(before_previous, previous);
    std::swap(previous, current);
  }
  return previous[b.size()];
}

// The candidate a typo most likely meant, if any is close enough to be worth suggesting.
template <typename Names>
std::optional<std::string> ClosestName(std::string_view name, const Names& candidates) {
  constexpr size_t kMaxSuggestedDistance = 3;
  std::optional<std::string> best;
  size_t best_distance = kMaxSuggestedDistance + 1;
  for (std::string_view candidate : candidates) {
    const size_t length_difference =
        name.size() > candidate.size() ? name.size() - candidate.size() : candidate.size() - name.size();
    if (length_difference >= best_distance) continue;  // a lower bound: skips hopeless long names cheaply
    const size_t allowed =
        std::clamp<size_t>(std::max(name.size(), candidate.size()) / 3, 1, kMaxSuggestedDistance);
    const size_t distance = EditDistance(name, candidate);
    if (distance <= allowed && distance < best_distance) {
      best_distance = distance;
      best = std::string(candidate);
    }
  }
  return best;
}

std::string DidYouMean(const std::optional<std::string>& suggestion) {
  return suggestion ? " (did you mean " + Quoted(*suggestion) + "?)" : "";
}

// Where in a document a message is about: "name" or "name: /pointer".
std::string Where(std::string_view name, std::string_view pointer) {
  std::string where(name);
  if (!pointer.empty()) where.append(": ").append(pointer);
  return where;
}

// ---------------------------------------------------------------------------------------------
// ParseJson

enum class TokenKind { kContainerStart, kString };

// Byte offset of the n-th (1-based) token of `kind`; `text` must be well-formed JSON up to it,
// which holds when nlohmann's parser has accepted every token before it.
size_t OffsetOfNthToken(std::string_view text, TokenKind kind, size_t n) {
  size_t seen = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"') {
      if (kind == TokenKind::kString && ++seen == n) return i;
      for (++i; i < text.size() && text[i] != '"'; ++i) {
        if (text[i] == '\\') ++i;
      }
    } else if (c == '{' || c == '[') {
      if (kind == TokenKind::kContainerStart && ++seen == n) return i;
    }
  }
  return text.size();
}

// "[json.exception.parse_error.101] parse error at line 1, column 4: syntax error ..." ->
// "syntax error ...": we print the location ourselves, in our own format.
std::string NlohmannMessage(const json::exception& error) {
  std::string_view message = error.what();
  if (const size_t id_end = message.find("] "); id_end != std::string_view::npos)
    message.remove_prefix(id_end + 2);
  if (message.starts_with("parse error")) {
    if (const size_t colon = message.find(": "); colon != std::string_view::npos)
      message.remove_prefix(colon + 2);
  }
  return std::string(message);
}

// Builds the value as nlohmann's own DOM parser would, but refuses to go past the limits
// before anything is built, and refuses duplicate keys (which nlohmann resolves silently).
class LimitedDomBuilder final : public nlohmann::json_sax<json> {
 public:
  LimitedDomBuilder(std::string_view text, const ParseLimits& limits) : text_(text), limits_(limits) {}

  json& root() { return root_; }

  struct Failure {
    StatusCode code;
    std::string message;
    size_t offset;
  };
  const std::optional<Failure>& failure() const { return failure_; }

  bool null() override { return Add(nullptr); }
  bool boolean(bool value) override { return Add(value); }
  bool number_integer(number_integer_t value) override { return Add(value); }
  bool number_unsigned(number_unsigned_t value) override { return Add(value); }
  bool number_float(number_float_t value, const string_t& /*text*/) override { return Add(value); }
  bool string(string_t& value) override { return CheckString(value) && Add(std::move(value)); }
  bool binary(binary_t& value) override { return Add(json::binary(std::move(value))); }

  bool start_object(size_t /*size*/) override { return Open(json::object()); }
  bool start_array(size_t /*size*/) override { return Open(json::array()); }
  bool end_object() override { return Close(); }
  bool end_array() override { return Close(); }

  bool key(string_t& name) override {
    if (!CheckString(name)) return false;
    json& object = *open_.back();
    if (object.contains(name)) {
      return Fail(StatusCode::kParseError, "duplicate key " + Quoted(name),
                  OffsetOfNthToken(text_, TokenKind::kString, strings_seen_));
    }
    member_ = &object[std::move(name)];
    return true;
  }

  bool parse_error(size_t position, const std::string& /*last_token*/,
                   const json::exception& error) override {
    // `position` counts the bytes read, the offending one included.
    return Fail(StatusCode::kParseError, NlohmannMessage(error), position > 0 ? position - 1 : 0);
  }

 private:
  bool Add(json value) {
    Place(std::move(value));
    return true;
  }

  // Where the value went.
  json* Place(json value) {
    if (open_.empty()) {
      root_ = std::move(value);
      return &root_;
    }
    json& parent = *open_.back();
    if (parent.is_array()) {
      parent.push_back(std::move(value));
      return &parent.back();
    }
    *member_ = std::move(value);
    return member_;
  }

  bool Open(json container) {
    ++containers_seen_;
    if (open_.size() >= static_cast<size_t>(std::max(limits_.max_depth, 0))) {
      return Fail(StatusCode::kLimitExceeded,
                  "nesting is deeper than the limit of " + std::to_string(limits_.max_depth) + " levels",
                  OffsetOfNthToken(text_, TokenKind::kContainerStart, containers_seen_));
    }
    // Pointers stay valid: a container on open_ is the last child of its parent, and nothing
    // is added to the parent until it is closed. Object members live in a std::map.
    open_.push_back(Place(std::move(container)));
    return true;
  }

  bool Close() {
    open_.pop_back();
    return true;
  }

  bool CheckString(const std::string& value) {
    ++strings_seen_;
    if (value.size() <= limits_.max_string_length) return true;
    return Fail(StatusCode::kLimitExceeded,
                "string of " + std::to_string(value.size()) + " bytes is longer than the limit of " +
                    std::to_string(limits_.max_string_length) + " bytes",
                OffsetOfNthToken(text_, TokenKind::kString, strings_seen_));
  }

  bool Fail(StatusCode code, std::string message, size_t offset) {
    failure_ = Failure{code, std::move(message), offset};
    return false;
  }

  std::string_view text_;
  const ParseLimits& limits_;
  json root_;
  std::vector<json*> open_;
  json* member_ = nullptr;
  size_t containers_seen_ = 0;
  size_t strings_seen_ = 0;
  std::optional<Failure> failure_;
};

}  // namespace

Result<json> ParseJson(std::string_view text, std::string_view name, const ParseLimits& limits) {
  if (text.size() > limits.max_bytes) {
    return LimitExceededError(std::string(name) + ": " + std::to_string(text.size()) +
                              " bytes is more than the limit of " + std::to_string(limits.max_bytes) +
                              " bytes");
  }
  LimitedDomBuilder builder(text, limits);
  try {
    if (json::sax_parse(text, &builder)) return std::move(builder.root());
  } catch (const json::exception& error) {
    return InternalError(std::string(name) + ": JSON parser failed: " + error.what());
  }
  if (!builder.failure())
    return InternalError(std::string(name) + ": JSON parser stopped without saying why");
  const auto& failure = *builder.failure();
  const LineColumn at = LineColumnAt(text, failure.offset);
  return Status(failure.code, std::string(name) + ":" + std::to_string(at.line) + ":" +
                                  std::to_string(at.column) + ": " + failure.message);
}

// ---------------------------------------------------------------------------------------------
// FindPointerLines

namespace {

// One past the closing quote of the string that starts at `open_quote`.
size_t EndOfString(std::string_view text, size_t open_quote) {
  size_t i = open_quote + 1;
  while (i < text.size() && text[i] != '"') i += text[i] == '\\' ? 2 : 1;
  return std::min(i + 1, text.size());
}

std::string DecodeKey(std::string_view quoted) {
  if (quoted.find('\\') == std::string_view::npos) return std::string(quoted.substr(1, quoted.size() - 2));
  const json decoded = json::parse(quoted, nullptr, /*allow_exceptions=*/false);
  return decoded.is_string() ? decoded.get<std::string>() : std::string();
}

bool EndsScalar(char c) {
  return c == ',' || c == ']' || c == '}' || c == ':' || c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

}  // namespace

std::vector<size_t> FindPointerLines(std::string_view text, const std::vector<std::string>& pointers) {
  std::vector<size_t> lines(pointers.size(), 0);
  std::unordered_map<std::string_view, std::vector<size_t>> wanted;
  for (size_t i = 0; i < pointers.size(); ++i) wanted[pointers[i]].push_back(i);

  // An explicit stack rather than recursion: the text may be nested arbitrarily deep.
  struct Open {
    bool is_array;
    size_t pointer_length;  // of the container's own pointer
    size_t next_index;
  };
  std::vector<Open> open;
  std::string pointer;
  size_t line = 1;
  bool expect_key = false;
  auto record = [&] {
    if (auto it = wanted.find(pointer); it != wanted.end()) {
      for (size_t index : it->second) lines[index] = line;
      wanted.erase(it);
    }
  };

  size_t i = text.starts_with("\xEF\xBB\xBF") ? 3 : 0;
  while (i < text.size() && !wanted.empty()) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      ++i;
    } else if (c == ' ' || c == '\t' || c == '\r' || c == ':') {
      ++i;
    } else if (c == ',') {
      expect_key = !open.empty() && !open.back().is_array;
      ++i;
    } else if (c == '}' || c == ']') {
      if (open.empty()) break;
      pointer.resize(open.back().pointer_length);
      open.pop_back();
      expect_key = false;
      ++i;
    } else if (expect_key) {
      if (c != '"' || open.empty()) break;
      const size_t end = EndOfString(text, i);
      pointer.resize(open.back().pointer_length);
      AppendPointerToken(pointer, DecodeKey(text.substr(i, end - i)));
      record();
      expect_key = false;
      i = end;
    } else {
      if (!open.empty() && open.back().is_array) {
        pointer.resize(open.back().pointer_length);
        AppendPointerToken(pointer, std::to_string(open.back().next_index++));
      }
      record();
      if (c == '{' || c == '[') {
        open.push_back({c == '[', pointer.size(), 0});
        expect_key = c == '{';
        ++i;
      } else if (c == '"') {
        i = EndOfString(text, i);
      } else {
        while (i < text.size() && !EndsScalar(text[i])) ++i;
      }
    }
  }
  return lines;
}

// ---------------------------------------------------------------------------------------------
// Compiled schema

namespace internal {

constexpr int kNoSchema = -1;

enum TypeBit : uint8_t {
  kNullBit = 1 << 0,
  kBooleanBit = 1 << 1,
  kObjectBit = 1 << 2,
  kArrayBit = 1 << 3,
  kNumberBit = 1 << 4,
  kStringBit = 1 << 5,
  kIntegerBit = 1 << 6,
};

struct Pattern {
  std::string source;
  std::regex regex;
};

// One schema object (or boolean schema); subschemas are indices into CompiledSchema::nodes.
struct Node {
  bool rejects_everything = false;  // the schema `false`
  uint8_t allowed_types = 0;        // TypeBits; 0 when there is no "type"
  std::optional<json> const_value;
  std::optional<json> enum_values;
  std::map<std::string, int, std::less<>> properties;
  std::vector<std::pair<Pattern, int>> pattern_properties;
  int additional_properties = kNoSchema;
  std::vector<std::string> required;
  std::vector<std::pair<std::string, std::vector<std::string>>> dependent_required;
  std::optional<uint64_t> min_properties, max_properties;
  std::vector<int> prefix_items;
  int items = kNoSchema;
  std::optional<uint64_t> min_items, max_items;
  bool unique_items = false;
  std::optional<json> minimum, maximum, exclusive_minimum, exclusive_maximum, multiple_of;
  std::optional<uint64_t> min_length, max_length;
  std::optional<Pattern> pattern;
  std::vector<int> all_of, any_of, one_of;
  int not_schema = kNoSchema, if_schema = kNoSchema, then_schema = kNoSchema, else_schema = kNoSchema;
  int ref = kNoSchema;
};

struct CompiledSchema {
  std::vector<Node> nodes;  // nodes[0] is the root
};

}  // namespace internal

namespace {

using internal::CompiledSchema;
using internal::kNoSchema;
using internal::Node;
using internal::Pattern;

constexpr int kMaxSchemaDepth = 128;
constexpr size_t kMaxValidationDepth = 1000;
constexpr std::string_view kDraft202012 = "https://json-schema.org/draft/2020-12/schema";

// Only to suggest what a misspelt keyword meant; CompileKeyword decides what is supported.
const std::vector<std::string_view>& SupportedKeywords() {
  static const std::vector<std::string_view> kKeywords = {
      "type", "enum", "const", "properties", "patternProperties", "additionalProperties", "required",
      "dependentRequired", "minProperties", "maxProperties", "prefixItems", "items", "minItems", "maxItems",
      "uniqueItems", "minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "multipleOf", "minLength",
      "maxLength", "pattern", "allOf", "anyOf", "oneOf", "not", "if", "then", "else", "$ref", "$defs",
      "$schema", "$id", "title", "description", "default", "examples", "$comment", "deprecated",
      "readOnly", "writeOnly"};
  return kKeywords;
}

bool IsAnnotation(std::string_view keyword) {
  return keyword == "title" || keyword == "description" || keyword == "default" || keyword == "examples" ||
         keyword == "$comment" || keyword == "deprecated" || keyword == "readOnly" || keyword == "writeOnly";
}

// Exact for every mix of int64, uint64 and double, so comparisons need no per-type cases.
static_assert(std::numeric_limits<long double>::digits >= 64, "long double must hold every int64 and uint64");
long double NumberValue(const json& number) {
  switch (number.type()) {
    case json::value_t::number_integer: return static_cast<long double>(number.get<int64_t>());
    case json::value_t::number_unsigned: return static_cast<long double>(number.get<uint64_t>());
    default: return static_cast<long double>(number.get<double>());
  }
}

uint8_t InstanceTypeBits(const json& value) {
  using namespace internal;
  switch (value.type()) {
    case json::value_t::null: return kNullBit;
    case json::value_t::boolean: return kBooleanBit;
    case json::value_t::object: return kObjectBit;
    case json::value_t::array: return kArrayBit;
    case json::value_t::string: return kStringBit;
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return kNumberBit | (IsIntegral(value) ? kIntegerBit : 0);
    default: return 0;
  }
}

const std::vector<std::pair<std::string_view, uint8_t>>& TypeNames() {
  using namespace internal;
  static const std::vector<std::pair<std::string_view, uint8_t>> kNames = {
      {"null", kNullBit},     {"boolean", kBooleanBit}, {"object", kObjectBit},  {"array", kArrayBit},
      {"number", kNumberBit}, {"string", kStringBit},   {"integer", kIntegerBit}};
  return kNames;
}

std::string DescribeTypes(uint8_t bits) {
  std::string names;
  for (const auto& [name, bit] : TypeNames()) {
    if ((bits & bit) == 0) continue;
    if (!names.empty()) names += " or ";
    names += name;
  }
  return names;
}

// "%25" -> "%": a URI fragment is percent-encoded; JSON Pointer escaping (~0, ~1) stays.
std::optional<std::string> PercentDecoded(std::string_view text) {
  std::string decoded;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '%') {
      decoded += text[i];
      continue;
    }
    if (i + 2 >= text.size()) return std::nullopt;
    unsigned value = 0;
    const auto [end, error] = std::from_chars(text.data() + i + 1, text.data() + i + 3, value, 16);
    if (error != std::errc() || end != text.data() + i + 3) return std::nullopt;
    decoded += static_cast<char>(value);
    i += 2;
  }
  return decoded;
}

// The value a JSON Pointer names in `document`, or nullptr.
const json* Resolve(const json& document, std::string_view pointer) {
  const json* at = &document;
  while (!pointer.empty()) {
    if (pointer[0] != '/') return nullptr;
    pointer.remove_prefix(1);
    const size_t end = std::min(pointer.find('/'), pointer.size());
    std::string token;
    for (size_t i = 0; i < end; ++i) {
      if (pointer[i] != '~') {
        token += pointer[i];
      } else if (i + 1 < end && (pointer[i + 1] == '0' || pointer[i + 1] == '1')) {
        token += pointer[++i] == '0' ? '~' : '/';
      } else {
        return nullptr;
      }
    }
    pointer.remove_prefix(end);
    if (at->is_object()) {
      const auto it = at->find(token);
      if (it == at->end()) return nullptr;
      at = &*it;
    } else if (at->is_array()) {
      size_t index = 0;
      const auto [last, error] = std::from_chars(token.data(), token.data() + token.size(), index);
      const bool canonical = !token.empty() && (token == "0" || token[0] != '0');
      if (error != std::errc() || last != token.data() + token.size() || !canonical || index >= at->size()) {
        return nullptr;
      }
      at = &(*at)[index];
    } else {
      return nullptr;
    }
  }
  return at;
}

class Compiler {
 public:
  Compiler(const json& root, std::string_view name) : root_(root), name_(name) {}

  Result<std::shared_ptr<const CompiledSchema>> Run() {
    SOLID_ASSIGN_OR_RETURN(const int root_index, CompileAt(root_, "", 0));
    SOLID_CHECK(root_index == 0);
    SOLID_RETURN_IF_ERROR(ResolveRefs());
    SOLID_RETURN_IF_ERROR(RejectEndlessRecursion());
    auto compiled = std::make_shared<CompiledSchema>();
    compiled->nodes = std::move(nodes_);
    return std::shared_ptr<const CompiledSchema>(std::move(compiled));
  }

 private:
  Status Error(std::string_view pointer, const std::string& message) const {
    return InvalidArgumentError(Where(name_, pointer) + ": " + message);
  }

  Result<int> CompileAt(const json& schema, const std::string& pointer, int depth) {
    if (const auto it = index_by_pointer_.find(pointer); it != index_by_pointer_.end()) return it->second;
    if (depth > kMaxSchemaDepth) {
      return Error(pointer, "schema is nested deeper than " + std::to_string(kMaxSchemaDepth) + " levels");
    }
    const int index = static_cast<int>(nodes_.size());
    nodes_.emplace_back();
    pointers_.push_back(pointer);
    index_by_pointer_.emplace(pointer, index);

    Node node;
    if (schema.is_boolean()) {
      node.rejects_everything = !schema.get<bool>();
    } else if (schema.is_object()) {
      for (const auto& [keyword, value] : schema.items()) {
        SOLID_RETURN_IF_ERROR(CompileKeyword(node, index, keyword, value, pointer, depth));
      }
    } else {
      return Error(pointer, "a schema must be an object or a boolean, not " + std::string(TypeName(schema)));
    }
    nodes_[static_cast<size_t>(index)] = std::move(node);
    return index;
  }

  Result<int> Subschema(const json& value, const std::string& pointer, int depth) {
    return CompileAt(value, pointer, depth + 1);
  }

  Result<std::vector<int>> SubschemaArray(const json& value, const std::string& pointer, int depth,
                                          std::string_view keyword) {
    if (!value.is_array() || value.empty())
      return Error(pointer, std::string(keyword) + " must be a non-empty array of schemas");
    std::vector<int> indices;
    for (size_t i = 0; i < value.size(); ++i) {
      SOLID_ASSIGN_OR_RETURN(const int index,
                             Subschema(value[i], ChildPointer(pointer, std::to_string(i)), depth));
      indices.push_back(index);
    }
    return indices;
  }

  Result<uint64_t> NonNegativeInteger(const json& value, const std::string& pointer,
                                      std::string_view keyword) const {
    if (value.is_number_unsigned()) return value.get<uint64_t>();
    if (value.is_number() && IsIntegral(value) && NumberValue(value) >= 0) {
      // A float such as 1e30 is a valid bound that no count can reach.
      const long double x = NumberValue(value);
      return x >= 18446744073709551615.0L ? UINT64_MAX : static_cast<uint64_t>(x);
    }
    return Error(pointer, std::string(keyword) + " must be a non-negative integer, not " + Describe(value));
  }

  Result<std::vector<std::string>> UniqueStrings(const json& value, const std::string& pointer,
                                                 std::string_view keyword) const {
    std::vector<std::string> strings;
    if (value.is_array()) {
      for (const json& element : value) {
        if (!element.is_string()) break;
        if (std::find(strings.begin(), strings.end(), element.get<std::string>()) != strings.end()) {
          return Error(pointer,
                       std::string(keyword) + " lists " + Quoted(element.get<std::string>()) + " twice");
        }
        strings.push_back(element.get<std::string>());
      }
      if (strings.size() == value.size()) return strings;
    }
    return Error(pointer, std::string(keyword) + " must be an array of strings");
  }

  Result<Pattern> CompilePattern(const std::string& source, const std::string& pointer) const {
    try {
      return Pattern{source, std::regex(source, std::regex::ECMAScript)};
    } catch (const std::regex_error& error) {
      return Error(pointer,
                   "invalid or unsupported regular expression " + Quoted(source) + ": " + error.what());
    }
  }

  Status CompileKeyword(Node& node, int node_index, const std::string& keyword, const json& value,
                        const std::string& pointer, int depth) {
    const std::string at = ChildPointer(pointer, keyword);
    const bool is_root = pointer.empty();
    if (IsAnnotation(keyword)) return Status::Ok();
    if (keyword == "$schema") {
      if (!is_root) return Error(at, "$schema is only supported at the root (no embedded schema resources)");
      if (!value.is_string() || (value.get<std::string>() != kDraft202012 &&
                                 value.get<std::string>() != std::string(kDraft202012) + "#")) {
        return Error(at, "only draft 2020-12 (" + std::string(kDraft202012) + ") is supported, not " +
                             Describe(value));
      }
      return Status::Ok();
    }
    if (keyword == "$id") {
      if (!is_root) return Error(at, "$id is only supported at the root (no embedded schema resources)");
      if (!value.is_string()) return Error(at, "$id must be a string");
      return Status::Ok();
    }
    if (keyword == "type") {
      std::vector<std::string> names;
      if (value.is_string()) {
        names.push_back(value.get<std::string>());
      } else {
        SOLID_ASSIGN_OR_RETURN(names, UniqueStrings(value, at, keyword));
        if (names.empty()) return Error(at, "type must not be an empty array");
      }
      for (const std::string& name : names) {
        const auto& known = TypeNames();
        const auto it =
            std::find_if(known.begin(), known.end(), [&](const auto& entry) { return entry.first == name; });
        if (it == known.end()) return Error(at, "unknown type " + Quoted(name));
        node.allowed_types |= it->second;
      }
      return Status::Ok();
    }
    if (keyword == "enum") {
      if (!value.is_array()) return Error(at, "enum must be an array");
      node.enum_values = value;
      return Status::Ok();
    }
    if (keyword == "const") {
      node.const_value = value;
      return Status::Ok();
    }
    if (keyword == "properties" || keyword == "patternProperties" || keyword == "$defs") {
      if (!value.is_object()) return Error(at, keyword + " must be an object whose values are schemas");
      for (const auto& [name, subschema] : value.items()) {
        SOLID_ASSIGN_OR_RETURN(const int index, Subschema(subschema, ChildPointer(at, name), depth));
        if (keyword == "properties") {
          node.properties.emplace(name, index);
        } else if (keyword == "patternProperties") {
          SOLID_ASSIGN_OR_RETURN(Pattern pattern, CompilePattern(name, ChildPointer(at, name)));
          node.pattern_properties.emplace_back(std::move(pattern), index);
        }
      }
      return Status::Ok();
    }
    if (keyword == "additionalProperties") {
      SOLID_ASSIGN_OR_RETURN(node.additional_properties, Subschema(value, at, depth));
      return Status::Ok();
    }
    if (keyword == "required") {
      SOLID_ASSIGN_OR_RETURN(node.required, UniqueStrings(value, at, keyword));
      return Status::Ok();
    }
    if (keyword == "dependentRequired") {
      if (!value.is_object())
        return Error(at, "dependentRequired must be an object whose values are arrays of strings");
      for (const auto& [name, dependencies] : value.items()) {
        SOLID_ASSIGN_OR_RETURN(auto names, UniqueStrings(dependencies, ChildPointer(at, name), keyword));
        node.dependent_required.emplace_back(name, std::move(names));
      }
      return Status::Ok();
    }
    if (keyword == "prefixItems") {
      SOLID_ASSIGN_OR_RETURN(node.prefix_items, SubschemaArray(value, at, depth, keyword));
      return Status::Ok();
    }
    if (keyword == "items") {
      if (value.is_array()) {
        return Error(at, "items must be a schema; an array of schemas is prefixItems in draft 2020-12");
      }
      SOLID_ASSIGN_OR_RETURN(node.items, Subschema(value, at, depth));
      return Status::Ok();
    }
    if (keyword == "uniqueItems") {
      if (!value.is_boolean()) return Error(at, "uniqueItems must be a boolean");
      node.unique_items = value.get<bool>();
      return Status::Ok();
    }
    const std::pair<std::string_view, std::optional<uint64_t> Node::*> kCounts[] = {
        {"minItems", &Node::min_items},           {"maxItems", &Node::max_items},
        {"minLength", &Node::min_length},         {"maxLength", &Node::max_length},
        {"minProperties", &Node::min_properties}, {"maxProperties", &Node::max_properties}};
    for (const auto& [name, member] : kCounts) {
      if (keyword != name) continue;
      SOLID_ASSIGN_OR_RETURN(node.*member, NonNegativeInteger(value, at, keyword));
      return Status::Ok();
    }
    const std::pair<std::string_view, std::optional<json> Node::*> kBounds[] = {
        {"minimum", &Node::minimum},
        {"maximum", &Node::maximum},
        {"exclusiveMinimum", &Node::exclusive_minimum},
        {"exclusiveMaximum", &Node::exclusive_maximum},
        {"multipleOf", &Node::multiple_of}};
    for (const auto& [name, member] : kBounds) {
      if (keyword != name) continue;
      if (!value.is_number()) return Error(at, keyword + " must be a number");
      if (keyword == "multipleOf" && !(NumberValue(value) > 0))
        return Error(at, "multipleOf must be greater than 0");
      node.*member = value;
      return Status::Ok();
    }
    if (keyword == "pattern") {
      if (!value.is_string()) return Error(at, "pattern must be a string");
      SOLID_ASSIGN_OR_RETURN(node.pattern, CompilePattern(value.get<std::string>(), at));
      return Status::Ok();
    }
    const std::pair<std::string_view, std::vector<int> Node::*> kCombinations[] = {
        {"allOf", &Node::all_of}, {"anyOf", &Node::any_of}, {"oneOf", &Node::one_of}};
    for (const auto& [name, member] : kCombinations) {
      if (keyword != name) continue;
      SOLID_ASSIGN_OR_RETURN(node.*member, SubschemaArray(value, at, depth, keyword));
      return Status::Ok();
    }
    const std::pair<std::string_view, int Node::*> kSingles[] = {{"not", &Node::not_schema},
                                                                 {"if", &Node::if_schema},
                                                                 {"then", &Node::then_schema},
                                                                 {"else", &Node::else_schema}};
    for (const auto& [name, member] : kSingles) {
      if (keyword != name) continue;
      SOLID_ASSIGN_OR_RETURN(node.*member, Subschema(value, at, depth));
      return Status::Ok();
    }
    if (keyword == "$ref") {
      const std::string reference = value.is_string() ? value.get<std::string>() : std::string();
      std::optional<std::string> target;
      if (reference.starts_with("#")) target = PercentDecoded(std::string_view(reference).substr(1));
      if (!target || !(target->empty() || target->starts_with("/"))) {
        return Error(
            at,
            "only a $ref to a JSON Pointer within this schema (\"#\", \"#/$defs/name\") is supported, not " +
                Describe(value));
      }
      // Resolved once every subschema is compiled, so that reference chains do not recurse.
      unresolved_refs_.push_back({node_index, std::move(*target), at});
      return Status::Ok();
    }
    return Error(
        at, "unsupported keyword " + Quoted(keyword) + DidYouMean(ClosestName(keyword, SupportedKeywords())));
  }

  Status ResolveRefs() {
    while (!unresolved_refs_.empty()) {
      const UnresolvedRef ref = std::move(unresolved_refs_.back());
      unresolved_refs_.pop_back();
      const json* target = Resolve(root_, ref.target);
      if (target == nullptr)
        return Error(ref.at, "$ref \"#" + ref.target + "\" names nothing in this schema");
      SOLID_ASSIGN_OR_RETURN(const int index, CompileAt(*target, ref.target, 0));
      nodes_[static_cast<size_t>(ref.from)].ref = index;
    }
    return Status::Ok();
  }

  // A cycle of $ref, allOf, anyOf, oneOf, not or if/then/else applies a schema to the very
  // value it is applying to, forever: refuse it now rather than overflow the stack later.
  Status RejectEndlessRecursion() const {
    enum class Visit : uint8_t { kNew, kOnPath, kDone };
    std::vector<Visit> visits(nodes_.size(), Visit::kNew);
    std::vector<std::vector<int>> edges(nodes_.size());
    for (size_t i = 0; i < nodes_.size(); ++i) {
      const Node& node = nodes_[i];
      std::vector<int>& out = edges[i];
      out.insert(out.end(), node.all_of.begin(), node.all_of.end());
      out.insert(out.end(), node.any_of.begin(), node.any_of.end());
      out.insert(out.end(), node.one_of.begin(), node.one_of.end());
      // then/else apply only under an if.
      const int kSingles[] = {node.ref, node.not_schema, node.if_schema,
                              node.if_schema == kNoSchema ? kNoSchema : node.then_schema,
                              node.if_schema == kNoSchema ? kNoSchema : node.else_schema};
      for (int single : kSingles) {
        if (single != kNoSchema) out.push_back(single);
      }
    }
    struct Frame {
      int node;
      size_t next_edge;
    };
    for (size_t start = 0; start < nodes_.size(); ++start) {
      if (visits[start] != Visit::kNew) continue;
      std::vector<Frame> path = {{static_cast<int>(start), 0}};
      visits[start] = Visit::kOnPath;
      while (!path.empty()) {
        Frame& frame = path.back();
        const std::vector<int>& out = edges[static_cast<size_t>(frame.node)];
        if (frame.next_edge == out.size()) {
          visits[static_cast<size_t>(frame.node)] = Visit::kDone;
          path.pop_back();
          continue;
        }
        const int next = out[frame.next_edge++];
        if (visits[static_cast<size_t>(next)] == Visit::kOnPath) {
          return Error(
              pointers_[static_cast<size_t>(next)],
              "schema applies itself to the same value endlessly (a $ref cycle that never descends into "
              "a property or item)");
        }
        if (visits[static_cast<size_t>(next)] == Visit::kNew) {
          visits[static_cast<size_t>(next)] = Visit::kOnPath;
          path.push_back({next, 0});
        }
      }
    }
    return Status::Ok();
  }

  struct UnresolvedRef {
    int from;            // the node holding the $ref
    std::string target;  // JSON Pointer, percent-decoded
    std::string at;      // where the $ref is, for messages
  };

  const json& root_;
  std::string name_;
  std::vector<Node> nodes_;
  std::vector<std::string> pointers_;  // schema location of each node, for messages
  std::unordered_map<std::string, int> index_by_pointer_;
  std::vector<UnresolvedRef> unresolved_refs_;
};

// ---------------------------------------------------------------------------------------------
// Validation

enum class PatternMatch : uint8_t { kMatch, kNoMatch, kSubjectTooLong };

// Out of line: the regex matcher's locals must not join the frames of the recursive validator.
[[gnu::noinline]] PatternMatch Search(const Pattern& pattern, const std::string& subject) {
  if (subject.size() > Schema::kMaxPatternSubjectBytes) return PatternMatch::kSubjectTooLong;
  return std::regex_search(subject, pattern.regex) ? PatternMatch::kMatch : PatternMatch::kNoMatch;
}

std::string TooLongForPattern(std::string_view what, const std::string& subject, const Pattern& pattern) {
  return std::string(what) + " of " + std::to_string(subject.size()) +
         " bytes is too long to match against pattern " + pattern.source + " (the limit is " +
         std::to_string(Schema::kMaxPatternSubjectBytes) + " bytes)";
}

std::string Plural(uint64_t count, std::string_view noun) {
  return std::to_string(count) + " " + std::string(noun) + (count == 1 ? "" : "s");
}

// Apply recurses once per level of the instance and once per applicator ($ref, allOf, ...),
// so what is on that path must use little stack: the keyword checks and message building,
// which do not recurse, are kept out of line so that their locals are not part of every level's
// frame (with sanitizers a frame with everything inlined took 8 KiB).
class Validator {
 public:
  explicit Validator(const CompiledSchema& schema) : nodes_(schema.nodes) {}

  // Stops adding to `out` once it holds limit_ violations.
  void Apply(int index, const json& instance, std::vector<Violation>& out) {
    if (out.size() >= limit_) return;
    if (depth_ >= kMaxValidationDepth) {
      ReportTooDeep(out);
      return;
    }
    ++depth_;
    const Node& node = nodes_[static_cast<size_t>(index)];
    if (node.rejects_everything) {
      ReportRejected(out);
    } else {
      CheckValue(node, instance, out);
      if (instance.is_array()) ApplyItems(node, instance, out);
      if (instance.is_object()) ApplyProperties(node, instance, out);
      ApplyApplicators(node, instance, out);
    }
    --depth_;
  }

 private:
  void Add(std::vector<Violation>& out, std::string message) {
    if (out.size() < limit_) out.push_back({pointer_, std::move(message)});
  }

  void AddAtChild(std::vector<Violation>& out, std::string_view token, std::string message) {
    const size_t length = pointer_.size();
    AppendPointerToken(pointer_, token);
    Add(out, std::move(message));
    pointer_.resize(length);
  }

  // Applies a subschema to a child value, with the pointer extended by `token`.
  void ApplyToChild(int index, const json& child, std::string_view token, std::vector<Violation>& out) {
    const size_t length = pointer_.size();
    AppendPointerToken(pointer_, token);
    Apply(index, child, out);
    pointer_.resize(length);
  }

  // The first violation of `index` on `instance`, if any: enough to decide a branch of
  // anyOf/oneOf/not/if and to explain its failure, without collecting the rest.
  std::optional<Violation> FirstViolation(int index, const json& instance) {
    std::vector<Violation> violations;
    const size_t saved_limit = std::exchange(limit_, 1);
    Apply(index, instance, violations);
    limit_ = saved_limit;
    if (violations.empty()) return std::nullopt;
    return std::move(violations.front());
  }

  void ApplyItems(const Node& node, const json& instance, std::vector<Violation>& out) {
    const size_t size = instance.size();
    const size_t prefix = std::min(size, node.prefix_items.size());
    for (size_t i = 0; i < prefix; ++i)
      ApplyToChild(node.prefix_items[i], instance[i], std::to_string(i), out);
    if (node.items == kNoSchema) return;
    const bool items_forbidden = nodes_[static_cast<size_t>(node.items)].rejects_everything;
    for (size_t i = prefix; i < size && out.size() < limit_; ++i) {
      if (items_forbidden) {
        ReportUnexpectedItem(out, i, node.prefix_items.size());
      } else {
        ApplyToChild(node.items, instance[i], std::to_string(i), out);
      }
    }
  }

  void ApplyProperties(const Node& node, const json& instance, std::vector<Violation>& out) {
    // The map itself rather than items(), whose iteration proxies carry strings of their own.
    for (const auto& [name, value] : instance.get_ref<const json::object_t&>()) {
      if (out.size() >= limit_) return;
      bool evaluated = false;
      if (const auto it = node.properties.find(name); it != node.properties.end()) {
        evaluated = true;
        ApplyToChild(it->second, value, name, out);
      }
      for (const auto& [pattern, index] : node.pattern_properties) {
        switch (Search(pattern, name)) {
          case PatternMatch::kMatch:
            evaluated = true;
            ApplyToChild(index, value, name, out);
            break;
          case PatternMatch::kNoMatch: break;
          case PatternMatch::kSubjectTooLong: ReportKeyTooLongForPattern(out, name, pattern); break;
        }
      }
      if (evaluated || node.additional_properties == kNoSchema) continue;
      if (nodes_[static_cast<size_t>(node.additional_properties)].rejects_everything) {
        ReportUnknownKey(out, node, name);
      } else {
        ApplyToChild(node.additional_properties, value, name, out);
      }
    }
  }

  void ApplyApplicators(const Node& node, const json& instance, std::vector<Violation>& out) {
    if (node.ref != kNoSchema) Apply(node.ref, instance, out);
    for (int index : node.all_of) Apply(index, instance, out);
    if (!node.any_of.empty()) ApplyAnyOf(node, instance, out);
    if (!node.one_of.empty()) ApplyOneOf(node, instance, out);
    if (node.not_schema != kNoSchema && !FirstViolation(node.not_schema, instance)) ReportMatchesNot(out);
    if (node.if_schema != kNoSchema) {
      const int branch = FirstViolation(node.if_schema, instance) ? node.else_schema : node.then_schema;
      if (branch != kNoSchema) Apply(branch, instance, out);
    }
  }

  [[gnu::noinline]] void ApplyAnyOf(const Node& node, const json& instance, std::vector<Violation>& out) {
    std::vector<std::optional<Violation>> failures;
    for (int index : node.any_of) {
      failures.push_back(FirstViolation(index, instance));
      if (!failures.back()) return;
    }
    ReportNoAlternative(out, "anyOf", failures);
  }

  [[gnu::noinline]] void ApplyOneOf(const Node& node, const json& instance, std::vector<Violation>& out) {
    std::vector<std::optional<Violation>> failures;
    std::optional<size_t> first_match;
    for (size_t i = 0; i < node.one_of.size(); ++i) {
      failures.push_back(FirstViolation(node.one_of[i], instance));
      if (failures.back()) continue;
      if (first_match) {
        ReportSeveralAlternatives(out, *first_match, i);
        return;
      }
      first_match = i;
    }
    if (!first_match) ReportNoAlternative(out, "oneOf", failures);
  }

  // The keywords that look at the value itself, not into its items or properties.
  [[gnu::noinline]] void CheckValue(const Node& node, const json& instance, std::vector<Violation>& out) {
    if (node.allowed_types != 0 && (node.allowed_types & InstanceTypeBits(instance)) == 0) {
      Add(out, "expected " + DescribeTypes(node.allowed_types) + ", got " + std::string(TypeName(instance)));
    }
    if (node.const_value && instance != *node.const_value) {
      Add(out, "expected " + DescribeSchemaValue(*node.const_value) + ", got " + Describe(instance));
    }
    if (node.enum_values &&
        std::find(node.enum_values->begin(), node.enum_values->end(), instance) == node.enum_values->end()) {
      constexpr size_t kMaxListed = 10;
      std::string allowed;
      for (size_t i = 0; i < node.enum_values->size() && i < kMaxListed; ++i) {
        allowed += (i == 0 ? "" : ", ") + DescribeSchemaValue((*node.enum_values)[i]);
      }
      if (node.enum_values->size() > kMaxListed) allowed += ", ...";
      Add(out, Describe(instance) + " is not one of " + allowed);
    }
    if (instance.is_number()) CheckNumber(node, instance, out);
    if (instance.is_string()) CheckString(node, instance.get_ref<const std::string&>(), out);
    if (instance.is_array()) CheckArray(node, instance, out);
    if (instance.is_object()) CheckObject(node, instance, out);
  }

  void CheckNumber(const Node& node, const json& instance, std::vector<Violation>& out) {
    const long double x = NumberValue(instance);
    const std::string shown = Describe(instance);
    if (node.minimum && x < NumberValue(*node.minimum)) {
      Add(out, shown + " is less than the minimum " + Dump(*node.minimum));
    }
    if (node.maximum && x > NumberValue(*node.maximum)) {
      Add(out, shown + " is greater than the maximum " + Dump(*node.maximum));
    }
    if (node.exclusive_minimum && x <= NumberValue(*node.exclusive_minimum)) {
      Add(out, shown + " is not greater than the exclusive minimum " + Dump(*node.exclusive_minimum));
    }
    if (node.exclusive_maximum && x >= NumberValue(*node.exclusive_maximum)) {
      Add(out, shown + " is not less than the exclusive maximum " + Dump(*node.exclusive_maximum));
    }
    if (node.multiple_of && !IsMultiple(instance, *node.multiple_of)) {
      Add(out, shown + " is not a multiple of " + Dump(*node.multiple_of));
    }
  }

  static bool IsMultiple(const json& instance, const json& divisor) {
    if (IsIntegral(instance) && IsIntegral(divisor)) {
      // fmod is exact, and long double holds both exactly.
      return std::fmod(NumberValue(instance), NumberValue(divisor)) == 0;
    }
    // A fractional divisor such as 0.01 has no exact binary value: allow for rounding in the
    // quotient. An overflowing quotient cannot be shown to be whole, so it is not a multiple.
    const double quotient = instance.get<double>() / divisor.get<double>();
    if (!std::isfinite(quotient)) return false;
    return std::abs(quotient - std::round(quotient)) <= 1e-9 * std::max(1.0, std::abs(quotient));
  }

  void CheckString(const Node& node, const std::string& instance, std::vector<Violation>& out) {
    if (node.min_length || node.max_length) {
      const size_t length = CountCodePoints(instance);
      if (node.min_length && length < *node.min_length) {
        Add(out,
            "expected at least " + Plural(*node.min_length, "character") + ", got " + std::to_string(length));
      }
      if (node.max_length && length > *node.max_length) {
        Add(out,
            "expected at most " + Plural(*node.max_length, "character") + ", got " + std::to_string(length));
      }
    }
    if (node.pattern) {
      switch (Search(*node.pattern, instance)) {
        case PatternMatch::kMatch: break;
        case PatternMatch::kNoMatch: Add(out, "does not match pattern " + node.pattern->source); break;
        case PatternMatch::kSubjectTooLong:
          Add(out, TooLongForPattern("string", instance, *node.pattern));
          break;
      }
    }
  }

  void CheckArray(const Node& node, const json& instance, std::vector<Violation>& out) {
    const size_t size = instance.size();
    if (node.min_items && size < *node.min_items) {
      Add(out, "expected at least " + Plural(*node.min_items, "item") + ", got " + std::to_string(size));
    }
    if (node.max_items && size > *node.max_items) {
      Add(out, "expected at most " + Plural(*node.max_items, "item") + ", got " + std::to_string(size));
    }
    if (node.unique_items && size > 1) {
      // Sorting keeps this O(n log n) on untrusted arrays; nlohmann's < and == agree, and
      // both treat 1 and 1.0 as the same number, as JSON Schema requires.
      std::vector<size_t> order(size);
      std::iota(order.begin(), order.end(), size_t{0});
      std::stable_sort(order.begin(), order.end(),
                       [&](size_t a, size_t b) { return instance[a] < instance[b]; });
      for (size_t i = 1; i < size; ++i) {
        if (instance[order[i - 1]] == instance[order[i]]) {
          Add(out, "items " + std::to_string(order[i - 1]) + " and " + std::to_string(order[i]) +
                       " are equal, but items must be unique");
          break;
        }
      }
    }
  }

  void CheckObject(const Node& node, const json& instance, std::vector<Violation>& out) {
    const size_t size = instance.size();
    if (node.min_properties && size < *node.min_properties) {
      Add(out, "expected at least " + Plural(*node.min_properties, "key") + ", got " + std::to_string(size));
    }
    if (node.max_properties && size > *node.max_properties) {
      Add(out, "expected at most " + Plural(*node.max_properties, "key") + ", got " + std::to_string(size));
    }
    for (const std::string& name : node.required) {
      if (!instance.contains(name)) Add(out, "missing required key " + Quoted(name));
    }
    for (const auto& [name, dependencies] : node.dependent_required) {
      if (!instance.contains(name)) continue;
      for (const std::string& dependency : dependencies) {
        if (!instance.contains(dependency)) {
          Add(out, "key " + Quoted(dependency) + " is required when " + Quoted(name) + " is present");
        }
      }
    }
  }

  [[gnu::noinline]] void ReportTooDeep(std::vector<Violation>& out) {
    Add(out,
        "nesting is deeper than the " + std::to_string(kMaxValidationDepth) + " levels validation allows");
  }

  [[gnu::noinline]] void ReportRejected(std::vector<Violation>& out) {
    Add(out, "no value is allowed here (the schema is false)");
  }

  [[gnu::noinline]] void ReportUnexpectedItem(std::vector<Violation>& out, size_t index, size_t allowed) {
    AddAtChild(out, std::to_string(index), "unexpected item: expected at most " + Plural(allowed, "item"));
  }

  [[gnu::noinline]] void ReportKeyTooLongForPattern(std::vector<Violation>& out, const std::string& name,
                                                    const Pattern& pattern) {
    AddAtChild(out, name, TooLongForPattern("key", name, pattern));
  }

  [[gnu::noinline]] void ReportUnknownKey(std::vector<Violation>& out, const Node& node,
                                          const std::string& name) {
    std::vector<std::string_view> known;
    for (const auto& property : node.properties) known.push_back(property.first);
    AddAtChild(out, name, "unknown key " + Quoted(name) + DidYouMean(ClosestName(name, known)));
  }

  [[gnu::noinline]] void ReportMatchesNot(std::vector<Violation>& out) {
    Add(out, "matches the schema under \"not\"");
  }

  [[gnu::noinline]] void ReportSeveralAlternatives(std::vector<Violation>& out, size_t first, size_t second) {
    Add(out, "matches oneOf alternatives " + std::to_string(first) + " and " + std::to_string(second) +
                 ", but must match exactly one");
  }

  // "matches none of the anyOf alternatives: [0] expected string, got integer; [1] /a: ..."
  [[gnu::noinline]] void ReportNoAlternative(std::vector<Violation>& out, std::string_view keyword,
                                             const std::vector<std::optional<Violation>>& failures) {
    std::string message = "matches none of the " + std::string(keyword) + " alternatives: ";
    for (size_t i = 0; i < failures.size(); ++i) {
      if (i > 0) message += "; ";
      message += fmt::format("[{}] ", i);
      const Violation& failure = *failures[i];
      if (failure.pointer != pointer_) message += failure.pointer + ": ";
      message += failure.message;
    }
    Add(out, std::move(message));
  }

  const std::vector<Node>& nodes_;
  size_t limit_ = Schema::kMaxViolations;
  size_t depth_ = 0;
  std::string pointer_;
};

}  // namespace

Result<Schema> Schema::Compile(const json& schema, std::string_view name) {
  try {
    SOLID_ASSIGN_OR_RETURN(auto compiled, Compiler(schema, name).Run());
    return Schema(std::move(compiled));
  } catch (const json::exception& error) {
    return InternalError(std::string(name) + ": compiling the schema failed: " + error.what());
  }
}

std::vector<Violation> Schema::Validate(const json& instance) const {
  std::vector<Violation> violations;
  Validator(*compiled_).Apply(0, instance, violations);
  if (violations.size() >= kMaxViolations) {
    violations.push_back(
        {"", "stopped after " + std::to_string(kMaxViolations) + " violations; there may be more"});
  }
  return violations;
}

Status Schema::Check(const json& instance, std::string_view instance_name,
                     std::string_view instance_text) const {
  const std::vector<Violation> violations = Validate(instance);
  if (violations.empty()) return Status::Ok();
  const size_t reported = std::min(violations.size(), kMaxReportedViolations);
  std::vector<std::string> pointers;
  for (size_t i = 0; i < reported; ++i) pointers.push_back(violations[i].pointer);
  const std::vector<size_t> lines =
      instance_text.empty() ? std::vector<size_t>(reported, 0) : FindPointerLines(instance_text, pointers);
  std::string message;
  for (size_t i = 0; i < reported; ++i) {
    if (i > 0) message += '\n';
    message += instance_name;
    if (lines[i] != 0) message += ":" + std::to_string(lines[i]);
    if (!violations[i].pointer.empty()) message += ": " + Truncated(violations[i].pointer, 200);
    message += ": " + violations[i].message;
  }
  if (violations.size() > reported) {
    message += "\n" + std::string(instance_name) + ": ... and " +
               std::to_string(violations.size() - reported) + " more violations";
  }
  return ParseError(std::move(message));
}

}  // namespace solid::json
