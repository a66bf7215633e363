// The shader's pixel lanes in SIMD registers (internal to solid::render): a tile's 16
// pixels are kept in columns, one array of 16 floats per quantity, and the loops over them
// run a native vector at a time: 4 floats with SSE2 (the x86-64 baseline), 8 with AVX2 and
// 16 with AVX-512, in the kernel set built for each (film_kernels.h). Only exactly
// rounded operations are used (+, -, *, /, sqrt, comparisons, selects), and the build
// forbids contracting them into FMAs, so every vector width gives the bits that scalar
// code with the same operations in the same order gives.
#pragma once

#include <bit>
#include <cstdint>
#include <experimental/simd>
#include <numbers>

#include "shading.h"

// Built into each kernel set's namespace (film_kernels.h), whose lanes differ in width;
// elsewhere (tests) into `native`.
#ifndef SOLID_FILM_ISA
#define SOLID_FILM_ISA native
#endif

namespace solid::render {

// Pixels are traced in kTile x kTile tiles, one 16-ray packet per tile and sample for
// the camera rays, then one per light for the shadow rays and one for the ambient
// rays: a tile's rays are coherent enough that packets beat single rays by far.
inline constexpr int kTile = 4;
inline constexpr int kLanes = kTile * kTile;

namespace SOLID_FILM_ISA {

namespace stdx = std::experimental;

using Floats = stdx::native_simd<float>;
using FloatMask = Floats::mask_type;
using Ints = stdx::rebind_simd_t<int32_t, Floats>;
inline constexpr int kWidth = static_cast<int>(Floats::size());
static_assert(kLanes % kWidth == 0);

// A column: one value per lane. Loads and stores at lane c, a multiple of kWidth.
using Column = float[kLanes];
using Column3 = float[3][kLanes];

struct Floats3 {
  Floats x, y, z;
  friend Floats3 operator+(const Floats3& a, const Floats3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
  friend Floats3 operator-(const Floats3& a, const Floats3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
  friend Floats3 operator*(const Floats3& a, const Floats3& b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
  friend Floats3 operator*(const Floats3& a, const Floats& s) { return {a.x * s, a.y * s, a.z * s}; }
  // Takes v in the lanes of m.
  void Where(const FloatMask& m, const Floats3& v) {
    where(m, x) = v.x;
    where(m, y) = v.y;
    where(m, z) = v.z;
  }
};

inline Floats Load(const float* column, int c) { return Floats(column + c, stdx::vector_aligned); }
inline void Store(const Floats& v, float* column, int c) { v.copy_to(column + c, stdx::vector_aligned); }
inline Floats3 Load3(const Column3& column, int c) {
  return {Load(column[0], c), Load(column[1], c), Load(column[2], c)};
}
inline void Store3(const Floats3& v, Column3& column, int c) {
  Store(v.x, column[0], c);
  Store(v.y, column[1], c);
  Store(v.z, column[2], c);
}
inline void Store3(const Floats3& v, float* x, float* y, float* z, int c) {
  Store(v.x, x, c);
  Store(v.y, y, c);
  Store(v.z, z, c);
}
inline void SetLane(Column3& column, int i, Vec3f v) {
  column[0][i] = v.x;
  column[1][i] = v.y;
  column[2][i] = v.z;
}
inline Floats3 Splat3(Vec3f v) { return {Floats(v.x), Floats(v.y), Floats(v.z)}; }
inline Floats Dot(const Floats3& a, const Floats3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// v at unit length; v itself where its length is 0 (or NaN).
inline Floats3 Normalized(const Floats3& v) {
  const Floats len2 = Dot(v, v);
  Floats3 unit = v * (1 / stdx::sqrt(len2));
  unit.Where(!(len2 > 0), v);
  return unit;
}

// 1 or -1 with the sign bit of x (copysign(1, x): -1 for -0). Not std::experimental's
// copysign, whose out-of-line copy would be shared with other files (film_kernels.h).
inline Floats SignOf(const Floats& x) {
  const Ints sign_bit = std::bit_cast<Ints>(x) & static_cast<int32_t>(0x80000000u);
  return std::bit_cast<Floats>(sign_bit | std::bit_cast<Ints>(Floats(1)));
}

// Embree's masks (-1: the lane takes part) and ids at lane c, as masks of Floats, read as
// float bits without a conversion: -1 (all ones) is a NaN, which compares unequal to
// everything, itself included; 0 is 0; an id below 2^31 - 2^23 is a number or 0.
inline FloatMask IsSet(const int* mask, int c) {
  return std::bit_cast<Floats>(Ints(mask + c, stdx::vector_aligned)) != 0;
}
inline FloatMask IsHit(const unsigned* geometry_ids, int c) {
  static_assert(static_cast<int32_t>(RTC_INVALID_GEOMETRY_ID) == -1);
  const Ints bits(reinterpret_cast<const int32_t*>(geometry_ids) + c, stdx::vector_aligned);
  const Floats ids = std::bit_cast<Floats>(bits);
  return ids == ids;
}
inline void StoreMask(const FloatMask& m, int* mask, int c) {
  const Ints bits([&](auto k) { return m[k] ? -1 : 0; });
  bits.copy_to(mask + c, stdx::vector_aligned);
}

// log2 of x > 0 (a normal float): x = m 2^k with m in [sqrt(1/2), sqrt(2)), and
// ln m = 2 atanh(t), t = (m - 1) / (m + 1), |t| < 0.172, whose series to t^11 is within
// 2e-9 of it.
inline Floats Log2(const Floats& x) {
  const Ints bits = std::bit_cast<Ints>(x);
  Floats m = std::bit_cast<Floats>((bits & 0x7fffff) | 0x3f800000);  // [1, 2)
  Floats k = stdx::static_simd_cast<Floats>((bits >> 23) - 127);
  const FloatMask high = m > 1.41421356f;
  where(high, m) = m * 0.5f;
  where(high, k) = k + 1;
  const Floats t = (m - 1) / (m + 1), t2 = t * t;
  const Floats series = 1 + t2 * (1 / 3.0f + t2 * (1 / 5.0f + t2 * (1 / 7.0f + t2 * (1 / 9.0f + t2 * (1 / 11.0f)))));
  return k + t * series * (2 / std::numbers::ln2_v<float>);
}

// 2^y for y in [-126, 127]: 2^k (k the nearest integer) times e^(f ln 2), f in
// [-1/2, 1/2], whose Taylor series to degree 7 is within 5e-9 of it.
inline Floats Exp2(const Floats& y) {
  const Floats z = y + 0.5f;
  Floats k = stdx::static_simd_cast<Floats>(stdx::static_simd_cast<Ints>(z));  // towards 0
  where(k > z, k) = k - 1;
  const Floats g = (y - k) * std::numbers::ln2_v<float>;
  const Floats tail = 1 / 120.0f + g * (1 / 720.0f + g * (1 / 5040.0f));
  const Floats series = 1 + g * (1 + g * (1 / 2.0f + g * (1 / 6.0f + g * (1 / 24.0f + g * tail))));
  return series * std::bit_cast<Floats>((stdx::static_simd_cast<Ints>(k) + 127) << 23);
}

// x^e for x >= 0 and e >= 1 (a specular lobe's cosine and exponent): relative error under
// 4e-6 where x^e >= 1e-6 (Log2's few ulps times |e log2 x|), and 0 where x^e < 2^-126 (std::pow
// gives a subnormal or 0 there). In place of std::pow, a call per lane and light that took
// a tenth of the light loop.
inline Floats Pow(const Floats& x, const Floats& e) {
  Floats y = e * Log2(x);
  const FloatMask vanishes = !(y >= -126);  // x = 0, subnormal, NaN, or a narrow lobe far off its peak
  where(vanishes, y) = 0;
  where(y > 127, y) = 127;
  Floats r = Exp2(y);
  where(vanishes, r) = 0;
  return r;
}

// cos 2 pi a and sin 2 pi a, for a in [0, 1), within 1e-7: a quarter-turn reduction (exact,
// as 4a and its nearest integer are) to r in [-pi/4, pi/4], whose Taylor series to degree 9
// are within 3e-8 of sin and cos.
inline void CosSinTurn(const Floats& a, Floats* cos, Floats* sin) {
  const Floats quarters = 4 * a;
  const Floats q = stdx::static_simd_cast<Floats>(stdx::static_simd_cast<Ints>(quarters + 0.5f));  // 0..4
  const Floats r = (quarters - q) * (std::numbers::pi_v<float> / 2), r2 = r * r;
  const Floats s = r * (1 + r2 * (-1 / 6.0f + r2 * (1 / 120.0f + r2 * (-1 / 5040.0f + r2 * (1 / 362880.0f)))));
  const Floats c = 1 + r2 * (-1 / 2.0f + r2 * (1 / 24.0f + r2 * (-1 / 720.0f + r2 * (1 / 40320.0f))));
  // Quarter q turns (c, s) by q right angles: (c, s), (-s, c), (-c, -s), (s, -c).
  const FloatMask odd = q == 1 || q == 3;
  *cos = c;
  *sin = s;
  where(odd, *cos) = s;
  where(odd, *sin) = c;
  where(q == 1 || q == 2, *cos) = -*cos;
  where(q == 2 || q == 3, *sin) = -*sin;
}

}  // namespace SOLID_FILM_ISA

}  // namespace solid::render
