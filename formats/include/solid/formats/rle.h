// COCO run-length encoded masks, bit-for-bit compatible with pycocotools
// (common/maskApi.c of cocodataset/cocoapi).
//
// A mask of height x width pixels is read in column-major (Fortran) order, the
// order COCO uses, and stored as the lengths of alternating runs of unset and
// set pixels, starting with an unset run (which is 0 when the first pixel is
// set). Our images are row-major, so the encoders and the decoder take and give
// row-major buffers and do the reordering themselves.
//
// Limits: width * height must not exceed kMaxPixels, because COCO stores run
// lengths and pixel positions as 32-bit unsigned integers.
//
// Functions taking an Rle require it to be valid (Validate returns Ok), which
// every Rle produced by this module is. Functions taking two Rle require equal
// dimensions. Breaking either precondition is a programming error: the result
// is unspecified or the process aborts through SOLID_CHECK, but there is no
// undefined behaviour.
//
// Thread safety: every function is pure; concurrent calls are safe as long as
// no caller mutates an argument during the call.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "solid/formats/status.h"

namespace solid::rle {

inline constexpr uint64_t kMaxPixels = UINT32_MAX;

struct Rle {
  uint32_t height = 0;
  uint32_t width = 0;
  std::vector<uint32_t> counts;  // run lengths in pixels, column-major, first run unset

  friend bool operator==(const Rle&, const Rle&) = default;
};

// COCO [x, y, width, height] in pixels; x is the column. All zero for an empty mask.
struct Box {
  int64_t x = 0;
  int64_t y = 0;
  int64_t w = 0;
  int64_t h = 0;

  friend bool operator==(const Box&, const Box&) = default;
};

// mask[y * width + x] != 0 means pixel (x, y) is set.
// Precondition: mask.size() == height * width <= kMaxPixels (checked).
Rle EncodeRowMajor(std::span<const uint8_t> mask, uint32_t height, uint32_t width);

// A height x width mask that is unset outside the window [x0, x0 + window_width) x
// [y0, y0 + window_height) and `window` inside it, given column by column (window[(x -
// x0) * window_height + (y - y0)] != 0 sets pixel (x, y)). Equals EncodeRowMajor of that
// mask, without a whole-image buffer: a mask pass that knows where an object can lie
// writes only that window.
// Precondition: the window lies within the image, window.size() == window_width *
// window_height, height * width <= kMaxPixels (checked).
Rle EncodeColumnMajorWindow(std::span<const uint8_t> window, uint32_t x0, uint32_t y0, uint32_t window_width,
                            uint32_t window_height, uint32_t height, uint32_t width);

struct IdRle {
  uint32_t id = 0;
  Rle rle;  // the mask of the pixels whose id equals `id`
};

// Encodes every id that occurs in a row-major id image (0 included: callers
// drop the ids they treat as background) in one pass over the pixels.
// Returns one entry per distinct id, sorted by id; each equals
// EncodeRowMajor of the mask (ids == id).
// Precondition: ids.size() == height * width <= kMaxPixels (checked).
std::vector<IdRle> EncodeIdImageRowMajor(std::span<const uint32_t> ids, uint32_t height,
                                         uint32_t width);

// Row-major mask of height * width bytes, 1 for set pixels and 0 otherwise.
std::vector<uint8_t> DecodeRowMajor(const Rle& rle);

// pycocotools' compressed `counts` string (6 bits per character, '0'..'o').
std::string ToString(const Rle& rle);

// Parses a compressed `counts` string from untrusted input. Errors:
//   kParseError: a character outside '0'..'o', a string ending inside a
//     number, or a number that needs more than 64 bits;
//   kCorrupt: an empty string, a run that is negative, empty (except the
//     first) or exceeds 32 bits after undoing the delta coding, or runs that
//     do not sum to height * width;
//   kLimitExceeded: height * width > kMaxPixels.
// Messages name the problem and the character offset where it was found.
// pycocotools never writes empty runs after the first and its merge and iou
// stop early on them, so they are rejected although its parser accepts them.
Result<Rle> FromString(std::string_view counts, uint32_t height, uint32_t width);

// Ok when height * width <= kMaxPixels, there is at least one run, no run but
// the first is empty, and the runs sum to exactly height * width; kCorrupt or
// kLimitExceeded otherwise. A valid Rle is the unique encoding of its mask.
Status Validate(const Rle& rle);

// Number of set pixels.
uint64_t Area(const Rle& rle);

// pycocotools' toBbox: the tight box of the set pixels.
Box ToBbox(const Rle& rle);

// pycocotools' merge of two masks: intersection when `intersect`, else union.
Rle Merge(const Rle& a, const Rle& b, bool intersect);

// pycocotools' iou with iscrowd = 0: |a & b| / |a | b|, and 0 when disjoint.
double Iou(const Rle& a, const Rle& b);

// The mask pycocotools' frBbox gives for an integer box: the pixels with
// x in [min(box.x, box.x + box.w), max(...)) and y likewise, clipped to the
// image. Coordinates may be negative or lie outside the image.
// Precondition: height * width <= kMaxPixels (checked).
Rle FromBox(const Box& box, uint32_t height, uint32_t width);

// True when every set pixel of `inner` is set in `outer`.
bool Contains(const Rle& outer, const Rle& inner);

}  // namespace solid::rle
