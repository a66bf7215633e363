// Shared helpers of the formats tests.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <string>

#include "solid/formats/status.h"

#define ASSERT_OK(expr)                                  \
  do {                                                   \
    const ::solid::Status& solid_s_ = (expr);            \
    ASSERT_TRUE(solid_s_.ok()) << solid_s_.ToString();   \
  } while (0)
#define EXPECT_OK(expr)                                  \
  do {                                                   \
    const ::solid::Status& solid_s_ = (expr);            \
    EXPECT_TRUE(solid_s_.ok()) << solid_s_.ToString();   \
  } while (0)

namespace solid::testing {

// A fresh directory under the system temp dir, removed when the test ends.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string("solid-") + (info ? info->test_suite_name() + std::string("-") + info->name() : "t");
    path_ = std::filesystem::temp_directory_path() / (name + "-" + std::to_string(std::random_device{}()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace solid::testing
