#include "solid/formats/image_codec.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <utility>

#include "fixtures/crafted_images.h"
#include "formats/test_util.h"

namespace solid {
namespace {

Image8 Gradient(uint32_t w, uint32_t h, uint32_t channels) {
  Image8 im{w, h, channels, std::vector<uint8_t>(size_t{w} * h * channels)};
  for (size_t i = 0; i < im.pixels.size(); ++i) im.pixels[i] = static_cast<uint8_t>((i * 7) % 251);
  return im;
}

TEST(ImageCodec, PngIsLosslessAndDeterministic) {
  Image8 im = Gradient(37, 21, 3);
  auto a = EncodeImage(im, ImageFormat::kPng);
  auto b = EncodeImage(im, ImageFormat::kPng);
  ASSERT_OK(a.status());
  ASSERT_OK(b.status());
  EXPECT_EQ(*a, *b);
  auto decoded = DecodeImage(*a, ImageFormat::kPng);
  ASSERT_OK(decoded.status());
  EXPECT_EQ(decoded->width, 37u);
  EXPECT_EQ(decoded->height, 21u);
  EXPECT_EQ(decoded->channels, 3u);
  EXPECT_EQ(decoded->pixels, im.pixels);
}

// Our PNG writer (libdeflate) read back by libpng, which checks every chunk's CRC and the
// zlib stream's Adler-32: every colour type, rows of one pixel, one row, noise that deflate
// cannot shrink and flat images it shrinks a thousandfold.
TEST(ImageCodec, PngOfEveryChannelCountAndShapeDecodesExactly) {
  uint64_t state = 0x9e3779b97f4a7c15u;
  auto next_byte = [&state] {
    state = state * 6364136223846793005u + 1442695040888963407u;
    return static_cast<uint8_t>(state >> 56);
  };
  for (uint32_t channels = 1; channels <= 4; ++channels) {
    for (auto [w, h] : {std::pair<uint32_t, uint32_t>{1, 1}, {1, 9}, {9, 1}, {33, 17}, {640, 480}}) {
      for (bool noise : {false, true}) {
        Image8 im{w, h, channels, std::vector<uint8_t>(size_t{w} * h * channels, 200)};
        if (noise) {
          for (uint8_t& v : im.pixels) v = next_byte();
        }
        SCOPED_TRACE(fmt::format("{}x{}x{} {}", w, h, channels, noise ? "noise" : "flat"));
        auto encoded = EncodeImage(im, ImageFormat::kPng);
        ASSERT_OK(encoded.status());
        auto decoded = DecodeImage(*encoded, ImageFormat::kPng);
        ASSERT_OK(decoded.status());
        EXPECT_EQ(decoded->width, w);
        EXPECT_EQ(decoded->height, h);
        EXPECT_EQ(decoded->channels, channels);
        EXPECT_EQ(decoded->pixels, im.pixels);
        if (!noise && w * h > 1000) {
          EXPECT_LT(encoded->size(), im.pixels.size() / 100);
        }
      }
    }
  }
}

TEST(ImageCodec, JpegRoundTripsWithinLossyTolerance) {
  Image8 im{64, 64, 3, std::vector<uint8_t>(64 * 64 * 3, 128)};
  auto bytes = EncodeImage(im, ImageFormat::kJpeg, 95);
  ASSERT_OK(bytes.status());
  auto decoded = DecodeImage(*bytes, ImageFormat::kJpeg);
  ASSERT_OK(decoded.status());
  // A flat image survives JPEG at quality 95 to within 2 levels per pixel.
  for (uint8_t v : decoded->pixels) EXPECT_NEAR(v, 128, 2);
}

TEST(ImageCodec, DepthExrKeepsHalfPrecision) {
  DepthImage depth{13, 7, std::vector<float>(13 * 7)};
  for (size_t i = 0; i < depth.values.size(); ++i) depth.values[i] = 0.5f + 0.37f * static_cast<float>(i);
  auto bytes = EncodeDepthExr(depth);
  ASSERT_OK(bytes.status());
  auto decoded = DecodeDepthExr(*bytes);
  ASSERT_OK(decoded.status());
  ASSERT_EQ(decoded->values.size(), depth.values.size());
  // half has an 11-bit significand: relative error at most 2^-11.
  for (size_t i = 0; i < depth.values.size(); ++i) {
    EXPECT_NEAR(decoded->values[i], depth.values[i], depth.values[i] * (1.0 / 2048));
  }
}

TEST(ImageCodec, RefusesDecompressionBombsBeforeDecoding) {
  const std::vector<uint8_t> bomb = fixtures::PngClaimingSize(100000, 100000);
  auto decoded = DecodeImage(bomb, ImageFormat::kPng);
  ASSERT_FALSE(decoded.ok());
  EXPECT_EQ(decoded.status().code(), StatusCode::kLimitExceeded) << decoded.status().ToString();
  EXPECT_NE(decoded.status().message().find("100000x100000"), std::string::npos) << decoded.status().message();
}

TEST(ImageCodec, GarbageIsAnErrorNotACrash) {
  std::vector<uint8_t> garbage(300);
  for (size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<uint8_t>(i * 31);
  for (ImageFormat f : {ImageFormat::kPng, ImageFormat::kJpeg, ImageFormat::kWebp}) {
    EXPECT_FALSE(DecodeImage(garbage, f).ok());
  }
  EXPECT_FALSE(DecodeDepthExr(garbage).ok());
  EXPECT_FALSE(DecodeImage({}, ImageFormat::kPng).ok());
}

// Inputs that fuzz targets (tests/fuzz) found, checked in under tests/formats/regressions/.
std::vector<uint8_t> Regression(const std::string& name) {
  std::ifstream in(std::string(SOLID_SOURCE_DIR) + "/tests/formats/regressions/" + name, std::ios::binary);
  EXPECT_TRUE(in.good()) << name;
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// An EXR the header walk refuses: as a depth map, and as every image format, decoded or
// only its header read, with `code` and a message holding `message`.
void ExpectExrRefusedEverywhere(const std::vector<uint8_t>& bytes, StatusCode code, const std::string& message) {
  Result<DepthImage> depth = DecodeDepthExr(bytes);
  ASSERT_FALSE(depth.ok());
  EXPECT_EQ(depth.status().code(), code);
  EXPECT_NE(depth.status().message().find(message), std::string::npos) << depth.status().message();
  for (ImageFormat f : {ImageFormat::kPng, ImageFormat::kJpeg, ImageFormat::kWebp}) {
    for (const Status& status : {DecodeImage(bytes, f).status(), ReadImageHeader(bytes, f, kTextureLimits).status()}) {
      ASSERT_FALSE(status.ok());
      EXPECT_EQ(status.code(), code) << status.message();
      EXPECT_NE(status.message().find(message), std::string::npos) << status.message();
    }
  }
}

// image_fuzz timeout-441e85de: a 690-byte EXR whose header attributes claim megabytes, which
// OpenEXR allocated (and OpenImageIO then probed every other format) for over 10 s under ASan.
// Refused from the header walk, naming the attribute's offset and claim, whatever it is read as.
TEST(ImageCodec, ImageFuzzTimeout441e85deHugeExrAttribute) {
  const std::vector<uint8_t> bytes = Regression("image-timeout-441e85de.exr");
  ASSERT_EQ(bytes.size(), 690u);
  ExpectExrRefusedEverywhere(bytes, StatusCode::kParseError,
                             "header at byte 151: an attribute claims 16800256 bytes, 515 remain");
}

// image_fuzz slow-unit-87c0c1ca: a 252-byte EXR whose data window claims 20000631x3 pixels;
// OpenEXR spent 15 s opening it, before the limits (checked on the opened header) could
// refuse it. Refused from the header walk, as a depth map and as any image format.
TEST(ImageCodec, ImageFuzzSlowUnit87c0c1caHugeExrDataWindow) {
  const std::vector<uint8_t> bytes = Regression("image-slow-87c0c1ca.exr");
  ASSERT_EQ(bytes.size(), 252u);
  ExpectExrRefusedEverywhere(bytes, StatusCode::kLimitExceeded, "header at byte 114 claims a 20000631x3 data window");
}

// image_fuzz timeout-16617999: a 357-byte EXR whose attributes fit the file but whose parse
// by content sent OpenEXR past the header, into allocations that took over 10 s under ASan.
TEST(ImageCodec, ImageFuzzTimeout16617999ExrParsedPastItsHeader) {
  const std::vector<uint8_t> bytes = Regression("image-timeout-16617999.exr");
  ASSERT_EQ(bytes.size(), 357u);
  Result<DepthImage> depth = DecodeDepthExr(bytes);
  ASSERT_FALSE(depth.ok());
  EXPECT_EQ(depth.status().code(), StatusCode::kParseError);
  EXPECT_NE(depth.status().message().find("decoding EXR: header at byte"), std::string::npos)
      << depth.status().message();
}

TEST(ImageCodec, ExrHeaderWalkAcceptsWhatWeWrite) {
  DepthImage depth{3, 2, {1, 2, 3, 4, 5, 6}};
  Result<std::vector<uint8_t>> bytes = EncodeDepthExr(depth);
  ASSERT_OK(bytes.status());
  Result<DepthImage> decoded = DecodeDepthExr(*bytes);
  ASSERT_OK(decoded.status());
  EXPECT_EQ(decoded->values, depth.values);
  // Cut inside the header: refused by the walk rather than handed to OpenEXR.
  std::vector<uint8_t> cut(bytes->begin(), bytes->begin() + 40);
  Result<DepthImage> truncated = DecodeDepthExr(cut);
  ASSERT_FALSE(truncated.ok());
  EXPECT_NE(truncated.status().message().find("header at byte"), std::string::npos) << truncated.status().message();
}

TEST(ImageCodec, RejectsMismatchedBuffers) {
  Image8 wrong{4, 4, 3, std::vector<uint8_t>(10)};
  EXPECT_EQ(EncodeImage(wrong, ImageFormat::kPng).status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace solid
