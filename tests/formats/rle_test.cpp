#include "solid/formats/rle.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

namespace solid::rle {
namespace {

using ::testing::HasSubstr;

// A row-major mask with its dimensions; bytes other than 0 and 1 are kept to
// check that encoders treat every non-zero byte as set.
struct Mask {
  uint32_t height = 0;
  uint32_t width = 0;
  std::vector<uint8_t> pixels;

  bool at(uint32_t x, uint32_t y) const { return pixels[size_t{y} * width + x] != 0; }
  std::vector<uint8_t> Normalized() const {
    std::vector<uint8_t> ones(pixels.size());
    std::transform(pixels.begin(), pixels.end(), ones.begin(), [](uint8_t v) { return v != 0 ? 1 : 0; });
    return ones;
  }
};

// The definition of COCO runs, one pixel at a time in column-major order.
std::vector<uint32_t> BruteForceRuns(const Mask& mask) {
  std::vector<uint32_t> runs;
  bool current = false;
  uint32_t length = 0;
  for (uint32_t x = 0; x < mask.width; ++x) {
    for (uint32_t y = 0; y < mask.height; ++y) {
      if (mask.at(x, y) != current) {
        runs.push_back(length);
        length = 0;
        current = !current;
      }
      ++length;
    }
  }
  runs.push_back(length);
  return runs;
}

uint64_t BruteForceArea(const Mask& mask) {
  return static_cast<uint64_t>(std::count_if(mask.pixels.begin(), mask.pixels.end(), [](uint8_t v) { return v != 0; }));
}

Box BruteForceBbox(const Mask& mask) {
  int64_t x_min = INT64_MAX, y_min = INT64_MAX, x_max = -1, y_max = -1;
  for (uint32_t y = 0; y < mask.height; ++y) {
    for (uint32_t x = 0; x < mask.width; ++x) {
      if (!mask.at(x, y)) continue;
      x_min = std::min<int64_t>(x_min, x);
      y_min = std::min<int64_t>(y_min, y);
      x_max = std::max<int64_t>(x_max, x);
      y_max = std::max<int64_t>(y_max, y);
    }
  }
  if (x_max < 0) return {};
  return {x_min, y_min, x_max - x_min + 1, y_max - y_min + 1};
}

Mask Combine(const Mask& a, const Mask& b, bool intersect) {
  Mask out{a.height, a.width, std::vector<uint8_t>(a.pixels.size())};
  for (size_t i = 0; i < out.pixels.size(); ++i) {
    const bool in_a = a.pixels[i] != 0, in_b = b.pixels[i] != 0;
    out.pixels[i] = (intersect ? (in_a && in_b) : (in_a || in_b)) ? 1 : 0;
  }
  return out;
}

Rle Encode(const Mask& mask) { return EncodeRowMajor(mask.pixels, mask.height, mask.width); }

// ---------------------------------------------------------------------------
// Random masks

using Rng = std::mt19937_64;

uint32_t Uniform(Rng& rng, uint32_t lo, uint32_t hi) { return std::uniform_int_distribution<uint32_t>(lo, hi)(rng); }

uint8_t RandomSetValue(Rng& rng) { return static_cast<uint8_t>(Uniform(rng, 0, 3) == 0 ? Uniform(rng, 1, 255) : 1); }

Mask NoiseMask(Rng& rng, uint32_t height, uint32_t width) {
  const double density = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
  std::bernoulli_distribution set(density);
  Mask mask{height, width, std::vector<uint8_t>(size_t{height} * width)};
  for (uint8_t& pixel : mask.pixels) pixel = set(rng) ? RandomSetValue(rng) : 0;
  return mask;
}

// A few random ellipses: the connected, mostly convex shapes of real objects.
Mask BlobMask(Rng& rng, uint32_t height, uint32_t width) {
  Mask mask{height, width, std::vector<uint8_t>(size_t{height} * width)};
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const uint32_t blobs = Uniform(rng, 1, 4);
  for (uint32_t i = 0; i < blobs; ++i) {
    const double cx = unit(rng) * width, cy = unit(rng) * height;
    const double rx = 0.5 + unit(rng) * width / 2, ry = 0.5 + unit(rng) * height / 2;
    const uint8_t value = RandomSetValue(rng);
    for (uint32_t y = 0; y < height; ++y) {
      for (uint32_t x = 0; x < width; ++x) {
        const double dx = (x + 0.5 - cx) / rx, dy = (y + 0.5 - cy) / ry;
        if (dx * dx + dy * dy <= 1.0) mask.pixels[size_t{y} * width + x] = value;
      }
    }
  }
  return mask;
}

Mask FilledMask(uint32_t height, uint32_t width, uint8_t value) {
  return {height, width, std::vector<uint8_t>(size_t{height} * width, value)};
}

// Sizes biased towards the edge cases: zero, one row, one column.
std::pair<uint32_t, uint32_t> RandomSize(Rng& rng) {
  switch (Uniform(rng, 0, 5)) {
    case 0: return {1, Uniform(rng, 1, 90)};
    case 1: return {Uniform(rng, 1, 90), 1};
    case 2: return {Uniform(rng, 0, 3), Uniform(rng, 0, 3)};
    default: return {Uniform(rng, 1, 70), Uniform(rng, 1, 70)};
  }
}

Mask RandomMask(Rng& rng, uint32_t height, uint32_t width) {
  switch (Uniform(rng, 0, 5)) {
    case 0: return FilledMask(height, width, 0);
    case 1: return FilledMask(height, width, RandomSetValue(rng));
    case 2:
    case 3: return NoiseMask(rng, height, width);
    default: return BlobMask(rng, height, width);
  }
}

// ---------------------------------------------------------------------------
// (a) Reference vectors from pycocotools

struct ReferenceFile {
  std::vector<nlohmann::json> masks;
  std::vector<nlohmann::json> pairs;
};

ReferenceFile LoadReferenceVectors() {
  // In the repository (tests/formats/data/README.md): these tests may not skip.
  const std::string path = std::string(SOLID_SOURCE_DIR) + "/tests/formats/data/coco_rle_vectors.jsonl";
  std::ifstream in(path);
  ReferenceFile file;
  if (!in) {
    ADD_FAILURE() << "reference vectors missing: " << path;
    return file;
  }
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    nlohmann::json entry = nlohmann::json::parse(line);
    const bool is_pair = entry.at("case").get<std::string>().starts_with("pair-");
    (is_pair ? file.pairs : file.masks).push_back(std::move(entry));
  }
  return file;
}

Mask MaskFromRows(const nlohmann::json& entry) {
  Mask mask{entry.at("h").get<uint32_t>(), entry.at("w").get<uint32_t>(), {}};
  for (const auto& row : entry.at("rows")) {
    for (char c : row.get<std::string>()) mask.pixels.push_back(c == '1' ? 1 : 0);
  }
  return mask;
}

TEST(RleReferenceVectors, SingleMasksMatchPycocotools) {
  const ReferenceFile file = LoadReferenceVectors();
  ASSERT_FALSE(file.masks.empty());
  for (const nlohmann::json& entry : file.masks) {
    SCOPED_TRACE(entry.at("case").get<std::string>());
    const Mask mask = MaskFromRows(entry);
    ASSERT_EQ(mask.pixels.size(), size_t{mask.height} * mask.width);
    const std::string counts = entry.at("counts").get<std::string>();
    const auto runs = entry.at("runs").get<std::vector<uint32_t>>();
    const auto bbox = entry.at("bbox").get<std::vector<int64_t>>();
    ASSERT_EQ(bbox.size(), 4u);

    const Rle encoded = Encode(mask);
    EXPECT_EQ(encoded.counts, runs);
    EXPECT_EQ(ToString(encoded), counts);
    const Result<Rle> parsed = FromString(counts, mask.height, mask.width);
    ASSERT_TRUE(parsed.ok()) << parsed.status().ToString();
    EXPECT_EQ(parsed->counts, runs);
    EXPECT_EQ(Area(encoded), entry.at("area").get<uint64_t>());
    EXPECT_EQ(ToBbox(encoded), (Box{bbox[0], bbox[1], bbox[2], bbox[3]}));
    EXPECT_EQ(DecodeRowMajor(encoded), mask.pixels);
  }
}

TEST(RleReferenceVectors, PairsMatchPycocotools) {
  const ReferenceFile file = LoadReferenceVectors();
  ASSERT_FALSE(file.pairs.empty());
  for (const nlohmann::json& entry : file.pairs) {
    SCOPED_TRACE(entry.at("case").get<std::string>());
    const auto height = entry.at("h").get<uint32_t>(), width = entry.at("w").get<uint32_t>();
    const Result<Rle> a = FromString(entry.at("a").get<std::string>(), height, width);
    const Result<Rle> b = FromString(entry.at("b").get<std::string>(), height, width);
    ASSERT_TRUE(a.ok()) << a.status().ToString();
    ASSERT_TRUE(b.ok()) << b.status().ToString();
    EXPECT_EQ(ToString(Merge(*a, *b, false)), entry.at("union").get<std::string>());
    EXPECT_EQ(ToString(Merge(*a, *b, true)), entry.at("intersection").get<std::string>());
    // Exact: the file holds the shortest decimal that round-trips to pycocotools' double.
    EXPECT_EQ(Iou(*a, *b), entry.at("iou").get<double>());
  }
}

// ---------------------------------------------------------------------------
// (b) Properties against brute force on random masks

TEST(RleProperties, EncodeDecodeStringAreaBboxAgreeWithBruteForce) {
  Rng rng(0x5eed0001);
  for (int iteration = 0; iteration < 3000; ++iteration) {
    const auto [height, width] = RandomSize(rng);
    const Mask mask = RandomMask(rng, height, width);
    SCOPED_TRACE(testing::Message() << "iteration " << iteration << ", " << height << "x" << width);

    const Rle rle = Encode(mask);
    ASSERT_EQ(rle.counts, BruteForceRuns(mask));
    ASSERT_TRUE(Validate(rle).ok()) << Validate(rle).ToString();
    ASSERT_EQ(DecodeRowMajor(rle), mask.Normalized());
    const Result<Rle> parsed = FromString(ToString(rle), height, width);
    ASSERT_TRUE(parsed.ok()) << parsed.status().ToString();
    ASSERT_EQ(*parsed, rle);
    ASSERT_EQ(Area(rle), BruteForceArea(mask));
    ASSERT_EQ(ToBbox(rle), BruteForceBbox(mask));
  }
}

TEST(RleProperties, MergeIouContainsAgreeWithPixelwiseLogic) {
  Rng rng(0x5eed0002);
  for (int iteration = 0; iteration < 2000; ++iteration) {
    const auto [height, width] = RandomSize(rng);
    const Mask a = RandomMask(rng, height, width);
    const Mask b = RandomMask(rng, height, width);
    SCOPED_TRACE(testing::Message() << "iteration " << iteration << ", " << height << "x" << width);
    const Rle rle_a = Encode(a), rle_b = Encode(b);

    const Mask both = Combine(a, b, true), either = Combine(a, b, false);
    ASSERT_EQ(Merge(rle_a, rle_b, false), Encode(either));
    ASSERT_EQ(Merge(rle_a, rle_b, true), Encode(both));

    const uint64_t intersection = BruteForceArea(both), union_area = BruteForceArea(either);
    const double expected_iou =
        intersection == 0 ? 0.0 : static_cast<double>(intersection) / static_cast<double>(union_area);
    ASSERT_EQ(Iou(rle_a, rle_b), expected_iou);

    bool a_contains_b = true;
    for (size_t i = 0; i < a.pixels.size(); ++i) a_contains_b &= a.pixels[i] != 0 || b.pixels[i] == 0;
    ASSERT_EQ(Contains(rle_a, rle_b), a_contains_b);
    ASSERT_TRUE(Contains(rle_a, Encode(both)));
    ASSERT_TRUE(Contains(Encode(either), rle_b));
  }
}

// Paints random rectangles and ellipses with ids taken from `id_pool`, over a background of pool[0].
std::vector<uint32_t> RandomIdImage(Rng& rng, uint32_t height, uint32_t width, const std::vector<uint32_t>& id_pool) {
  std::vector<uint32_t> ids(size_t{height} * width, id_pool[0]);
  if (ids.empty()) return ids;
  const bool noise = Uniform(rng, 0, 3) == 0;
  if (noise) {
    for (uint32_t& id : ids) id = id_pool[Uniform(rng, 0, static_cast<uint32_t>(id_pool.size() - 1))];
    return ids;
  }
  const uint32_t shapes = Uniform(rng, 0, 20);
  for (uint32_t s = 0; s < shapes; ++s) {
    const uint32_t id = id_pool[Uniform(rng, 0, static_cast<uint32_t>(id_pool.size() - 1))];
    const Mask shape = BlobMask(rng, height, width);
    for (size_t i = 0; i < ids.size(); ++i) {
      if (shape.pixels[i] != 0) ids[i] = id;
    }
  }
  return ids;
}

TEST(RleProperties, IdImageEncoderAgreesWithPerIdEncoding) {
  Rng rng(0x5eed0003);
  for (int iteration = 0; iteration < 600; ++iteration) {
    const auto [height, width] = RandomSize(rng);
    // Small dense ids like a renderer's, arbitrary 32-bit ids, and enough ids to grow the id table.
    std::vector<uint32_t> pool;
    switch (iteration % 3) {
      case 0:
        for (uint32_t id = 0; id < 16; ++id) pool.push_back(id);
        break;
      case 1:
        for (int i = 0; i < 6; ++i) pool.push_back(static_cast<uint32_t>(rng()));
        pool.push_back(UINT32_MAX);
        break;
      default:
        for (uint32_t id = 0; id < 400; ++id) pool.push_back(id * 7919u);
        break;
    }
    const std::vector<uint32_t> ids = RandomIdImage(rng, height, width, pool);
    SCOPED_TRACE(testing::Message() << "iteration " << iteration << ", " << height << "x" << width);

    std::map<uint32_t, Mask> expected;
    for (size_t i = 0; i < ids.size(); ++i) {
      auto [it, added] = expected.try_emplace(ids[i], Mask{height, width, std::vector<uint8_t>(ids.size())});
      it->second.pixels[i] = 1;
    }
    const std::vector<IdRle> encoded = EncodeIdImageRowMajor(ids, height, width);
    ASSERT_EQ(encoded.size(), expected.size());
    auto want = expected.begin();
    for (const IdRle& entry : encoded) {
      ASSERT_EQ(entry.id, want->first);
      ASSERT_EQ(entry.rle, Encode(want->second)) << "id " << entry.id;
      ++want;
    }
  }
}

TEST(RleProperties, WindowEncoderAgreesWithTheWholeMask) {
  Rng rng(0x5eed0004);
  for (int iteration = 0; iteration < 600; ++iteration) {
    const auto [height, width] = RandomSize(rng);
    // Windows touching each border, empty ones, and the whole image.
    const auto x0 = static_cast<uint32_t>(rng() % (width + 1)), y0 = static_cast<uint32_t>(rng() % (height + 1));
    const auto ww = static_cast<uint32_t>(rng() % (width - x0 + 1)), wh = static_cast<uint32_t>(rng() % (height - y0 + 1));
    const bool whole = iteration % 10 == 0;
    const uint32_t wx0 = whole ? 0 : x0, wy0 = whole ? 0 : y0, w = whole ? width : ww, h = whole ? height : wh;
    SCOPED_TRACE(testing::Message() << "iteration " << iteration << ", " << height << "x" << width << ", window "
                                    << w << "x" << h << " at " << wx0 << "," << wy0);
    const Mask blob = BlobMask(rng, h, w);
    std::vector<uint8_t> window(size_t{w} * h);
    Mask whole_mask{height, width, std::vector<uint8_t>(size_t{height} * width, 0)};
    for (uint32_t y = 0; y < h; ++y) {
      for (uint32_t x = 0; x < w; ++x) {
        // Set pixels as any nonzero byte, as a mask pass may write them.
        const uint8_t v = blob.pixels[size_t{y} * w + x] != 0 ? static_cast<uint8_t>(1 + rng() % 255) : 0;
        window[size_t{x} * h + y] = v;
        whole_mask.pixels[size_t{wy0 + y} * width + wx0 + x] = v != 0;
      }
    }
    ASSERT_EQ(EncodeColumnMajorWindow(window, wx0, wy0, w, h, height, width), Encode(whole_mask));
  }
}

TEST(RleProperties, FromBoxIsTheClippedHalfOpenRectangle) {
  Rng rng(0x5eed0004);
  for (int iteration = 0; iteration < 3000; ++iteration) {
    const auto [height, width] = RandomSize(rng);
    const auto coordinate = [&] { return static_cast<int64_t>(Uniform(rng, 0, 100)) - 20; };
    const auto extent = [&] { return static_cast<int64_t>(Uniform(rng, 0, 100)) - 30; };
    const Box box{coordinate(), coordinate(), extent(), extent()};
    SCOPED_TRACE(testing::Message() << "iteration " << iteration << ", " << height << "x" << width << ", box "
                                    << box.x << "," << box.y << "," << box.w << "," << box.h);
    Mask rectangle = FilledMask(height, width, 0);
    for (uint32_t y = 0; y < height; ++y) {
      for (uint32_t x = 0; x < width; ++x) {
        const bool inside_x = x >= std::min(box.x, box.x + box.w) && x < std::max(box.x, box.x + box.w);
        const bool inside_y = y >= std::min(box.y, box.y + box.h) && y < std::max(box.y, box.y + box.h);
        rectangle.pixels[size_t{y} * width + x] = inside_x && inside_y;
      }
    }
    ASSERT_EQ(FromBox(box, height, width), Encode(rectangle));
  }
}

TEST(RleFromBox, ExtremeCoordinatesClampWithoutOverflow) {
  const Rle full = Encode(FilledMask(4, 5, 1));
  const Rle empty = Encode(FilledMask(4, 5, 0));
  EXPECT_EQ(FromBox({INT64_MIN, INT64_MIN, INT64_MAX, INT64_MAX}, 4, 5), empty);
  EXPECT_EQ(FromBox({-1, -1, INT64_MAX, INT64_MAX}, 4, 5), full);
  EXPECT_EQ(FromBox({INT64_MAX, INT64_MAX, INT64_MIN, INT64_MIN}, 4, 5), full);
  EXPECT_EQ(FromBox({INT64_MAX, 0, INT64_MAX, 4}, 4, 5), empty);
  EXPECT_EQ(FromBox({0, 0, 5, 4}, 0, 0), (Rle{0, 0, {0}}));
}

TEST(RleEmptyImage, ZeroPixelsEncodeAsOneEmptyRun) {
  const Rle rle = EncodeRowMajor({}, 0, 7);
  EXPECT_EQ(rle, (Rle{0, 7, {0}}));
  EXPECT_EQ(ToString(rle), "0");
  EXPECT_TRUE(DecodeRowMajor(rle).empty());
  EXPECT_EQ(ToBbox(rle), Box{});
  EXPECT_EQ(Area(rle), 0u);
  EXPECT_EQ(Iou(rle, rle), 0.0);
  EXPECT_EQ(Merge(rle, rle, false), rle);
  EXPECT_TRUE(EncodeIdImageRowMajor({}, 7, 0).empty());
}

// Broken preconditions abort with a location instead of reading out of bounds or looping forever.
TEST(RlePreconditionsDeathTest, MismatchedMasksAbort) {
  const Rle three_pixels{1, 3, {3}};
  EXPECT_DEATH(Merge(three_pixels, Rle{3, 1, {3}}, false), "SOLID_CHECK failed");
  EXPECT_DEATH(Iou(three_pixels, Rle{1, 3, {1}}), "SOLID_CHECK failed");
  EXPECT_DEATH(Contains(Rle{1, 3, {1}}, three_pixels), "SOLID_CHECK failed");
  EXPECT_DEATH(EncodeRowMajor(std::vector<uint8_t>(5), 2, 3), "SOLID_CHECK failed");
  EXPECT_DEATH(FromBox({}, 65536, 65536), "SOLID_CHECK failed");
}

// ---------------------------------------------------------------------------
// (c) Malformed and hostile strings

// One COCO number (what ToString writes for a single already-delta-coded value).
std::string CocoNumber(int64_t value) {
  std::string text;
  for (bool more = true; more;) {
    int group = static_cast<int>(value & 0x1f);
    value >>= 5;
    more = (group & 0x10) != 0 ? value != -1 : value != 0;
    text.push_back(static_cast<char>('0' + (more ? group | 0x20 : group)));
  }
  return text;
}

void ExpectError(std::string_view text, uint32_t height, uint32_t width, StatusCode code,
                 std::initializer_list<std::string_view> message_parts) {
  const Result<Rle> parsed = FromString(text, height, width);
  ASSERT_FALSE(parsed.ok()) << "accepted \"" << text << "\"";
  EXPECT_EQ(parsed.status().code(), code) << parsed.status().ToString();
  for (std::string_view part : message_parts) EXPECT_THAT(parsed.status().message(), HasSubstr(std::string(part)));
}

TEST(RleFromString, RejectsCharactersOutsideTheAlphabet) {
  ExpectError("0p", 1, 1, StatusCode::kParseError, {"invalid character 0x70", "offset 1"});
  ExpectError("/", 1, 1, StatusCode::kParseError, {"invalid character 0x2f", "offset 0"});
  ExpectError(std::string("01\0", 3), 1, 1, StatusCode::kParseError, {"invalid character 0x00", "offset 2"});
  ExpectError("0\x80", 1, 1, StatusCode::kParseError, {"invalid character 0x80", "offset 1"});
}

TEST(RleFromString, RejectsStringEndingInsideANumber) {
  ExpectError("1P", 1, 1, StatusCode::kParseError, {"ends inside the number starting at offset 1"});
  ExpectError("o", 1, 1, StatusCode::kParseError, {"ends inside the number starting at offset 0"});
}

TEST(RleFromString, RejectsNumbersOverflowing64Bits) {
  // Twelve 5-bit groups (60 bits) still parse; a thirteenth cannot fit.
  ExpectError(std::string(12, 'P') + "0", 1, 1, StatusCode::kParseError, {"offset 0", "overflows 64 bits"});
  ExpectError("0" + std::string(20, 'o') + "0", 1, 1, StatusCode::kParseError, {"offset 1", "overflows 64 bits"});
  ExpectError(std::string(11, 'P') + "0", 1, 1, StatusCode::kCorrupt, {"sum to 0"});
}

TEST(RleFromString, RejectsRunsOutside32Bits) {
  ExpectError(CocoNumber(int64_t{1} << 32), 65536, 65535, StatusCode::kCorrupt, {"run 0", "offset 0", "exceeds 32 bits"});
  // Run 3 is coded relative to run 1: 5 + UINT32_MAX overflows although each number fits.
  const std::string delta_overflow = CocoNumber(0) + CocoNumber(5) + CocoNumber(1) + CocoNumber(UINT32_MAX);
  ExpectError(delta_overflow, 65536, 65535, StatusCode::kCorrupt, {"run 3", "exceeds 32 bits"});
}

TEST(RleFromString, RejectsNegativeRuns) {
  ExpectError(CocoNumber(-1), 1, 1, StatusCode::kCorrupt, {"run 0", "offset 0", "negative (-1)"});
  // Runs 1, 1, 1, then a delta of -2 against run 1 gives -1.
  const std::string text = CocoNumber(1) + CocoNumber(1) + CocoNumber(1) + CocoNumber(-2);
  ExpectError(text, 2, 2, StatusCode::kCorrupt, {"run 3", "offset 3", "negative (-1) after delta decoding"});
}

TEST(RleFromString, RejectsRunsNotSummingToThePixelCount) {
  ExpectError("5", 2, 2, StatusCode::kCorrupt, {"offset 1", "sum to 5, more than 2x2 = 4"});
  ExpectError("12", 2, 2, StatusCode::kCorrupt, {"sum to 3", "fewer than 2x2 = 4"});
  ExpectError("", 2, 2, StatusCode::kCorrupt, {"empty"});
  ExpectError("", 0, 0, StatusCode::kCorrupt, {"empty"});
}

TEST(RleFromString, RejectsImagesBeyondThe32BitPixelLimit) {
  ExpectError("0", 65536, 65536, StatusCode::kLimitExceeded, {"65536x65536"});
  ExpectError("0", UINT32_MAX, UINT32_MAX, StatusCode::kLimitExceeded, {"exceeds the COCO limit"});
  const Result<Rle> largest = FromString(CocoNumber(UINT32_MAX), 65537, 65535);
  ASSERT_TRUE(largest.ok()) << largest.status().ToString();
  EXPECT_EQ(largest->counts, std::vector<uint32_t>{UINT32_MAX});
}

// pycocotools' parser accepts them, but its merge and iou stop at the first one.
TEST(RleFromString, RejectsEmptyRunsAfterTheFirst) {
  EXPECT_TRUE(FromString("06", 2, 3).ok());
  ExpectError("105", 2, 3, StatusCode::kCorrupt, {"run 1", "offset 1", "empty"});
  // Run 3 equals run 1 plus a delta: 2 + (-2) = 0.
  ExpectError("122N", 2, 4, StatusCode::kCorrupt, {"run 3", "offset 3", "empty"});
}

TEST(RleValidate, ChecksRunSumsAndLimits) {
  EXPECT_TRUE(Validate({2, 3, {1, 5}}).ok());
  EXPECT_TRUE(Validate({2, 3, {0, 6}}).ok());
  EXPECT_TRUE(Validate({0, 3, {0}}).ok());
  EXPECT_EQ(Validate({2, 3, {1, 0, 5}}).code(), StatusCode::kCorrupt);
  EXPECT_EQ(Validate({2, 3, {6, 0}}).code(), StatusCode::kCorrupt);
  EXPECT_EQ(Validate({2, 3, {}}).code(), StatusCode::kCorrupt);
  EXPECT_EQ(Validate({2, 3, {1, 4}}).code(), StatusCode::kCorrupt);
  EXPECT_EQ(Validate({2, 3, {UINT32_MAX, UINT32_MAX, 7}}).code(), StatusCode::kCorrupt);
  EXPECT_EQ(Validate({65536, 65536, {0}}).code(), StatusCode::kLimitExceeded);
}

// Hostile input never crashes: it parses into a valid RLE or is rejected as malformed.
TEST(RleFromString, RandomStringsParseValidlyOrFail) {
  Rng rng(0x5eed0005);
  int accepted = 0;
  for (int iteration = 0; iteration < 8000; ++iteration) {
    const uint32_t height = Uniform(rng, 0, 12), width = Uniform(rng, 0, 12);
    std::string text;
    switch (iteration % 3) {
      case 0:  // any bytes
        text.resize(Uniform(rng, 0, 24));
        for (char& c : text) c = static_cast<char>(Uniform(rng, 0, 255));
        break;
      case 1:  // the COCO alphabet: reaches the numeric and sum checks
        text.resize(Uniform(rng, 0, 24));
        for (char& c : text) c = static_cast<char>('0' + Uniform(rng, 0, 63));
        break;
      default: {  // a valid string with a few characters replaced, inserted or dropped
        text = ToString(Encode(RandomMask(rng, height, width)));
        for (uint32_t edits = Uniform(rng, 0, 2); edits > 0 && !text.empty(); --edits) {
          const size_t at = Uniform(rng, 0, static_cast<uint32_t>(text.size() - 1));
          const char replacement = static_cast<char>('0' + Uniform(rng, 0, 63));
          switch (Uniform(rng, 0, 2)) {
            case 0: text[at] = replacement; break;
            case 1: text.insert(text.begin() + static_cast<std::ptrdiff_t>(at), replacement); break;
            default: text.erase(at, 1); break;
          }
        }
      }
    }
    const Result<Rle> parsed = FromString(text, height, width);
    if (parsed.ok()) {
      ++accepted;
      ASSERT_TRUE(Validate(*parsed).ok()) << text;
      // Numbers may carry redundant groups ("P0" is 0), so compare runs, not strings.
      const Result<Rle> reparsed = FromString(ToString(*parsed), height, width);
      ASSERT_TRUE(reparsed.ok()) << text;
      ASSERT_EQ(*reparsed, *parsed) << text;
      ASSERT_EQ(Encode({height, width, DecodeRowMajor(*parsed)}), *parsed) << text;
    } else {
      const StatusCode code = parsed.status().code();
      ASSERT_TRUE(code == StatusCode::kParseError || code == StatusCode::kCorrupt) << parsed.status().ToString();
      if (!text.empty()) {
        ASSERT_THAT(parsed.status().message(), HasSubstr("offset")) << parsed.status().ToString();
      }
    }
  }
  EXPECT_GT(accepted, 500);  // the generator must reach the success path too
}

}  // namespace
}  // namespace solid::rle
