#include "solid/formats/json_schema.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace solid::json {
namespace {

using nlohmann::json;
using testing::ElementsAre;
using testing::HasSubstr;
using testing::IsEmpty;
using testing::Pair;
using testing::StartsWith;

std::string ReadFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

Schema MustCompile(std::string_view schema_text) {
  auto schema = Schema::Compile(json::parse(schema_text), "test.schema.json");
  if (schema.ok()) return std::move(schema).value();
  ADD_FAILURE() << schema.status().ToString();
  return MustCompile("true");  // lets the test go on to report its own failures
}

Status CompileStatus(std::string_view schema_text) {
  return Schema::Compile(json::parse(schema_text), "test.schema.json").status();
}

// (pointer, message) pairs: short to assert with ElementsAre(Pair(...)).
std::vector<std::pair<std::string, std::string>> Violations(const Schema& schema,
                                                            std::string_view instance_text) {
  std::vector<std::pair<std::string, std::string>> pairs;
  for (auto& violation : schema.Validate(json::parse(instance_text))) {
    pairs.emplace_back(std::move(violation.pointer), std::move(violation.message));
  }
  return pairs;
}

// ---------------------------------------------------------------------------------------------
// ParseJson

TEST(ParseJsonTest, ParsesValidText) {
  auto value = ParseJson(R"({"a": [1, 2.5, "x", true, null], "b": {}})", "t.json");
  ASSERT_TRUE(value.ok()) << value.status().ToString();
  EXPECT_EQ(*value, json::parse(R"({"a": [1, 2.5, "x", true, null], "b": {}})"));
}

TEST(ParseJsonTest, SyntaxErrorGivesLineAndColumn) {
  auto value = ParseJson("{\n  \"a\": 1,\n  \"b\": tru\n}", "params.json");
  ASSERT_FALSE(value.ok());
  EXPECT_EQ(value.status().code(), StatusCode::kParseError);
  EXPECT_EQ(value.status().message(),
            "params.json:3:11: syntax error while parsing value - invalid literal; last read: '\"b\": "
            "tru<U+000A>'");
}

TEST(ParseJsonTest, TrailingCommaPointsAtTheBracket) {
  auto value = ParseJson("[1,\n 2,]", "t.json");
  ASSERT_FALSE(value.ok());
  EXPECT_THAT(value.status().message(),
              StartsWith("t.json:2:4: syntax error while parsing value - unexpected ']'"));
}

TEST(ParseJsonTest, ColumnCountsCodePoints) {
  auto value = ParseJson(R"(["żółw", x])", "t.json");
  ASSERT_FALSE(value.ok());
  EXPECT_THAT(value.status().message(), StartsWith("t.json:1:10: "));
}

TEST(ParseJsonTest, EmptyAndTruncatedInput) {
  auto empty = ParseJson("", "t.json");
  ASSERT_FALSE(empty.ok());
  EXPECT_THAT(empty.status().message(),
              StartsWith("t.json:1:1: syntax error while parsing value - unexpected end of input"));
  auto truncated = ParseJson("{\"a\": [1,\n", "t.json");
  ASSERT_FALSE(truncated.ok());
  EXPECT_THAT(truncated.status().message(), StartsWith("t.json:2:1: syntax error"));
}

TEST(ParseJsonTest, TrailingGarbageIsAnError) {
  auto value = ParseJson("{} {}", "t.json");
  ASSERT_FALSE(value.ok());
  EXPECT_THAT(value.status().message(), StartsWith("t.json:1:4: syntax error"));
}

TEST(ParseJsonTest, NumberOverflowAndBadUtf8AreErrors) {
  auto overflow = ParseJson("[1e400]", "t.json");
  ASSERT_FALSE(overflow.ok());
  EXPECT_EQ(overflow.status().code(), StatusCode::kParseError);
  EXPECT_THAT(overflow.status().message(), HasSubstr("number overflow"));
  auto bad_utf8 = ParseJson("[\"\xff\"]", "t.json");
  ASSERT_FALSE(bad_utf8.ok());
  EXPECT_THAT(bad_utf8.status().message(), StartsWith("t.json:1:3: syntax error"));
}

TEST(ParseJsonTest, DuplicateKeyIsAnError) {
  auto value = ParseJson("{\n  \"seed\": 1,\n  \"seed\": 2\n}", "t.json");
  ASSERT_FALSE(value.ok());
  EXPECT_EQ(value.status().code(), StatusCode::kParseError);
  EXPECT_EQ(value.status().message(), "t.json:3:3: duplicate key \"seed\"");
  EXPECT_TRUE(ParseJson(R"({"a": {"x": 1}, "b": {"x": 2}})", "t.json").ok());
}

TEST(ParseJsonTest, DeeplyNestedArrayIsRefusedCleanly) {
  const std::string deep = std::string(10000, '[') + std::string(10000, ']');
  auto value = ParseJson(deep, "deep.json");
  ASSERT_FALSE(value.ok());
  EXPECT_EQ(value.status().code(), StatusCode::kLimitExceeded);
  EXPECT_EQ(value.status().message(), "deep.json:1:65: nesting is deeper than the limit of 64 levels");

  auto unclosed = ParseJson(std::string(100000, '['), "deep.json");
  ASSERT_FALSE(unclosed.ok());
  EXPECT_EQ(unclosed.status().code(), StatusCode::kLimitExceeded);
}

TEST(ParseJsonTest, DepthLimitCountsObjectsAndArrays) {
  std::string nested;
  for (int i = 0; i < 4; ++i) nested += i % 2 == 0 ? "{\"k\":" : "[";
  nested += "1]}]}";
  EXPECT_TRUE(ParseJson(nested, "t.json", {.max_depth = 4}).ok());
  auto too_deep = ParseJson(nested, "t.json", {.max_depth = 3});
  ASSERT_FALSE(too_deep.ok());
  EXPECT_EQ(too_deep.status().message(), "t.json:1:12: nesting is deeper than the limit of 3 levels");
}

TEST(ParseJsonTest, SizeAndStringLimits) {
  auto big = ParseJson("[1, 2, 3]", "t.json", {.max_bytes = 8});
  ASSERT_FALSE(big.ok());
  EXPECT_EQ(big.status().code(), StatusCode::kLimitExceeded);
  EXPECT_EQ(big.status().message(), "t.json: 9 bytes is more than the limit of 8 bytes");

  auto long_string =
      ParseJson("{\"a\": \"0123456789\",\n \"b\": \"01234567890\"}", "t.json", {.max_string_length = 10});
  ASSERT_FALSE(long_string.ok());
  EXPECT_EQ(long_string.status().code(), StatusCode::kLimitExceeded);
  EXPECT_EQ(long_string.status().message(),
            "t.json:2:7: string of 11 bytes is longer than the limit of 10 bytes");

  auto long_key = ParseJson(R"({"a\"b\\cdefghi": 1})", "t.json", {.max_string_length = 10});
  ASSERT_FALSE(long_key.ok());
  EXPECT_THAT(long_key.status().message(), StartsWith("t.json:1:2: string of 11 bytes"));
}

// ---------------------------------------------------------------------------------------------
// FindPointerLines

TEST(FindPointerLinesTest, FindsKeysItemsAndRoot) {
  const std::string text = R"({
  "a": 1,
  "b": [
    10,
    {"c": true,
     "d~e/f": null}
  ],
  "\u0067": "escaped key"
})";
  const std::vector<std::string> pointers = {
      "", "/a", "/b", "/b/0", "/b/1", "/b/1/c", "/b/1/d~0e~1f", "/g", "/b/2", "/missing", "/a/0"};
  EXPECT_THAT(FindPointerLines(text, pointers), ElementsAre(1, 2, 3, 4, 5, 5, 6, 8, 0, 0, 0));
}

TEST(FindPointerLinesTest, MalformedTextGivesZerosNotErrors) {
  EXPECT_THAT(FindPointerLines("{\"a\": [1, }}}]]]", {"/a", "/b"}), ElementsAre(1, 0));
  EXPECT_THAT(FindPointerLines("", {"", "/a"}), ElementsAre(0, 0));
  EXPECT_THAT(FindPointerLines(std::string(100000, '['), {"/0/0/0"}), ElementsAre(1));
}

// ---------------------------------------------------------------------------------------------
// Keywords

TEST(SchemaKeywordTest, Type) {
  const Schema schema = MustCompile(R"({"type": "integer"})");
  EXPECT_THAT(Violations(schema, "3"), IsEmpty());
  EXPECT_THAT(Violations(schema, "3.0"), IsEmpty()) << "1.0 is an integer per the spec";
  EXPECT_THAT(Violations(schema, "3.5"), ElementsAre(Pair("", "expected integer, got number")));
  EXPECT_THAT(Violations(schema, "\"3\""), ElementsAre(Pair("", "expected integer, got string")));

  const Schema several = MustCompile(R"({"type": ["string", "null"]})");
  EXPECT_THAT(Violations(several, "null"), IsEmpty());
  EXPECT_THAT(Violations(several, "\"x\""), IsEmpty());
  EXPECT_THAT(Violations(several, "{}"), ElementsAre(Pair("", "expected null or string, got object")));

  const Schema number = MustCompile(R"({"type": "number"})");
  EXPECT_THAT(Violations(number, "18446744073709551615"), IsEmpty());
  EXPECT_THAT(Violations(number, "true"), ElementsAre(Pair("", "expected number, got boolean")));
}

TEST(SchemaKeywordTest, EnumAndConst) {
  const Schema enumeration = MustCompile(R"({"enum": ["png", "jpeg", 1, [1, 2]]})");
  EXPECT_THAT(Violations(enumeration, "\"png\""), IsEmpty());
  EXPECT_THAT(Violations(enumeration, "1.0"), IsEmpty());
  EXPECT_THAT(Violations(enumeration, "[1, 2]"), IsEmpty());
  EXPECT_THAT(Violations(enumeration, "\"gif\""),
              ElementsAre(Pair("", "\"gif\" is not one of \"png\", \"jpeg\", 1, [1,2]")));
  EXPECT_THAT(Violations(enumeration, "{}"),
              ElementsAre(Pair("", "an object is not one of \"png\", \"jpeg\", 1, [1,2]")));

  const Schema constant = MustCompile(R"({"const": "solid-dataset"})");
  EXPECT_THAT(Violations(constant, "\"solid-dataset\""), IsEmpty());
  EXPECT_THAT(Violations(constant, "\"solid\""),
              ElementsAre(Pair("", "expected \"solid-dataset\", got \"solid\"")));
  EXPECT_THAT(Violations(constant, "{}"), ElementsAre(Pair("", "expected \"solid-dataset\", got an object")));
  EXPECT_THAT(Violations(MustCompile(R"({"const": {"a": [1]}})"), R"({"a": [1.0]})"), IsEmpty());
  EXPECT_THAT(Violations(MustCompile(R"({"const": {"a": [1]}})"), R"({"a": [2]})"),
              ElementsAre(Pair("", "expected {\"a\":[1]}, got an object")));
}

TEST(SchemaKeywordTest, PropertiesRequiredAndAdditionalProperties) {
  const Schema schema = MustCompile(R"({
    "properties": {"min_objects": {"type": "integer"}, "max_objects": {"type": "integer"}},
    "required": ["min_objects"],
    "additionalProperties": false})");
  EXPECT_THAT(Violations(schema, R"({"min_objects": 1})"), IsEmpty());
  EXPECT_THAT(Violations(schema, R"({"max_objects": "x"})"),
              ElementsAre(Pair("", "missing required key \"min_objects\""),
                          Pair("/max_objects", "expected integer, got string")));
  EXPECT_THAT(Violations(schema, R"({"min_objects": 1, "min_objets": 2, "zzz": 3})"),
              ElementsAre(Pair("/min_objets", "unknown key \"min_objets\" (did you mean \"min_objects\"?)"),
                          Pair("/zzz", "unknown key \"zzz\"")));
  EXPECT_THAT(Violations(schema, "[1]"), IsEmpty()) << "object keywords ignore other types";

  const Schema additional_schema =
      MustCompile(R"({"properties": {"a": true}, "additionalProperties": {"type": "string"}})");
  EXPECT_THAT(Violations(additional_schema, R"({"a": 1, "b": "x"})"), IsEmpty());
  EXPECT_THAT(Violations(additional_schema, R"({"a": 1, "b": 2})"),
              ElementsAre(Pair("/b", "expected string, got integer")));
}

TEST(SchemaKeywordTest, PatternProperties) {
  const Schema schema = MustCompile(R"({
    "patternProperties": {"^x-": {"type": "string"}, "[0-9]$": {"type": "integer"}},
    "additionalProperties": false})");
  EXPECT_THAT(Violations(schema, R"({"x-a": "s", "n1": 1, "x-1": "s"})"),
              ElementsAre(Pair("/x-1", "expected integer, got string")));
  EXPECT_THAT(Violations(schema, R"({"y": 1})"), ElementsAre(Pair("/y", "unknown key \"y\"")));
}

TEST(SchemaKeywordTest, PointerTokensAreEscaped) {
  const Schema schema = MustCompile(R"({"additionalProperties": {"type": "integer"}})");
  EXPECT_THAT(Violations(schema, R"({"a/b": "x", "c~d": "y"})"),
              ElementsAre(Pair("/a~1b", "expected integer, got string"),
                          Pair("/c~0d", "expected integer, got string")));
}

TEST(SchemaKeywordTest, ItemsAndPrefixItems) {
  const Schema items = MustCompile(R"({"items": {"type": "number"}})");
  EXPECT_THAT(Violations(items, "[1, 2.5]"), IsEmpty());
  EXPECT_THAT(
      Violations(items, R"([1, "a", 2, null])"),
      ElementsAre(Pair("/1", "expected number, got string"), Pair("/3", "expected number, got null")));

  const Schema tuple =
      MustCompile(R"({"prefixItems": [{"type": "string"}, {"type": "integer"}], "items": false})");
  EXPECT_THAT(Violations(tuple, R"(["a", 1])"), IsEmpty());
  EXPECT_THAT(Violations(tuple, R"(["a"])"), IsEmpty());
  EXPECT_THAT(Violations(tuple, R"([1, 1, 2])"),
              ElementsAre(Pair("/0", "expected string, got integer"),
                          Pair("/2", "unexpected item: expected at most 2 items")));

  const Schema rest = MustCompile(R"({"prefixItems": [{"type": "string"}], "items": {"type": "integer"}})");
  EXPECT_THAT(Violations(rest, R"(["a", 1, "b"])"), ElementsAre(Pair("/2", "expected integer, got string")));
}

TEST(SchemaKeywordTest, ItemCountsAndUniqueness) {
  const Schema schema = MustCompile(R"({"minItems": 2, "maxItems": 3, "uniqueItems": true})");
  EXPECT_THAT(Violations(schema, "[1, 2]"), IsEmpty());
  EXPECT_THAT(Violations(schema, "[1]"), ElementsAre(Pair("", "expected at least 2 items, got 1")));
  EXPECT_THAT(Violations(schema, "[1, 2, 3, 4]"), ElementsAre(Pair("", "expected at most 3 items, got 4")));
  EXPECT_THAT(Violations(schema, R"([{"a": 1}, 2, {"a": 1.0}])"),
              ElementsAre(Pair("", "items 0 and 2 are equal, but items must be unique")));
  EXPECT_THAT(Violations(schema, R"([1, true])"), IsEmpty()) << "true is not the number 1";
}

TEST(SchemaKeywordTest, NumericBounds) {
  const Schema schema =
      MustCompile(R"({"minimum": 1, "maximum": 10, "exclusiveMaximum": 10, "multipleOf": 0.5})");
  EXPECT_THAT(Violations(schema, "1"), IsEmpty());
  EXPECT_THAT(Violations(schema, "9.5"), IsEmpty());
  EXPECT_THAT(Violations(schema, "0.5"), ElementsAre(Pair("", "0.5 is less than the minimum 1")));
  EXPECT_THAT(Violations(schema, "10"),
              ElementsAre(Pair("", "10 is not less than the exclusive maximum 10")));
  EXPECT_THAT(Violations(schema, "11"),
              ElementsAre(Pair("", "11 is greater than the maximum 10"),
                          Pair("", "11 is not less than the exclusive maximum 10")));
  EXPECT_THAT(Violations(schema, "2.25"), ElementsAre(Pair("", "2.25 is not a multiple of 0.5")));
  EXPECT_THAT(Violations(schema, "\"x\""), IsEmpty()) << "numeric keywords ignore other types";

  const Schema exclusive_minimum = MustCompile(R"({"exclusiveMinimum": 0})");
  EXPECT_THAT(Violations(exclusive_minimum, "0"),
              ElementsAre(Pair("", "0 is not greater than the exclusive minimum 0")));
  EXPECT_THAT(Violations(exclusive_minimum, "1e-300"), IsEmpty());
}

TEST(SchemaKeywordTest, NumbersCompareExactlyPastDoublePrecision) {
  const Schema schema = MustCompile(R"({"maximum": 9007199254740992})");  // 2^53
  EXPECT_THAT(Violations(schema, "9007199254740992"), IsEmpty());
  EXPECT_THAT(Violations(schema, "9007199254740993"),
              ElementsAre(Pair("", "9007199254740993 is greater than the maximum 9007199254740992")));
  const Schema unsigned_bound = MustCompile(R"({"minimum": 18446744073709551615})");
  EXPECT_THAT(Violations(unsigned_bound, "-1"),
              ElementsAre(Pair("", "-1 is less than the minimum 18446744073709551615")));
  const Schema multiple = MustCompile(R"({"multipleOf": 3})");
  EXPECT_THAT(Violations(multiple, "9007199254740993"), IsEmpty());
  EXPECT_THAT(Violations(multiple, "9007199254740994"),
              ElementsAre(Pair("", "9007199254740994 is not a multiple of 3")));
}

TEST(SchemaKeywordTest, StringLengthCountsCodePoints) {
  const Schema schema = MustCompile(R"({"minLength": 2, "maxLength": 3})");
  EXPECT_THAT(Violations(schema, "\"żółw\""), ElementsAre(Pair("", "expected at most 3 characters, got 4")));
  EXPECT_THAT(Violations(schema, "\"żół\""), IsEmpty());
  EXPECT_THAT(Violations(schema, "\"a\""), ElementsAre(Pair("", "expected at least 2 characters, got 1")));
  EXPECT_THAT(Violations(schema, "\"\U0001F600\U0001F600\""), IsEmpty()) << "two code points, eight bytes";
}

TEST(SchemaKeywordTest, PatternSearchesRatherThanMatchesWhole) {
  const Schema schema = MustCompile(R"({"pattern": "[0-9]{2}"})");
  EXPECT_THAT(Violations(schema, "\"ab12cd\""), IsEmpty());
  EXPECT_THAT(Violations(schema, "\"a1b2\""), ElementsAre(Pair("", "does not match pattern [0-9]{2}")));
  const Schema anchored = MustCompile(R"({"pattern": "^0x[0-9a-f]{16}$"})");
  EXPECT_THAT(Violations(anchored, "\"0x0123456789abcdef\""), IsEmpty());
  EXPECT_THAT(Violations(anchored, "\"0x0123456789ABCDEF\""),
              ElementsAre(Pair("", "does not match pattern ^0x[0-9a-f]{16}$")));
}

TEST(SchemaKeywordTest, LongStringsAreNotFedToTheRegexMatcher) {
  const Schema schema = MustCompile(R"({"pattern": "^(a|b)*$", "patternProperties": {"^(a|b)*$": true}})");
  const std::string long_string(Schema::kMaxPatternSubjectBytes + 1, 'a');
  EXPECT_THAT(
      Violations(schema, json(long_string).dump()),
      ElementsAre(Pair("",
                       "string of 1025 bytes is too long to match against pattern ^(a|b)*$ (the limit is "
                       "1024 bytes)")));
  EXPECT_THAT(
      Violations(schema, json{{long_string, 1}}.dump()),
      ElementsAre(
          Pair("/" + long_string,
               "key of 1025 bytes is too long to match against pattern ^(a|b)*$ (the limit is 1024 bytes)")));
  EXPECT_THAT(Violations(schema, json(std::string(Schema::kMaxPatternSubjectBytes, 'a')).dump()), IsEmpty());
}

TEST(SchemaKeywordTest, PropertyCountsAndDependentRequired) {
  const Schema schema = MustCompile(R"({"minProperties": 1, "maxProperties": 2,
                                        "dependentRequired": {"width": ["height"]}})");
  EXPECT_THAT(Violations(schema, R"({"width": 1, "height": 2})"), IsEmpty());
  EXPECT_THAT(Violations(schema, "{}"), ElementsAre(Pair("", "expected at least 1 key, got 0")));
  EXPECT_THAT(Violations(schema, R"({"a": 1, "b": 2, "c": 3})"),
              ElementsAre(Pair("", "expected at most 2 keys, got 3")));
  EXPECT_THAT(Violations(schema, R"({"width": 1})"),
              ElementsAre(Pair("", "key \"height\" is required when \"width\" is present")));
}

TEST(SchemaKeywordTest, AllOfAnyOfOneOfNot) {
  const Schema all_of = MustCompile(R"({"allOf": [{"type": "integer"}, {"minimum": 2}]})");
  EXPECT_THAT(Violations(all_of, "2"), IsEmpty());
  EXPECT_THAT(Violations(all_of, "1.5"), ElementsAre(Pair("", "expected integer, got number"),
                                                     Pair("", "1.5 is less than the minimum 2")));

  const Schema any_of =
      MustCompile(R"({"anyOf": [{"type": "string"}, {"properties": {"a": {"type": "integer"}}}]})");
  EXPECT_THAT(Violations(any_of, "\"x\""), IsEmpty());
  EXPECT_THAT(Violations(any_of, R"({"a": 1})"), IsEmpty());
  EXPECT_THAT(Violations(any_of, R"({"a": "x"})"),
              ElementsAre(Pair("",
                               "matches none of the anyOf alternatives: [0] expected string, got object; "
                               "[1] /a: expected integer, got string")));

  const Schema one_of = MustCompile(R"({"oneOf": [{"type": "integer"}, {"minimum": 2}]})");
  EXPECT_THAT(Violations(one_of, "1"), IsEmpty());
  EXPECT_THAT(Violations(one_of, "2.5"), IsEmpty());
  EXPECT_THAT(Violations(one_of, "3"),
              ElementsAre(Pair("", "matches oneOf alternatives 0 and 1, but must match exactly one")));
  EXPECT_THAT(Violations(one_of, "1.5"),
              ElementsAre(Pair("",
                               "matches none of the oneOf alternatives: [0] expected integer, got number; "
                               "[1] 1.5 is less than the minimum 2")));

  const Schema negation = MustCompile(R"({"not": {"type": "null"}})");
  EXPECT_THAT(Violations(negation, "0"), IsEmpty());
  EXPECT_THAT(Violations(negation, "null"), ElementsAre(Pair("", "matches the schema under \"not\"")));
}

TEST(SchemaKeywordTest, IfThenElse) {
  const Schema schema = MustCompile(R"({
    "if": {"properties": {"kind": {"const": "box"}}, "required": ["kind"]},
    "then": {"required": ["size"]},
    "else": {"required": ["radius"]}})");
  EXPECT_THAT(Violations(schema, R"({"kind": "box", "size": 1})"), IsEmpty());
  EXPECT_THAT(Violations(schema, R"({"kind": "box"})"),
              ElementsAre(Pair("", "missing required key \"size\"")));
  EXPECT_THAT(Violations(schema, R"({"kind": "ball"})"),
              ElementsAre(Pair("", "missing required key \"radius\"")));
}

TEST(SchemaKeywordTest, RefToDefsAndRoot) {
  const Schema schema = MustCompile(R"({
    "$defs": {"point": {"type": "array", "prefixItems": [{"type": "number"}, {"type": "number"}], "items": false},
              "a~b/c%d": {"type": "string"}},
    "properties": {"at": {"$ref": "#/$defs/point"},
                   "escaped": {"$ref": "#/$defs/a~0b~1c%25d"},
                   "children": {"type": "array", "items": {"$ref": "#"}}},
    "additionalProperties": false})");
  EXPECT_THAT(Violations(schema, R"({"at": [1, 2], "escaped": "x", "children": [{"at": [3, 4]}, {}]})"),
              IsEmpty());
  EXPECT_THAT(
      Violations(schema, R"({"at": [1, "y"], "escaped": 1, "children": [{"at": [3, 4, 5]}, {"bad": 1}]})"),
      ElementsAre(Pair("/at/1", "expected number, got string"),
                  Pair("/children/0/at/2", "unexpected item: expected at most 2 items"),
                  Pair("/children/1/bad", "unknown key \"bad\""),
                  Pair("/escaped", "expected string, got integer")));
}

TEST(SchemaKeywordTest, RefAppliesAlongsideSiblingKeywords) {
  const Schema schema =
      MustCompile(R"({"$defs": {"n": {"type": "integer"}}, "$ref": "#/$defs/n", "minimum": 5})");
  EXPECT_THAT(Violations(schema, "5"), IsEmpty());
  EXPECT_THAT(Violations(schema, "4.5"), ElementsAre(Pair("", "4.5 is less than the minimum 5"),
                                                     Pair("", "expected integer, got number")));
}

TEST(SchemaKeywordTest, BooleanSchemas) {
  EXPECT_THAT(Violations(MustCompile("true"), R"({"anything": [1]})"), IsEmpty());
  EXPECT_THAT(Violations(MustCompile("false"), "1"),
              ElementsAre(Pair("", "no value is allowed here (the schema is false)")));
  EXPECT_THAT(Violations(MustCompile(R"({"properties": {"gone": false}})"), R"({"gone": 1})"),
              ElementsAre(Pair("/gone", "no value is allowed here (the schema is false)")));
}

TEST(SchemaKeywordTest, AnnotationsAreAccepted) {
  const Schema schema = MustCompile(R"({"$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": "https://solid.invalid/x.json", "title": "t", "description": "d", "default": 1, "examples": [1],
    "$comment": "c", "deprecated": false, "readOnly": false, "writeOnly": false, "type": "integer"})");
  EXPECT_THAT(Violations(schema, "1"), IsEmpty());
}

// ---------------------------------------------------------------------------------------------
// Compile refuses what it would otherwise ignore or misread

TEST(SchemaCompileTest, RejectsUnsupportedKeywordsWithTheirLocation) {
  const Status format = CompileStatus(R"({"properties": {"seed": {"type": "string", "format": "uuid"}}})");
  EXPECT_EQ(format.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(format.message(), "test.schema.json: /properties/seed/format: unsupported keyword \"format\"");

  EXPECT_EQ(CompileStatus(R"({"minLenght": 1})").message(),
            "test.schema.json: /minLenght: unsupported keyword \"minLenght\" (did you mean \"minLength\"?)");
  for (const char* schema : {R"({"unevaluatedProperties": false})", R"({"$dynamicRef": "#a"})",
                             R"({"$anchor": "a"})", R"({"contains": {}})", R"({"dependentSchemas": {}})"}) {
    EXPECT_THAT(CompileStatus(schema).message(), HasSubstr("unsupported keyword")) << schema;
  }
}

TEST(SchemaCompileTest, RejectsMalformedKeywordValues) {
  const std::pair<const char*, const char*> cases[] = {
      {R"({"type": "float"})", "test.schema.json: /type: unknown type \"float\""},
      {R"({"type": []})", "test.schema.json: /type: type must not be an empty array"},
      {R"({"minLength": -1})",
       "test.schema.json: /minLength: minLength must be a non-negative integer, not -1"},
      {R"({"maxItems": 1.5})",
       "test.schema.json: /maxItems: maxItems must be a non-negative integer, not 1.5"},
      {R"({"multipleOf": 0})", "test.schema.json: /multipleOf: multipleOf must be greater than 0"},
      {R"({"required": ["a", "a"]})", "test.schema.json: /required: required lists \"a\" twice"},
      {R"({"required": "a"})", "test.schema.json: /required: required must be an array of strings"},
      {R"({"items": [{}]})",
       "test.schema.json: /items: items must be a schema; an array of schemas is prefixItems in draft "
       "2020-12"},
      {R"({"anyOf": []})", "test.schema.json: /anyOf: anyOf must be a non-empty array of schemas"},
      {R"({"properties": {"a": 1}})",
       "test.schema.json: /properties/a: a schema must be an object or a boolean, not integer"},
      {R"({"$schema": "http://json-schema.org/draft-07/schema#"})",
       "test.schema.json: /$schema: only draft 2020-12 (https://json-schema.org/draft/2020-12/schema) is "
       "supported, "
       "not \"http://json-schema.org/draft-07/schema#\""},
      {R"({"$defs": {"a": {"$id": "a.json"}}})",
       "test.schema.json: /$defs/a/$id: $id is only supported at the root (no embedded schema resources)"},
  };
  for (const auto& [schema, message] : cases) {
    const Status status = CompileStatus(schema);
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << schema;
    EXPECT_EQ(status.message(), message) << schema;
  }
  EXPECT_THAT(
      CompileStatus(R"({"pattern": "(unclosed"})").message(),
      StartsWith("test.schema.json: /pattern: invalid or unsupported regular expression \"(unclosed\": "));
  EXPECT_THAT(
      CompileStatus(R"({"patternProperties": {"\\p{L}": true}})").message(),
      StartsWith("test.schema.json: /patternProperties/\\p{L}: invalid or unsupported regular expression"));
}

TEST(SchemaCompileTest, RejectsRefsItCannotFollow) {
  EXPECT_EQ(CompileStatus(R"({"$ref": "other.json#/$defs/a"})").message(),
            "test.schema.json: /$ref: only a $ref to a JSON Pointer within this schema (\"#\", "
            "\"#/$defs/name\") is "
            "supported, not \"other.json#/$defs/a\"");
  EXPECT_THAT(CompileStatus(R"({"$ref": "#anchor"})").message(), HasSubstr("only a $ref to a JSON Pointer"));
  EXPECT_EQ(CompileStatus(R"({"properties": {"a": {"$ref": "#/$defs/missing"}}})").message(),
            "test.schema.json: /properties/a/$ref: $ref \"#/$defs/missing\" names nothing in this schema");
  EXPECT_THAT(CompileStatus(R"({"$ref": "#/$defs/a%2"})").message(),
              HasSubstr("only a $ref to a JSON Pointer"));
}

TEST(SchemaCompileTest, RejectsRefCyclesThatNeverDescend) {
  EXPECT_THAT(CompileStatus(R"({"$ref": "#"})").message(),
              HasSubstr("applies itself to the same value endlessly"));
  EXPECT_THAT(
      CompileStatus(
          R"({"$defs": {"a": {"allOf": [{"$ref": "#/$defs/b"}]}, "b": {"not": {"$ref": "#/$defs/a"}}}})")
          .message(),
      HasSubstr("applies itself to the same value endlessly"));
  // Recursion through a property or an item consumes the instance, so it ends.
  EXPECT_TRUE(CompileStatus(R"({"properties": {"next": {"$ref": "#"}}, "items": {"$ref": "#"}})").ok());
}

TEST(SchemaCompileTest, RefusesSchemasNestedTooDeep) {
  json schema = true;
  json* innermost = &schema;
  for (int i = 0; i < 200; ++i) {
    *innermost = {{"not", true}};
    innermost = &(*innermost)["not"];
  }
  EXPECT_THAT(Schema::Compile(schema, "deep.schema.json").status().message(),
              HasSubstr("nested deeper than 128 levels"));
}

// ---------------------------------------------------------------------------------------------
// Limits on validation

TEST(SchemaValidateTest, DeepProgrammaticInstanceDoesNotOverflowTheStack) {
  // ParseJson limits depth, but Validate also takes values built in memory.
  json deep_array = json::array();
  json deep_object = json::object();
  json* innermost_array = &deep_array;
  json* innermost_object = &deep_object;
  for (int i = 0; i < 100000; ++i) {
    innermost_array->push_back(json::array());
    innermost_array = &innermost_array->back();
    innermost_object = &((*innermost_object)["k"] = json::object());
  }
  const char* const kRecursiveSchemas[] = {
      R"({"items": {"$ref": "#"}, "additionalProperties": {"$ref": "#"}})",
      R"({"anyOf": [{"items": {"$ref": "#"}, "properties": {"k": {"$ref": "#"}}}]})"};
  for (const char* schema_text : kRecursiveSchemas) {
    const Schema schema = MustCompile(schema_text);
    for (const json* instance : {&deep_array, &deep_object}) {
      const std::vector<Violation> violations = schema.Validate(*instance);
      ASSERT_EQ(violations.size(), 1u) << schema_text;
      EXPECT_THAT(violations[0].message,
                  HasSubstr("nesting is deeper than the 1000 levels validation allows"));
    }
  }
}

TEST(SchemaValidateTest, StopsCollectingAfterTheLimit) {
  const Schema schema = MustCompile(R"({"items": {"type": "string"}})");
  const std::vector<Violation> violations = schema.Validate(json(std::vector<int>(5000, 1)));
  ASSERT_EQ(violations.size(), Schema::kMaxViolations + 1);
  EXPECT_EQ(violations.back().message, "stopped after 1000 violations; there may be more");
  EXPECT_EQ(violations[Schema::kMaxViolations - 1].pointer, "/999");
}

// ---------------------------------------------------------------------------------------------
// Check: the message a user reads

TEST(SchemaCheckTest, UnknownKeyNamesTheLineAndSuggestsTheKnownKey) {
  const Schema schema = MustCompile(R"({
    "properties": {"objects": {"type": "object", "additionalProperties": false,
                               "properties": {"min_objects": {"type": "integer"}, "max_objects": {"type": "integer"}}},
                   "seed": {"type": "string", "pattern": "^0x[0-9a-f]{16}$"}}})");
  const std::string text = R"({
  "seed": "0x0123456789abcdeF",
  "objects": {
    "max_objects": 3,
    "min_objets": 1
  }
})";
  auto instance = ParseJson(text, "params.json");
  ASSERT_TRUE(instance.ok());
  const Status status = schema.Check(*instance, "params.json", text);
  EXPECT_EQ(status.code(), StatusCode::kParseError);
  EXPECT_EQ(status.message(),
            "params.json:5: /objects/min_objets: unknown key \"min_objets\" (did you mean \"min_objects\"?)\n"
            "params.json:2: /seed: does not match pattern ^0x[0-9a-f]{16}$");

  EXPECT_EQ(schema.Check(*instance, "params.json").message(),
            "params.json: /objects/min_objets: unknown key \"min_objets\" (did you mean \"min_objects\"?)\n"
            "params.json: /seed: does not match pattern ^0x[0-9a-f]{16}$");
  EXPECT_TRUE(schema.Check(json::parse(R"({"objects": {"min_objects": 1}})"), "params.json").ok());
}

TEST(SchemaCheckTest, CapsTheReportedViolations) {
  const Schema schema = MustCompile(R"({"items": {"type": "string"}})");
  const Status status = schema.Check(json(std::vector<int>(25, 1)), "list.json");
  EXPECT_THAT(status.message(), StartsWith("list.json: /0: expected string, got integer\nlist.json: /1: "));
  EXPECT_THAT(
      status.message(),
      HasSubstr("list.json: /19: expected string, got integer\nlist.json: ... and 5 more violations"));
}

// ---------------------------------------------------------------------------------------------
// The schemas we ship

class ManifestSchemaTest : public testing::Test {
 protected:
  void SetUp() override {
    const std::string text = ReadFile(std::filesystem::path(SOLID_SCHEMAS_DIR) / "manifest.schema.json");
    auto parsed = ParseJson(text, "manifest.schema.json");
    ASSERT_TRUE(parsed.ok()) << parsed.status().ToString();
    auto compiled = Schema::Compile(*parsed, "manifest.schema.json");
    ASSERT_TRUE(compiled.ok()) << compiled.status().ToString();
    schema_ = std::make_unique<Schema>(std::move(compiled).value());
  }

  static json ValidManifest() {
    return json::parse(R"({
      "format": "solid-dataset", "format_version": 2,
      "generator": {"name": "solid", "version": "0.1.0", "git_sha": "44c1952"},
      "seed": "0x00000000deadbeef", "images": 1000000, "shard_size": 4096,
      "width": 640, "height": 480, "image_format": "png",
      "params": {"layout": {"min_objects": 1}},
      "params_hash": "0123456789abcdef", "catalog_hash": "fedcba9876543210"})");
  }

  std::unique_ptr<Schema> schema_;
};

TEST_F(ManifestSchemaTest, AcceptsAValidManifest) {
  const Status status = schema_->Check(ValidManifest(), "manifest.json");
  EXPECT_TRUE(status.ok()) << status.ToString();
}

TEST_F(ManifestSchemaTest, RejectsBadManifests) {
  const std::vector<std::pair<json, std::string>> cases = {
      {{{"seed", "0xDEADBEEF"}}, "manifest.json: /seed: does not match pattern ^0x[0-9a-f]{16}$"},
      {{{"format", "solid"}}, "manifest.json: /format: expected \"solid-dataset\", got \"solid\""},
      {{{"format_version", 3}}, "manifest.json: /format_version: 3 is greater than the maximum 2"},
      {{{"width", 0}}, "manifest.json: /width: 0 is less than the minimum 1"},
      {{{"images", 1.5}}, "manifest.json: /images: expected integer, got number"},
      {{{"image_format", "gif"}},
       "manifest.json: /image_format: \"gif\" is not one of \"png\", \"jpeg\", \"webp\""},
      {{{"generator", {{"name", "solid"}, {"version", ""}, {"sha", "x"}}}},
       "manifest.json: /generator/sha: unknown key \"sha\"\n"
       "manifest.json: /generator/version: expected at least 1 character, got 0"},
      {{{"shard_sise", 1}},
       "manifest.json: /shard_sise: unknown key \"shard_sise\" (did you mean \"shard_size\"?)"},
  };
  for (const auto& [patch, message] : cases) {
    json manifest = ValidManifest();
    manifest.update(patch);
    EXPECT_EQ(schema_->Check(manifest, "manifest.json").message(), message) << patch.dump();
  }
  json missing = ValidManifest();
  missing.erase("seed");
  missing.erase("params_hash");
  EXPECT_EQ(
      schema_->Check(missing, "manifest.json").message(),
      "manifest.json: missing required key \"seed\"\nmanifest.json: missing required key \"params_hash\"");
}

TEST_F(ManifestSchemaTest, ReportsLinesInTheManifestText) {
  const std::string text = R"({
  "format": "solid-dataset",
  "format_version": 2,
  "generator": {"name": "solid", "version": "0.1.0"},
  "seed": "0x00000000DEADBEEF",
  "images": 10, "shard_size": 4, "width": 64, "height": 64, "image_format": "png",
  "params": {},
  "params_hash": "0123456789abcdef",
  "catalog_hash": "fedcba9876543210",
  "extra": true
})";
  auto manifest = ParseJson(text, "manifest.json");
  ASSERT_TRUE(manifest.ok()) << manifest.status().ToString();
  EXPECT_EQ(schema_->Check(*manifest, "manifest.json", text).message(),
            "manifest.json:10: /extra: unknown key \"extra\"\n"
            "manifest.json:5: /seed: does not match pattern ^0x[0-9a-f]{16}$");
}

// ---------------------------------------------------------------------------------------------
// JSON-Schema-Test-Suite, as packaged by Debian (json-schema-test-suite)

std::filesystem::path TestSuiteRoot() {
  if (const char* root = std::getenv("SOLID_JSON_SCHEMA_TEST_SUITE")) return root;
  return "/usr/share/json-schema-test-suite/tests";
}

TEST(JsonSchemaTestSuite, SupportedKeywordsPass) {
  // Debian 12's package (2.0.0) stops at draft 7; a newer suite (SOLID_JSON_SCHEMA_TEST_SUITE
  // may name an upstream checkout's tests/) has draft 2020-12, which is what we implement.
  // The files below test keywords whose meaning did not change from draft 7 to 2020-12; where a
  // draft-7 case depends on a change (items as an array, "definitions", "dependencies"), our
  // Compile refuses its schema and the case is counted as skipped.
  const std::filesystem::path root = TestSuiteRoot();
  std::filesystem::path draft;
  for (const char* name : {"draft2020-12", "draft7"}) {
    if (std::filesystem::is_directory(root / name)) {
      draft = root / name;
      break;
    }
  }
  if (draft.empty()) {
    GTEST_SKIP() << "JSON-Schema-Test-Suite not found under " << root
                 << ": install the Debian package json-schema-test-suite";
  }
  const char* const kFiles[] = {
      "additionalProperties", "allOf", "anyOf", "boolean_schema", "const", "default", "defs", "dependentRequired",
      "enum", "exclusiveMaximum", "exclusiveMinimum", "if-then-else", "infinite-loop-detection", "items",
      "maxItems", "maxLength", "maxProperties", "maximum", "minItems", "minLength", "minProperties", "minimum",
      "multipleOf", "not", "oneOf", "pattern", "patternProperties", "prefixItems", "properties", "ref",
      "required", "type", "uniqueItems"};

  size_t files = 0, ran = 0, passed = 0, skipped = 0;
  std::map<std::string, size_t> skip_reasons;
  for (const char* file : kFiles) {
    const std::filesystem::path path = draft / (std::string(file) + ".json");
    if (!std::filesystem::exists(path)) continue;
    ++files;
    auto groups = ParseJson(ReadFile(path), path.string());
    ASSERT_TRUE(groups.ok()) << groups.status().ToString();
    for (const json& group : *groups) {
      const std::string group_name = std::string(file) + ": " + group.at("description").get<std::string>();
      auto schema = Schema::Compile(group.at("schema"), group_name);
      if (!schema.ok()) {
        skipped += group.at("tests").size();
        std::string reason = schema.status().message().substr(group_name.size() + 2);
        skip_reasons[reason] += group.at("tests").size();
        continue;
      }
      for (const json& test : group.at("tests")) {
        ++ran;
        const std::vector<Violation> violations = schema->Validate(test.at("data"));
        const bool expected_valid = test.at("valid").get<bool>();
        if (violations.empty() == expected_valid) {
          ++passed;
          continue;
        }
        std::string explanation;
        for (const Violation& violation : violations)
          explanation += "\n  " + violation.pointer + ": " + violation.message;
        ADD_FAILURE() << group_name << " / " << test.at("description").get<std::string>() << ": expected "
                      << (expected_valid ? "valid" : "invalid") << ", data " << test.at("data").dump()
                      << explanation;
      }
    }
  }
  std::cout << "JSON-Schema-Test-Suite " << draft << ": " << files << " files, " << ran << " cases ran, "
            << passed << " passed, " << skipped << " skipped (schema refused by Compile):\n";
  for (const auto& [reason, count] : skip_reasons) std::cout << "  " << count << " x " << reason << "\n";
  EXPECT_GT(ran, 0u);
}

}  // namespace
}  // namespace solid::json
