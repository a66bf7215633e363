// Our JSON Schema validator (formats/json_schema.cpp) against valijson, Debian's C++ one
// (libvalijson-dev, header-only, with an nlohmann adapter): docs/dependencies.md quotes what
// this prints. Three parts:
//  1. JSON-Schema-Test-Suite pass rates: every top-level file of each draft directory given
//     (Debian's json-schema-test-suite has draft 3 to 7; our schemas are 2020-12), split into
//     the files of the keywords our schemas use and the rest.
//  2. The messages both give for realistic bad params, manifest and search-space documents.
//  3. Time to validate our six presets and a manifest, N times each.
//   json_schema_vs_valijson [--suite DIR]... [--iterations N]
// GCC 12 warns falsely inside libstdc++'s std::regex, which valijson uses (GCC bug 105562, as
// in formats/json_schema.cpp); the pragma covers only the library headers.
#pragma GCC diagnostic push
#if !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <regex>
#include <valijson/adapters/nlohmann_json_adapter.hpp>
#include <valijson/schema.hpp>
#include <valijson/schema_parser.hpp>
#include <valijson/validator.hpp>
#pragma GCC diagnostic pop

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "solid/formats/json_schema.h"
#include "solid/formats/schemas.h"
#include "solid/render/params.h"

namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

// The keywords of schemas/*.schema.json; prefixItems and $defs exist only from 2019-09/2020-12.
const std::set<std::string> kOurKeywordFiles = {
    "additionalProperties", "boolean_schema", "const",    "default",     "defs",       "enum",
    "exclusiveMaximum",     "exclusiveMinimum", "if-then-else", "items",  "maxItems",   "maxLength",
    "maxProperties",        "maximum",        "minItems", "minLength",   "minProperties", "minimum",
    "oneOf",                "pattern",        "prefixItems", "properties", "ref",       "required",
    "type"};

struct Valijson {
  valijson::Schema schema;
};

// valijson reports failures of a schema it cannot use by exceptions.
std::unique_ptr<Valijson> ValijsonCompile(const json& schema, std::string* error) {
  auto out = std::make_unique<Valijson>();
  try {
    valijson::SchemaParser parser(valijson::SchemaParser::kDraft7);
    valijson::adapters::NlohmannJsonAdapter adapter(schema);
    parser.populateSchema(adapter, out->schema);
  } catch (const std::exception& e) {
    *error = e.what();
    return nullptr;
  }
  return out;
}

struct ValijsonError {
  std::string pointer, message;
};

// valijson's context is {"<root>", "[key]", "[0]", ...}: as a JSON Pointer.
std::vector<ValijsonError> ValijsonValidate(valijson::Validator& validator, const Valijson& compiled,
                                            const json& instance) {
  valijson::ValidationResults results;
  valijson::adapters::NlohmannJsonAdapter target(instance);
  validator.validate(compiled.schema, target, &results);
  std::vector<ValijsonError> errors;
  for (const auto& error : results) {
    std::string pointer;
    for (size_t i = 1; i < error.context.size(); ++i) {
      std::string token = error.context[i].substr(1, error.context[i].size() - 2);
      std::string escaped;
      for (char c : token) escaped += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
      pointer += "/" + escaped;
    }
    errors.push_back({pointer, error.description});
  }
  return errors;
}

struct Tally {
  size_t cases = 0, passed = 0, refused = 0;  // refused: the schema did not compile
  void Add(const Tally& other) {
    cases += other.cases;
    passed += other.passed;
    refused += other.refused;
  }
  std::string Row() const {
    return fmt::format("{:>5} cases {:>5} passed {:>5} failed {:>5} refused  ({:5.1f}% passed, {:5.1f}% of the rest)",
                       cases, passed, cases - passed - refused, refused, cases ? 100.0 * passed / cases : 0.0,
                       cases - refused ? 100.0 * passed / (cases - refused) : 0.0);
  }
};

json ReadJson(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return json::parse(text.str());
}

void RunSuite(const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.path().extension() == ".json") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  Tally ours_used, ours_other, theirs_used, theirs_other;
  std::vector<std::string> theirs_failures, ours_failures;
  for (const auto& path : files) {
    const std::string stem = path.stem().string();
    const bool used = kOurKeywordFiles.count(stem) > 0;
    Tally ours, theirs;
    for (const json& group : ReadJson(path)) {
      const size_t n = group.at("tests").size();
      ours.cases += n;
      theirs.cases += n;
      auto schema = solid::json::Schema::Compile(group.at("schema"), "suite");
      std::string error;
      auto compiled = ValijsonCompile(group.at("schema"), &error);
      valijson::Validator validator;
      if (!schema.ok()) ours.refused += n;
      if (!compiled) theirs.refused += n;
      for (const json& test : group.at("tests")) {
        const bool valid = test.at("valid").get<bool>();
        const std::string where = fmt::format("{}: {}: {}", stem, group.at("description").get<std::string>(),
                                              test.at("description").get<std::string>());
        if (schema.ok()) {
          if (schema->Validate(test.at("data")).empty() == valid) {
            ++ours.passed;
          } else if (used) {
            ours_failures.push_back(where);
          }
        }
        if (compiled) {
          bool got = false;
          try {
            got = ValijsonValidate(validator, *compiled, test.at("data")).empty();
          } catch (const std::exception&) {
            got = !valid;  // an exception while validating is a failure of the case
          }
          if (got == valid) {
            ++theirs.passed;
          } else if (used) {
            theirs_failures.push_back(where);
          }
        }
      }
    }
    (used ? ours_used : ours_other).Add(ours);
    (used ? theirs_used : theirs_other).Add(theirs);
  }
  Tally ours_all = ours_used, theirs_all = theirs_used;
  ours_all.Add(ours_other);
  theirs_all.Add(theirs_other);
  fmt::print("== {} ({} files)\n", dir.string(), files.size());
  fmt::print("  files of our schemas' keywords\n    ours     {}\n    valijson {}\n", ours_used.Row(), theirs_used.Row());
  fmt::print("  every file\n    ours     {}\n    valijson {}\n", ours_all.Row(), theirs_all.Row());
  for (const auto& f : ours_failures) fmt::print("  ours fails:     {}\n", f);
  for (const auto& f : theirs_failures) fmt::print("  valijson fails: {}\n", f);
}

json EmbeddedJson(std::string_view name) {
  auto text = solid::schemas::Get(name);
  if (!text.ok()) throw std::runtime_error(text.status().ToString());
  return json::parse(*text);
}

// A manifest as `solid render` writes one: the resolved params of a preset inside.
std::string ManifestText() {
  auto params = solid::render::LoadPreset("occlusion");
  if (!params.ok()) throw std::runtime_error(params.status().ToString());
  json manifest = {{"format", "solid-dataset"},
                   {"format_version", 2},
                   {"generator", {{"name", "solid"}, {"version", "0.2.0"}, {"git_sha", "0123456789abcdef"}}},
                   {"seed", "0x9e3779b97f4a7c15"},
                   {"images", 1000},
                   {"shard_size", 256},
                   {"width", 640},
                   {"height", 480},
                   {"image_format", "png"},
                   {"params", solid::render::ParamsToJson(*params)},
                   {"params_hash", "0123456789abcdef"},
                   {"catalog_hash", "fedcba9876543210"}};
  return manifest.dump(2);
}

struct BadDocument {
  const char* what;
  const char* schema;  // embedded name
  std::string name;    // file name in messages
  std::string text;
};

std::vector<BadDocument> BadDocuments() {
  json manifest = json::parse(ManifestText());
  json missing = manifest;
  missing.erase("seed");
  missing["params_hash"] = "0123456789ABCDEF";
  json out_of_range = manifest;
  out_of_range["format_version"] = 3;
  out_of_range["image_format"] = "tiff";
  return {
      {"params: wrong type deep inside (a bucket bound as a string)", "params.schema.json", "params.json",
       R"({
  "preset": "scale-distribution",
  "objects": {
    "scale": {
      "law": "mixture",
      "buckets": [{"range_m": [0.1, "1.0"], "p": 0.7}, {"range_m": [1.0, 2.0], "p": 0.3}]
    }
  }
})"},
      {"params: unknown key (a typo)", "params.schema.json", "params.json",
       R"({
  "placement": {
    "occlude_prb": 0.5
  }
})"},
      {"params: out of range", "params.schema.json", "params.json",
       R"({
  "grid": {"points_per_axis": 4096},
  "camera": {"hfov_deg": -10}
})"},
      {"params: enum mismatch", "params.schema.json", "params.json", R"({"scene": {"kind": "white-cube"}})"},
      {"params: if/then/else (uniform law given buckets)", "params.schema.json", "params.json",
       R"({"objects": {"scale": {"law": "uniform", "buckets": [{"range_m": [0.1, 1.0], "p": 1.0}]}}})"},
      {"manifest: missing required, pattern", "manifest.schema.json", "manifest.json", missing.dump(2)},
      {"manifest: out of range, enum", "manifest.schema.json", "manifest.json", out_of_range.dump(2)},
      {"search space: bounds of strings (prefixItems, 2020-12)", "search-space.schema.json", "space.json",
       R"({"free": {"placement.occlude_prob": {"transform": "value", "bounds": ["0.1", "0.9"]}}})"},
  };
}

void CompareMessages() {
  fmt::print("\n== messages on bad documents (ours: Schema::Check with the text; valijson: pointer from its "
             "context, then its description)\n");
  for (const BadDocument& bad : BadDocuments()) {
    const json schema_doc = EmbeddedJson(bad.schema);
    auto schema = solid::json::Schema::Compile(schema_doc, bad.schema);
    std::string error;
    auto compiled = ValijsonCompile(schema_doc, &error);
    if (!schema.ok() || !compiled) throw std::runtime_error("schema did not compile: " + error);
    const json doc = json::parse(bad.text);
    fmt::print("-- {}\n   ours:\n", bad.what);
    const solid::Status status = schema->Check(doc, bad.name, bad.text);
    std::istringstream lines(status.ok() ? std::string("(accepted)") : status.message());
    for (std::string line; std::getline(lines, line);) fmt::print("     {}\n", line);
    valijson::Validator validator;
    const auto errors = ValijsonValidate(validator, *compiled, doc);
    fmt::print("   valijson ({} errors):\n", errors.size());
    if (errors.empty()) fmt::print("     (accepted)\n");
    for (const auto& e : errors) fmt::print("     {}: {}\n", e.pointer.empty() ? "(root)" : e.pointer, e.message);
  }
}

template <typename F>
double MicrosPer(int iterations, F&& f) {
  const auto start = Clock::now();
  for (int i = 0; i < iterations; ++i) f();
  return std::chrono::duration<double, std::micro>(Clock::now() - start).count() / iterations;
}

void CompareSpeed(int iterations) {
  fmt::print("\n== speed ({} validations of each document, one thread; compile once)\n", iterations);
  struct Doc {
    std::string label;
    const char* schema;
    json instance;
  };
  std::vector<Doc> docs;
  for (const std::string& preset : solid::render::PresetNames())
    docs.push_back({"preset " + preset, "params.schema.json", EmbeddedJson("presets/" + preset + ".json")});
  docs.push_back({"manifest (occlusion params inside)", "manifest.schema.json", json::parse(ManifestText())});
  double ours_total = 0, theirs_total = 0;
  size_t ours_violations = 0, theirs_failures = 0;  // while timing; both must stay 0
  for (const Doc& doc : docs) {
    const json schema_doc = EmbeddedJson(doc.schema);
    auto schema = solid::json::Schema::Compile(schema_doc, doc.schema);
    std::string error;
    auto compiled = ValijsonCompile(schema_doc, &error);
    if (!schema.ok() || !compiled) throw std::runtime_error("schema did not compile: " + error);
    if (!schema->Validate(doc.instance).empty()) throw std::runtime_error(doc.label + " fails our schema");
    valijson::Validator validator;
    if (!ValijsonValidate(validator, *compiled, doc.instance).empty())
      throw std::runtime_error(doc.label + " fails valijson");
    const double ours = MicrosPer(iterations, [&] { ours_violations += schema->Validate(doc.instance).size(); });
    const double theirs = MicrosPer(iterations, [&] {
      valijson::ValidationResults results;
      valijson::adapters::NlohmannJsonAdapter target(doc.instance);
      theirs_failures += !validator.validate(compiled->schema, target, &results);
    });
    ours_total += ours;
    theirs_total += theirs;
    fmt::print("  {:<40} ours {:8.1f} us   valijson {:8.1f} us\n", doc.label, ours, theirs);
  }
  const double compile_ours = MicrosPer(50, [] {
    (void)solid::json::Schema::Compile(EmbeddedJson("params.schema.json"), "params.schema.json");
  });
  const double compile_theirs = MicrosPer(50, [] {
    std::string error;
    (void)ValijsonCompile(EmbeddedJson("params.schema.json"), &error);
  });
  fmt::print("  {:<40} ours {:8.1f} us   valijson {:8.1f} us\n", "all of the above", ours_total, theirs_total);
  fmt::print("  {:<40} ours {:8.1f} us   valijson {:8.1f} us\n", "compiling params.schema.json (with parse)",
             compile_ours, compile_theirs);
  fmt::print("  violations while timing (must be 0): ours {}, valijson {}\n", ours_violations, theirs_failures);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"JSON Schema validation: formats/json_schema.cpp vs valijson"};
  std::vector<std::string> suites = {"/usr/share/json-schema-test-suite/tests/draft7"};
  int iterations = 2000;
  app.add_option("--suite", suites, "a draft directory of JSON-Schema-Test-Suite (repeatable)");
  app.add_option("--iterations", iterations, "validations per document in the timing")->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  for (const std::string& suite : suites) RunSuite(suite);
  CompareMessages();
  CompareSpeed(iterations);
  return 0;
}
