// Deterministic randomness (style H5). <random>'s distributions differ between standard
// libraries, so every draw goes through this PCG32 and an explicit integer-to-double
// conversion: the same (seed, stream) gives the same numbers on every machine.
#pragma once

#include <cstdint>

namespace solid {

inline uint64_t SplitMix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// A seed derived from two others, e.g. (dataset seed, image index).
inline uint64_t MixSeed(uint64_t a, uint64_t b) { return SplitMix64(a ^ SplitMix64(b)); }

// [0, n) for Rng::Index drawn many times (a placement try's thousands of proposals):
// the rejection threshold costs a 64-bit division, computed here once.
struct IndexRange {
  explicit IndexRange(uint64_t size) : n(size), threshold((uint64_t{0} - size) % size) {}
  uint64_t n, threshold;
};

// PCG32 (O'Neill), one independent sequence per stream.
class Rng {
 public:
  Rng(uint64_t seed, uint64_t stream) : increment_((stream << 1) | 1) {
    Next();
    state_ += seed;
    Next();
  }

  uint32_t Next() {
    const uint64_t old = state_;
    state_ = old * 6364136223846793005ull + increment_;
    const auto xorshifted = static_cast<uint32_t>(((old >> 18) ^ old) >> 27);
    const auto rotation = static_cast<uint32_t>(old >> 59);
    return (xorshifted >> rotation) | (xorshifted << ((32 - rotation) & 31));
  }
  double Uniform() { return Next() * 0x1p-32; }  // [0, 1), exact in any IEEE double
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // The modulo bias is below 2^-24 for ranges under 2^8; Index is exact for any size.
  int Int(int lo, int hi_inclusive) {
    return lo + static_cast<int>(Next() % static_cast<uint32_t>(hi_inclusive - lo + 1));
  }
  // Uniform in [0, n) without modulo bias (Lemire's method), for large sets.
  uint64_t Index(uint64_t n) { return Index(IndexRange(n)); }
  uint64_t Index(const IndexRange& range) {
    for (;;) {
      const uint64_t r = (uint64_t{Next()} << 32) | Next();
      if (r >= range.threshold) return r % range.n;
    }
  }
  bool Chance(double p) { return Uniform() < p; }
  // A seed for a sub-generator that does not depend on later draws.
  uint64_t Seed() {
    const uint64_t high = Next();
    return (high << 32) | Next();
  }

 private:
  uint64_t state_ = 0;
  uint64_t increment_;
};

}  // namespace solid
