#include "solid/formats/status.h"

#include <gtest/gtest.h>

namespace solid {
namespace {

TEST(Status, AnOptionErrorKeepsItsFieldThroughContext) {
  const Status status = OptionError("images", "must be >= 0, got -3");
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(status.option(), "images");
  EXPECT_EQ(status.message(), "images: must be >= 0, got -3");
  const Status located = status.WithContext("render");
  EXPECT_EQ(located.option(), "images");
  EXPECT_EQ(located.message(), "render: images: must be >= 0, got -3");
  EXPECT_EQ(Status(status).WithContext("x").option(), "images");
}

TEST(Status, OtherErrorsNameNoOption) {
  EXPECT_EQ(IoError("disk full").option(), "");
  EXPECT_EQ(InvalidArgumentError("no target").option(), "");
}

}  // namespace
}  // namespace solid
