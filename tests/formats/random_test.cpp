#include "solid/formats/random.h"

#include <cstdint>

#include <gtest/gtest.h>

namespace solid {
namespace {

// Lemire's unbiased index from two 32-bit draws, spelled out: Index(n) and the
// IndexRange that placement draws its millions of lattice indices from must both give
// these values from the same draws, or the layouts of a seed would change.
uint64_t ReferenceIndex(Rng& rng, uint64_t n) {
  const uint64_t threshold = (uint64_t{0} - n) % n;
  for (;;) {
    const uint64_t high = rng.Next();
    const uint64_t r = (high << 32) | rng.Next();
    if (r >= threshold) return r % n;
  }
}

TEST(Rng, IndexAndIndexRangeDrawTheReferenceValues) {
  for (const uint64_t n : {uint64_t{1}, uint64_t{2}, uint64_t{3}, uint64_t{144}, uint64_t{1} << 20,
                           (uint64_t{1} << 32) + 1, (uint64_t{1} << 63) + 1, ~uint64_t{0}}) {
    Rng reference(7, 3), by_size(7, 3), by_range(7, 3);
    const IndexRange range(n);
    for (int i = 0; i < 10000; ++i) {
      const uint64_t expected = ReferenceIndex(reference, n);
      ASSERT_EQ(by_size.Index(n), expected) << "n " << n << " draw " << i;
      ASSERT_EQ(by_range.Index(range), expected) << "n " << n << " draw " << i;
    }
    const uint32_t next = reference.Next();
    EXPECT_EQ(by_size.Next(), next) << "n " << n << ": the same draws consumed";
    EXPECT_EQ(by_range.Next(), next) << "n " << n << ": the same draws consumed";
  }
}

// A range beyond 32 bits is drawn from 64: half of the indices of a range just above 2^63
// land in its upper half (a 32-bit draw would put none there).
TEST(Rng, IndexOfAHugeRangeReachesItsUpperHalf) {
  const uint64_t n = (uint64_t{1} << 63) + 1;
  Rng rng(1, 1);
  int upper_half = 0;
  constexpr int kDraws = 20000;
  for (int i = 0; i < kDraws; ++i) upper_half += rng.Index(IndexRange(n)) >= n / 2;
  // Binomial(20000, 0.5): 6 standard deviations are 424.
  EXPECT_NEAR(upper_half, kDraws / 2, 424);
}

}  // namespace
}  // namespace solid
