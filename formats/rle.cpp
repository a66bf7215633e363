#include "solid/formats/rle.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <numeric>
#include <utility>

namespace solid::rle {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the row scans turn bit positions in loaded words into byte offsets assuming little endian");

uint32_t CheckedPixelCount(uint32_t height, uint32_t width) {
  const uint64_t total = uint64_t{height} * width;
  SOLID_CHECK(total <= kMaxPixels);
  return static_cast<uint32_t>(total);
}

uint32_t CheckedPixelCount(size_t buffer_size, uint32_t height, uint32_t width) {
  const uint32_t total = CheckedPixelCount(height, width);
  SOLID_CHECK(buffer_size == total);
  return total;
}

uint64_t Load64(const void* bytes) {
  uint64_t word;
  std::memcpy(&word, bytes, sizeof word);
  return word;
}

// 16 bytes in one SIMD register (SSE2, NEON); GCC and Clang lower it portably.
using Vector16 = uint8_t __attribute__((vector_size(16)));

// Sets the top bit of every byte of `word` that is non-zero, clears all other bits.
// The per-byte sum cannot carry into the next byte because both terms are < 0x80.
uint64_t NonZeroByteFlags(uint64_t word) {
  constexpr uint64_t kLow7 = 0x7F7F7F7F7F7F7F7FULL;
  return (((word & kLow7) + kLow7) | word) & ~kLow7;
}

// True when the 32 bytes at `a` and `b` are equal. Neighbouring rows of a mask
// or id image mostly are, so the scans below skip them a block at a time.
bool Equal32(const void* a, const void* b) {
  Vector16 a_low, a_high, b_low, b_high;
  std::memcpy(&a_low, a, 16);
  std::memcpy(&a_high, static_cast<const uint8_t*>(a) + 16, 16);
  std::memcpy(&b_low, b, 16);
  std::memcpy(&b_high, static_cast<const uint8_t*>(b) + 16, 16);
  const Vector16 differences = (a_low ^ b_low) | (a_high ^ b_high);
  uint64_t halves[2];
  std::memcpy(halves, &differences, sizeof halves);
  return (halves[0] | halves[1]) == 0;
}

// Calls on_change(x) for every column x where `row` and `above` disagree on
// whether the pixel is set.
template <typename OnChange>
void ForEachSetnessChange(const uint8_t* above, const uint8_t* row, uint32_t width, OnChange on_change) {
  uint32_t x = 0;
  const auto scan_word = [&](uint32_t word_x) {
    const uint64_t a = Load64(above + word_x);
    const uint64_t b = Load64(row + word_x);
    if (a == b) return;
    for (uint64_t changed = NonZeroByteFlags(a) ^ NonZeroByteFlags(b); changed != 0; changed &= changed - 1) {
      on_change(word_x + static_cast<uint32_t>(std::countr_zero(changed)) / 8);
    }
  };
  for (; x + 32 <= width; x += 32) {
    if (Equal32(above + x, row + x)) continue;
    for (uint32_t word_x = x; word_x < x + 32; word_x += 8) scan_word(word_x);
  }
  for (; x + 8 <= width; x += 8) scan_word(x);
  for (; x < width; ++x) {
    if ((above[x] != 0) != (row[x] != 0)) on_change(x);
  }
}

// Same for id images.
template <typename OnChange>
void ForEachIdChange(const uint32_t* above, const uint32_t* row, uint32_t width, OnChange on_change) {
  uint32_t x = 0;
  for (; x + 8 <= width; x += 8) {
    if (Equal32(above + x, row + x)) continue;
    for (uint32_t i = x; i < x + 8; ++i) {
      if (above[i] != row[i]) on_change(i);
    }
  }
  for (; x < width; ++x) {
    if (above[x] != row[x]) on_change(x);
  }
}

struct Pixel {
  uint32_t x;
  uint32_t y;
};

// Pixels where the value differs from the previous pixel in column-major order,
// found while scanning rows top to bottom (the cache-friendly order for a
// row-major image) and then put into column-major order by a counting sort on
// the column. The sort is stable, so each column keeps its top-to-bottom order.
class ChangeCollector {
 public:
  explicit ChangeCollector(uint32_t width) : column_starts_(size_t{width} + 1, 0) {}

  void Add(uint32_t x, uint32_t y) {
    found_.push_back({x, y});
    ++column_starts_[x + 1];
  }

  std::vector<Pixel> InColumnMajorOrder() {
    std::partial_sum(column_starts_.begin(), column_starts_.end(), column_starts_.begin());
    std::vector<Pixel> sorted(found_.size());
    for (const Pixel& pixel : found_) sorted[column_starts_[pixel.x]++] = pixel;
    return sorted;
  }

 private:
  std::vector<Pixel> found_;
  std::vector<uint32_t> column_starts_;
};

ChangeCollector FindSetnessChanges(const uint8_t* mask, uint32_t height, uint32_t width) {
  ChangeCollector changes(width);
  // Row 0 continues the bottom of the previous column; pixel 0 follows an unset pixel.
  const uint8_t* bottom_row = mask + size_t{height - 1} * width;
  if (mask[0] != 0) changes.Add(0, 0);
  for (uint32_t x = 1; x < width; ++x) {
    if ((mask[x] != 0) != (bottom_row[x - 1] != 0)) changes.Add(x, 0);
  }
  for (uint32_t y = 1; y < height; ++y) {
    const uint8_t* row = mask + size_t{y} * width;
    ForEachSetnessChange(row - width, row, width, [&](uint32_t x) { changes.Add(x, y); });
  }
  return changes;
}

ChangeCollector FindIdChanges(const uint32_t* ids, uint32_t height, uint32_t width) {
  ChangeCollector changes(width);
  // Pixel 0 always starts a run: of whichever id it holds.
  const uint32_t* bottom_row = ids + size_t{height - 1} * width;
  changes.Add(0, 0);
  for (uint32_t x = 1; x < width; ++x) {
    if (ids[x] != bottom_row[x - 1]) changes.Add(x, 0);
  }
  for (uint32_t y = 1; y < height; ++y) {
    const uint32_t* row = ids + size_t{y} * width;
    ForEachIdChange(row - width, row, width, [&](uint32_t x) { changes.Add(x, y); });
  }
  return changes;
}

// Turns the ascending positions where a mask flips into run lengths, in place.
void FlipPositionsToRuns(std::vector<uint32_t>& positions, uint32_t total) {
  uint32_t previous = 0;
  for (uint32_t& position : positions) {
    const uint32_t start = position;
    position = start - previous;
    previous = start;
  }
  positions.push_back(total - previous);
}

// Distinct ids in first-seen order. Open addressing with Fibonacci hashing,
// because ids are arbitrary 32-bit values and every change looks up two of them.
class IdIndex {
 public:
  // Index of `id`; a new id gets the next index.
  uint32_t IndexOf(uint32_t id) {
    for (;;) {
      const size_t mask = slots_.size() - 1;
      for (size_t i = Home(id);; i = (i + 1) & mask) {
        Slot& slot = slots_[i];
        if (slot.index == kFree) {
          if (2 * (size_t{count_} + 1) > slots_.size()) break;  // keep the load at most 1/2
          slot = {id, count_};
          return count_++;
        }
        if (slot.id == id) return slot.index;
      }
      Grow();
    }
  }

 private:
  struct Slot {
    uint32_t id = 0;
    uint32_t index = kFree;
  };
  static constexpr uint32_t kFree = UINT32_MAX;

  size_t Home(uint32_t id) const { return (id * 0x9E3779B1u) >> shift_; }

  void Grow() {
    std::vector<Slot> old = std::exchange(slots_, std::vector<Slot>(slots_.size() * 2));
    --shift_;
    const size_t mask = slots_.size() - 1;
    for (const Slot& slot : old) {
      if (slot.index == kFree) continue;
      size_t i = Home(slot.id);
      while (slots_[i].index != kFree) i = (i + 1) & mask;
      slots_[i] = slot;
    }
  }

  std::vector<Slot> slots_ = std::vector<Slot>(16);
  int shift_ = 32 - 4;
  uint32_t count_ = 0;
};

// Walks the runs of one mask. A used-up run is replaced by the next one and
// flips the value; an empty first run is used up by a zero-pixel step.
class RunCursor {
 public:
  explicit RunCursor(const std::vector<uint32_t>& runs) : runs_(runs), left_(runs.empty() ? 0 : runs[0]) {}

  uint32_t left() const { return left_; }
  bool set() const { return set_; }
  bool exhausted() const { return left_ == 0 && next_ >= runs_.size(); }

  void Advance(uint32_t pixels) {
    left_ -= pixels;
    if (left_ == 0 && next_ < runs_.size()) {
      left_ = runs_[next_++];
      set_ = !set_;
    }
  }

 private:
  const std::vector<uint32_t>& runs_;
  size_t next_ = 1;
  uint32_t left_;
  bool set_ = false;
};

// Calls step(pixels, a_set, b_set) for consecutive stretches where neither
// mask changes, in the step sequence of maskApi.c (which starts with a
// zero-pixel step when a mask starts set), until both masks are used up or
// step returns false.
template <typename Step>
void WalkTogether(const Rle& a, const Rle& b, Step step) {
  SOLID_CHECK(a.height == b.height && a.width == b.width);
  RunCursor in_a(a.counts);
  RunCursor in_b(b.counts);
  for (;;) {
    // Runs covering different pixel counts would stall the walk on zero-pixel steps.
    SOLID_CHECK(!(in_a.exhausted() && in_b.left() > 0) && !(in_b.exhausted() && in_a.left() > 0));
    const uint32_t pixels = std::min(in_a.left(), in_b.left());
    if (!step(pixels, in_a.set(), in_b.set())) return;
    in_a.Advance(pixels);
    in_b.Advance(pixels);
    if (in_a.left() == 0 && in_b.left() == 0) return;
  }
}

// Clamps the interval between `start` and `start + extent` (either order) to
// [0, limit], for any int64 inputs.
std::pair<uint32_t, uint32_t> ClampedInterval(int64_t start, int64_t extent, uint32_t limit) {
  const auto clamp = [limit](int64_t v) { return static_cast<uint32_t>(std::clamp<int64_t>(v, 0, limit)); };
  int64_t end = 0;
  const uint32_t clamped_end =
      __builtin_add_overflow(start, extent, &end) ? (extent > 0 ? limit : 0) : clamp(end);
  const uint32_t clamped_start = clamp(start);
  return std::minmax(clamped_start, clamped_end);
}

// Appends runs, merging equal neighbours and skipping empty ones, so that the
// result is canonical whatever the caller's segmentation.
class RunBuilder {
 public:
  explicit RunBuilder(std::vector<uint32_t>& runs) : runs_(runs) { runs_.assign(1, 0); }

  void Append(bool set, uint32_t pixels) {
    if (pixels == 0) return;
    if (set != set_) {
      runs_.push_back(0);
      set_ = set;
    }
    runs_.back() += pixels;
  }

 private:
  std::vector<uint32_t>& runs_;
  bool set_ = false;
};

}  // namespace

Rle EncodeRowMajor(std::span<const uint8_t> mask, uint32_t height, uint32_t width) {
  const uint32_t total = CheckedPixelCount(mask.size(), height, width);
  Rle rle{height, width, {}};
  if (total == 0) {
    rle.counts = {0};  // what maskApi.c produces when there are no pixels
    return rle;
  }
  const std::vector<Pixel> changes = FindSetnessChanges(mask.data(), height, width).InColumnMajorOrder();
  rle.counts.reserve(changes.size() + 1);
  for (const Pixel& pixel : changes) rle.counts.push_back(pixel.x * height + pixel.y);
  FlipPositionsToRuns(rle.counts, total);
  return rle;
}

Rle EncodeColumnMajorWindow(std::span<const uint8_t> window, uint32_t x0, uint32_t y0, uint32_t window_width,
                            uint32_t window_height, uint32_t height, uint32_t width) {
  const uint32_t total = CheckedPixelCount(height, width);
  SOLID_CHECK(x0 <= width && window_width <= width - x0 && y0 <= height && window_height <= height - y0);
  SOLID_CHECK(window.size() == size_t{window_width} * window_height);
  Rle rle{height, width, {}};
  if (total == 0) {
    rle.counts = {0};  // as EncodeRowMajor
    return rle;
  }
  RunBuilder runs(rle.counts);
  runs.Append(false, x0 * height);
  for (uint32_t x = 0; x < window_width; ++x) {
    runs.Append(false, y0);
    const uint8_t* column = window.data() + size_t{x} * window_height;
    for (uint32_t y = 0; y < window_height;) {
      const bool set = column[y] != 0;
      uint32_t end = y + 1;
      while (end < window_height && (column[end] != 0) == set) ++end;
      runs.Append(set, end - y);
      y = end;
    }
    runs.Append(false, height - y0 - window_height);
  }
  runs.Append(false, (width - x0 - window_width) * height);
  return rle;
}

std::vector<IdRle> EncodeIdImageRowMajor(std::span<const uint32_t> ids, uint32_t height, uint32_t width) {
  const uint32_t total = CheckedPixelCount(ids.size(), height, width);
  std::vector<IdRle> encoded;
  if (total == 0) return encoded;

  // Each change ends a run of the id before it and starts one of the id at it.
  // Both lists of flip positions stay ascending because changes come in order.
  IdIndex index;
  const auto flip_at = [&](uint32_t id, uint32_t position) {
    const uint32_t i = index.IndexOf(id);
    if (i == encoded.size()) encoded.push_back({id, Rle{height, width, {}}});
    encoded[i].rle.counts.push_back(position);
  };
  const uint32_t* const pixels = ids.data();
  const size_t last_row_start = size_t{height - 1} * width;
  for (const Pixel& pixel : FindIdChanges(pixels, height, width).InColumnMajorOrder()) {
    const size_t offset = size_t{pixel.y} * width + pixel.x;
    const uint32_t position = pixel.x * height + pixel.y;
    if (position != 0) {
      const size_t previous = pixel.y > 0 ? offset - width : last_row_start + pixel.x - 1;
      flip_at(pixels[previous], position);
    }
    flip_at(pixels[offset], position);
  }
  for (IdRle& entry : encoded) FlipPositionsToRuns(entry.rle.counts, total);
  std::sort(encoded.begin(), encoded.end(), [](const IdRle& l, const IdRle& r) { return l.id < r.id; });
  return encoded;
}

std::vector<uint8_t> DecodeRowMajor(const Rle& rle) {
  const uint32_t height = rle.height;
  const uint32_t width = rle.width;
  const uint64_t total = uint64_t{height} * width;
  std::vector<uint8_t> mask(total, 0);
  if (total == 0) return mask;

  // Mark where the value flips, then recover values as a running XOR down each
  // column; since rows are contiguous, that XOR processes whole rows at a time.
  uint8_t* const pixels = mask.data();
  std::vector<uint8_t> column_flip_parity(width, 0);
  uint64_t position = 0;
  uint64_t column_start = 0;
  uint32_t x = 0;
  for (size_t i = 0; i + 1 < rle.counts.size(); ++i) {
    position += rle.counts[i];
    if (position >= total) break;  // runs breaking the precondition must not write out of bounds
    while (position >= column_start + height) {
      column_start += height;
      ++x;
    }
    const uint64_t y = position - column_start;
    pixels[y * width + x] ^= 1;
    column_flip_parity[x] ^= 1;
  }
  // The top pixel of a column continues from the bottom of the previous one.
  uint8_t carried = 0;
  for (uint32_t column = 0; column < width; ++column) {
    pixels[column] ^= carried;
    carried ^= column_flip_parity[column];
  }
  for (uint32_t y = 1; y < height; ++y) {
    const uint8_t* above = pixels + size_t{y - 1} * width;
    uint8_t* row = pixels + size_t{y} * width;
    uint32_t column = 0;
    for (; column + sizeof(Vector16) <= width; column += sizeof(Vector16)) {
      Vector16 a, b;
      std::memcpy(&a, above + column, sizeof a);
      std::memcpy(&b, row + column, sizeof b);
      b ^= a;
      std::memcpy(row + column, &b, sizeof b);
    }
    for (; column < width; ++column) row[column] ^= above[column];
  }
  return mask;
}

std::string ToString(const Rle& rle) {
  std::string text;
  text.reserve(rle.counts.size() * 2);
  for (size_t i = 0; i < rle.counts.size(); ++i) {
    int64_t value = rle.counts[i];
    // COCO codes a run relative to the previous run of the same value, but only
    // from index 3 on; index 2 is stored as is.
    if (i > 2) value -= rle.counts[i - 2];
    // Little-endian groups of 5 bits, 0x20 = more groups follow; the last group
    // ends when the remaining bits are pure sign extension of its bit 0x10.
    for (bool more = true; more;) {
      int group = static_cast<int>(value & 0x1f);
      value >>= 5;
      more = (group & 0x10) != 0 ? value != -1 : value != 0;
      if (more) group |= 0x20;
      text.push_back(static_cast<char>('0' + group));
    }
  }
  return text;
}

Result<Rle> FromString(std::string_view text, uint32_t height, uint32_t width) {
  const uint64_t total = uint64_t{height} * width;
  if (total > kMaxPixels) {
    return LimitExceededError(fmt::format("RLE of {}x{} pixels exceeds the COCO limit of {} pixels", height,
                                          width, kMaxPixels));
  }
  if (text.empty()) return CorruptError("empty RLE counts string: a mask has at least one run");

  // 12 groups of 5 bits fill 60 bits; a 13th would not fit in 64.
  constexpr unsigned kMaxGroupShift = 55;
  Rle rle{height, width, {}};
  rle.counts.reserve(text.size());
  uint64_t sum = 0;
  size_t offset = 0;
  while (offset < text.size()) {
    const size_t number_offset = offset;
    uint64_t bits = 0;
    for (unsigned shift = 0;; shift += 5) {
      if (offset == text.size()) {
        return ParseError(
            fmt::format("RLE counts string ends inside the number starting at offset {}", number_offset));
      }
      const auto character = static_cast<unsigned char>(text[offset]);
      if (character < '0' || character > 'o') {
        return ParseError(fmt::format("invalid character 0x{:02x} in RLE counts at offset {}, expected '0'..'o'",
                                      character, offset));
      }
      if (shift > kMaxGroupShift) {
        return ParseError(
            fmt::format("number at offset {} in RLE counts overflows 64 bits", number_offset));
      }
      const unsigned group = character - '0';
      bits |= uint64_t{group & 0x1fu} << shift;
      ++offset;
      if ((group & 0x20u) != 0) continue;
      if ((group & 0x10u) != 0) bits |= ~uint64_t{0} << (shift + 5);
      break;
    }
    // |value| < 2^59 and runs < 2^32, so the delta addition cannot overflow.
    int64_t value = static_cast<int64_t>(bits);
    const size_t run_index = rle.counts.size();
    if (run_index > 2) value += rle.counts[run_index - 2];
    if (value < 0) {
      return CorruptError(fmt::format("run {} at offset {} of RLE counts is negative ({}) after delta decoding",
                                      run_index, number_offset, value));
    }
    if (value == 0 && run_index > 0) {
      return CorruptError(fmt::format(
          "run {} at offset {} of RLE counts is empty; COCO runs after the first are never empty", run_index,
          number_offset));
    }
    if (value > int64_t{UINT32_MAX}) {
      return CorruptError(
          fmt::format("run {} at offset {} of RLE counts exceeds 32 bits ({})", run_index, number_offset, value));
    }
    sum += static_cast<uint64_t>(value);
    if (sum > total) {
      return CorruptError(fmt::format("runs up to offset {} of RLE counts sum to {}, more than {}x{} = {} pixels",
                                      offset, sum, height, width, total));
    }
    rle.counts.push_back(static_cast<uint32_t>(value));
  }
  if (sum != total) {
    return CorruptError(fmt::format("runs of RLE counts sum to {} at offset {} (end), fewer than {}x{} = {} pixels",
                                    sum, offset, height, width, total));
  }
  return rle;
}

Status Validate(const Rle& rle) {
  const uint64_t total = uint64_t{rle.height} * rle.width;
  if (total > kMaxPixels) {
    return LimitExceededError(fmt::format("RLE of {}x{} pixels exceeds the COCO limit of {} pixels", rle.height,
                                          rle.width, kMaxPixels));
  }
  if (rle.counts.empty()) return CorruptError("RLE has no runs: a mask has at least one run");
  uint64_t sum = 0;
  for (size_t i = 0; i < rle.counts.size(); ++i) {
    if (rle.counts[i] == 0 && i > 0) {
      return CorruptError(fmt::format("RLE run {} is empty; COCO runs after the first are never empty", i));
    }
    sum += rle.counts[i];
    if (sum > total) {
      return CorruptError(fmt::format("RLE runs up to run {} sum to {}, more than {}x{} = {} pixels", i, sum,
                                      rle.height, rle.width, total));
    }
  }
  if (sum != total) {
    return CorruptError(
        fmt::format("RLE runs sum to {}, fewer than {}x{} = {} pixels", sum, rle.height, rle.width, total));
  }
  return Status::Ok();
}

uint64_t Area(const Rle& rle) {
  uint64_t area = 0;
  for (size_t i = 1; i < rle.counts.size(); i += 2) area += rle.counts[i];
  return area;
}

Box ToBbox(const Rle& rle) {
  // Follows maskApi.c, which computes in 32-bit unsigned arithmetic: exact
  // because of the pixel-count limit. Pairs (unset run, set run) locate the
  // first and the last pixel of each set run.
  const uint32_t height = rle.height;
  const uint32_t width = rle.width;
  const size_t paired_runs = rle.counts.size() / 2 * 2;
  if (paired_runs == 0 || height == 0) return {};  // maskApi.c would divide by a zero height
  uint32_t x_min = width, y_min = height, x_max = 0, y_max = 0, run_start_x = 0, end = 0;
  for (size_t j = 0; j < paired_runs; ++j) {
    end += rle.counts[j];
    const uint32_t position = end - static_cast<uint32_t>(j % 2);  // first set pixel / last set pixel
    const uint32_t x = position / height;
    const uint32_t y = position % height;
    if (j % 2 == 0) {
      run_start_x = x;
    } else if (run_start_x < x) {
      // A set run that wraps into the next column covers the whole column height.
      y_min = 0;
      y_max = height - 1;
    }
    x_min = std::min(x_min, x);
    x_max = std::max(x_max, x);
    y_min = std::min(y_min, y);
    y_max = std::max(y_max, y);
  }
  return {x_min, y_min, uint32_t{x_max - x_min + 1}, uint32_t{y_max - y_min + 1}};
}

Rle Merge(const Rle& a, const Rle& b, bool intersect) {
  Rle merged{a.height, a.width, {}};
  merged.counts.reserve(a.counts.size() + b.counts.size());
  // A run ends where the merged value changes; the initial zero-pixel step of a
  // mask that starts set yields the empty first run COCO expects.
  bool run_set = false;
  uint32_t run_length = 0;
  WalkTogether(a, b, [&](uint32_t pixels, bool a_set, bool b_set) {
    const bool set = intersect ? (a_set && b_set) : (a_set || b_set);
    if (set != run_set) {
      merged.counts.push_back(run_length);
      run_length = 0;
      run_set = set;
    }
    run_length += pixels;
    return true;
  });
  merged.counts.push_back(run_length);
  return merged;
}

double Iou(const Rle& a, const Rle& b) {
  uint64_t intersection = 0;
  uint64_t union_area = 0;
  WalkTogether(a, b, [&](uint32_t pixels, bool a_set, bool b_set) {
    if (a_set || b_set) union_area += pixels;
    if (a_set && b_set) intersection += pixels;
    return true;
  });
  if (intersection == 0) return 0.0;
  return static_cast<double>(intersection) / static_cast<double>(union_area);
}

Rle FromBox(const Box& box, uint32_t height, uint32_t width) {
  const uint32_t total = CheckedPixelCount(height, width);
  // maskApi.c samples the box outline at 1/5 pixel and keeps the vertical
  // crossings of pixel centres; for integer corners that selects exactly the
  // pixels inside the half-open box, clipped to the image.
  const auto [x_begin, x_end] = ClampedInterval(box.x, box.w, width);
  const auto [y_begin, y_end] = ClampedInterval(box.y, box.h, height);
  Rle rle{height, width, {}};
  RunBuilder runs(rle.counts);
  if (x_begin == x_end || y_begin == y_end) {
    runs.Append(false, total);
    return rle;
  }
  const uint32_t box_height = y_end - y_begin;
  runs.Append(false, x_begin * height + y_begin);
  for (uint32_t x = x_begin; x < x_end; ++x) {
    if (x != x_begin) runs.Append(false, height - box_height);
    runs.Append(true, box_height);
  }
  runs.Append(false, total - ((x_end - 1) * height + y_end));
  return rle;
}

bool Contains(const Rle& outer, const Rle& inner) {
  bool contained = true;
  WalkTogether(outer, inner, [&](uint32_t pixels, bool outer_set, bool inner_set) {
    contained = !(pixels > 0 && inner_set && !outer_set);
    return contained;
  });
  return contained;
}

}  // namespace solid::rle
