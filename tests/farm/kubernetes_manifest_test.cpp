// The Kubernetes Indexed Job of docs/farm against the Kubernetes API schema, offline
// (tests/farm/kubernetes/validate_job.mjs: npm kubernetes-models for types, formats and enums,
// TypeScript over its declarations for unknown fields), and its numbers against its flags.
// What no offline check covers: the API server's own checks beyond the schema (cross-field
// rules and limits, such as those on completions and parallelism of Indexed Jobs), admission
// policies, and that the image, the PersistentVolumeClaim and 8 CPUs per pod exist in a
// given cluster.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdlib.h>

#include <optional>
#include <sstream>

#include "fixtures/run_command.h"

namespace solid::farm {
namespace {

namespace fs = std::filesystem;
using fixtures::RunCommand;
using fixtures::ShellQuote;

const fs::path kValidatorDir = fs::path(SOLID_SOURCE_DIR) / "tests/farm/kubernetes";
const fs::path kManifest = fs::path(SOLID_SOURCE_DIR) / "docs/farm/kubernetes-render-job.yaml";

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::optional<std::string> ValidatorUnavailable() {
  if (std::system("node --version >/dev/null 2>&1") != 0) {
    return std::string("node not found; install Node.js and run: npm ci --prefix tests/farm/kubernetes");
  }
  for (const char* package : {"kubernetes-models", "typescript", "yaml"}) {
    if (!fs::exists(kValidatorDir / "node_modules" / package / "package.json")) {
      return fmt::format("npm package {} not found in {}; run: npm ci --prefix tests/farm/kubernetes", package,
                         (kValidatorDir / "node_modules").string());
    }
  }
  return std::nullopt;
}

// The manifest with `from` replaced by `to`, written to `out` (unbroken if `from` has gone:
// then the tests below fail).
void WriteMutated(const fs::path& out, const std::string& from, const std::string& to) {
  std::string text = ReadText(kManifest);
  const size_t at = text.find(from);
  if (at != std::string::npos) text.replace(at, from.size(), to);
  std::ofstream(out) << text;
}

// One node process for every manifest (its TypeScript check takes seconds): the docs' one,
// and two broken copies that show the validator fails where the API server would, on a
// misspelt field and on a value outside an enum.
class KubernetesManifest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    unavailable_ = ValidatorUnavailable();
    if (unavailable_) return;
    char pattern[] = "/tmp/solid-kubernetes-XXXXXX";
    dir_ = ::mkdtemp(pattern);
    WriteMutated(dir_ / "misspelt.yaml", "backoffLimitPerIndex:", "backofLimitPerIndex:");
    WriteMutated(dir_ / "wrong-value.yaml", "completionMode: Indexed", "completionMode: Indexd");
    run_ = RunCommand("node " + ShellQuote((kValidatorDir / "validate_job.mjs").string()) + " " +
                      ShellQuote(kManifest.string()) + " " + ShellQuote((dir_ / "misspelt.yaml").string()) + " " +
                      ShellQuote((dir_ / "wrong-value.yaml").string()));
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }
  void SetUp() override {
    if (unavailable_) GTEST_SKIP() << *unavailable_;
  }
  // What the validator said of `file`.
  static std::string LinesOf(const fs::path& file) {
    std::string out;
    std::istringstream lines(run_.output);
    for (std::string line; std::getline(lines, line);) {
      if (line.starts_with(file.string() + ": ")) out += line + "\n";
    }
    return out;
  }

  static inline std::optional<std::string> unavailable_;
  static inline fs::path dir_;
  static inline fixtures::CommandRun run_;
};

TEST_F(KubernetesManifest, TheIndexedJobIsAValidJob) {
  EXPECT_EQ(run_.exit_status, 1) << "the broken copies must fail, and only they\n" << run_.output;
  EXPECT_EQ(LinesOf(kManifest), kManifest.string() + ": document 1: valid batch/v1 Job solid-render-more-objects-1m\n")
      << run_.output;
}

TEST_F(KubernetesManifest, AMisspeltFieldIsRejected) {
  EXPECT_NE(LinesOf(dir_ / "misspelt.yaml").find("'\"backofLimitPerIndex\"' does not exist in type 'IJobSpec'"),
            std::string::npos)
      << run_.output;
}

TEST_F(KubernetesManifest, AValueOutsideAnEnumIsRejected) {
  EXPECT_NE(LinesOf(dir_ / "wrong-value.yaml").find("data/spec/completionMode must be equal to one of the allowed values"),
            std::string::npos)
      << run_.output;
}

// One pod per shard: completions is the dataset's shard count, ceil(images / shard size).
TEST(KubernetesManifestNumbers, CompletionsAreTheShardCountOfItsFlags) {
  const std::string text = ReadText(kManifest);
  // The number after the first `key` (a flag's "--images=" or a field's "\n  completions: ").
  auto number = [&](const std::string& key) -> int64_t {
    const size_t at = text.find(key);
    if (at == std::string::npos) {
      ADD_FAILURE() << "no " << key << " in " << kManifest;
      return 0;
    }
    return std::atoll(text.c_str() + at + key.size());
  };
  const int64_t images = number("--images="), shard_size = number("--shard-size=");
  ASSERT_GT(shard_size, 0);
  EXPECT_EQ(number("\n  completions: "), (images + shard_size - 1) / shard_size);
}

}  // namespace
}  // namespace solid::farm
