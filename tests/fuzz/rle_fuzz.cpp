// libFuzzer target for the COCO RLE decoder (rle::FromString) and validity check
// (rle::Validate), the entry points of RLE strings read from shards and COCO files.
// Input: a mode byte, height and width (little-endian uint32 each), then the payload:
// a counts string (mode bit 0 set) or an array of little-endian uint32 runs for Validate.
// Every RLE accepted is checked against the properties the rest of the code relies on:
// it re-encodes to itself, and (when small enough to decode) Decode(Encode(m)) == m,
// Area and ToBbox agree with the decoded mask, and Merge, Iou and Contains behave as
// set operations on it.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <span>
#include <string_view>
#include <vector>

#include "fuzz/fuzz_util.h"
#include "solid/formats/rle.h"

namespace {

using solid::fuzz::Fail;
namespace rle = solid::rle;

// Decoding allocates height * width bytes: properties that need the mask only below this.
constexpr uint64_t kMaxDecodedPixels = uint64_t{1} << 16;

uint32_t LoadU32(const uint8_t* p) {
  uint32_t v = 0;
  std::memcpy(&v, p, 4);
  return v;
}

rle::Box BoxOfMask(const std::vector<uint8_t>& mask, uint32_t width) {
  // Over the mask, not over height and width: one of them may be huge when the other is 0.
  int64_t x0 = width, y0 = INT64_MAX, x1 = -1, y1 = -1;
  for (size_t i = 0; i < mask.size(); ++i) {
    if (mask[i] == 0) continue;
    const auto x = static_cast<int64_t>(i % width), y = static_cast<int64_t>(i / width);
    x0 = std::min(x0, x);
    y0 = std::min(y0, y);
    x1 = std::max(x1, x);
    y1 = std::max(y1, y);
  }
  if (x1 < 0) return {};
  return {x0, y0, x1 - x0 + 1, y1 - y0 + 1};
}

void CheckValid(const rle::Rle& r) {
  if (!rle::Validate(r).ok()) Fail("a decoded RLE does not validate");
  solid::Result<rle::Rle> again = rle::FromString(rle::ToString(r), r.height, r.width);
  if (!again.ok() || *again != r) Fail("FromString(ToString(r)) != r");
  const uint64_t pixels = uint64_t{r.height} * r.width;
  if (pixels > kMaxDecodedPixels) return;

  const std::vector<uint8_t> mask = rle::DecodeRowMajor(r);
  if (mask.size() != pixels) Fail("decoded mask has the wrong size");
  if (rle::EncodeRowMajor(mask, r.height, r.width) != r) Fail("Encode(Decode(r)) != r");
  const auto area = static_cast<uint64_t>(std::count(mask.begin(), mask.end(), 1));
  if (rle::Area(r) != area) Fail("Area differs from the decoded mask");
  if (rle::ToBbox(r) != BoxOfMask(mask, r.width)) Fail("ToBbox differs from the decoded mask");
  if (!rle::Contains(r, r)) Fail("an RLE does not contain itself");
  if (rle::Merge(r, r, true) != r || rle::Merge(r, r, false) != r) Fail("merging an RLE with itself changes it");
  if (area > 0 && rle::Iou(r, r) != 1.0) Fail("Iou(r, r) != 1");

  // Against the mask's complement: disjoint, and their union is everything.
  std::vector<uint8_t> inverse(mask.size());
  std::transform(mask.begin(), mask.end(), inverse.begin(), [](uint8_t v) { return static_cast<uint8_t>(v == 0); });
  const rle::Rle complement = rle::EncodeRowMajor(inverse, r.height, r.width);
  if (rle::Area(rle::Merge(r, complement, true)) != 0) Fail("a mask meets its complement");
  if (rle::Area(rle::Merge(r, complement, false)) != pixels) Fail("a mask and its complement do not cover the image");
  if (rle::Iou(r, complement) != 0.0) Fail("Iou of a mask and its complement is not 0");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 9) return 0;
  const bool string_mode = (data[0] & 1) != 0;
  const uint32_t height = LoadU32(data + 1), width = LoadU32(data + 5);
  const std::span<const uint8_t> payload(data + 9, size - 9);
  if (string_mode) {
    const std::string_view text(reinterpret_cast<const char*>(payload.data()), payload.size());
    solid::Result<rle::Rle> r = rle::FromString(text, height, width);
    if (r.ok()) {
      if (r->height != height || r->width != width) Fail("FromString changed the dimensions");
      CheckValid(*r);
    }
  } else {
    rle::Rle r{height, width, std::vector<uint32_t>(payload.size() / 4)};
    for (size_t i = 0; i < r.counts.size(); ++i) r.counts[i] = LoadU32(payload.data() + 4 * i);
    if (rle::Validate(r).ok()) CheckValid(r);
  }
  return 0;
}
