// The shader's vector math (render/lanes.h) against the standard library's.
#include "lanes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace solid::render {
namespace {

using namespace SOLID_FILM_ISA;

float First(const Floats& v) { return static_cast<float>(v[0]); }

// A specular lobe's power: relative error under 4e-6 wherever the power reaches 1e-6 (below,
// it adds nothing an 8-bit pixel shows), and 0 where std::pow underflows.
TEST(Lanes, PowFollowsStdPowOverSpecularLobes) {
  for (const float e : {1.0f, 1.5f, 2.0f, 7.3f, 30.0f, 98.0f, 250.0f, 511.0f, 1024.0f}) {
    for (int i = 0; i <= 20000; ++i) {
      const float x = 1.0f - static_cast<float>(i) * 5e-5f;
      const double want = std::pow(static_cast<double>(x), static_cast<double>(e));
      const float got = First(Pow(Floats(x), Floats(e)));
      if (want >= 1e-6) {
        ASSERT_NEAR(got, want, 4e-6 * want) << x << "^" << e;
      } else {
        ASSERT_LE(got, 2e-6) << x << "^" << e;
      }
    }
  }
  EXPECT_EQ(First(Pow(Floats(0), Floats(1))), 0.0f);
  EXPECT_EQ(First(Pow(Floats(1), Floats(1024))), 1.0f);
  EXPECT_EQ(First(Pow(Floats(0.5f), Floats(1024))), 0.0f);
}

TEST(Lanes, CosSinTurnIsWithin1e7OfCosAndSin) {
  for (int i = 0; i < 100000; ++i) {
    const float a = static_cast<float>(i) / 100000;
    Floats c, s;
    CosSinTurn(Floats(a), &c, &s);
    const double angle = 2 * std::numbers::pi * a;
    ASSERT_NEAR(First(c), std::cos(angle), 1e-7) << a;
    ASSERT_NEAR(First(s), std::sin(angle), 1e-7) << a;
  }
}

// Every lane is computed alike, whichever lane of which vector it is in.
TEST(Lanes, EveryLaneAlike) {
  alignas(64) float x[kLanes], e[kLanes], a[kLanes];
  for (int i = 0; i < kLanes; ++i) {
    x[i] = 0.5f + 0.03f * static_cast<float>(i);
    e[i] = 1.0f + 60.0f * static_cast<float>(i);
    a[i] = static_cast<float>(i) / kLanes;
  }
  for (int c = 0; c < kLanes; c += kWidth) {
    const Floats p = Pow(Load(x, c), Load(e, c));
    Floats cos, sin;
    CosSinTurn(Load(a, c), &cos, &sin);
    for (int k = 0; k < kWidth; ++k) {
      EXPECT_EQ(static_cast<float>(p[k]), First(Pow(Floats(x[c + k]), Floats(e[c + k])))) << c + k;
      Floats cos1, sin1;
      CosSinTurn(Floats(a[c + k]), &cos1, &sin1);
      EXPECT_EQ(static_cast<float>(cos[k]), First(cos1)) << c + k;
      EXPECT_EQ(static_cast<float>(sin[k]), First(sin1)) << c + k;
    }
  }
}

// copysign(1, x), the sign of the orthonormal basis around a normal: -1 for -0 too.
TEST(Lanes, SignOfIsCopysignOfOne) {
  for (const float x : {0.0f, -0.0f, 1e-30f, -1e-30f, 0.5f, -0.5f, 3e38f, -3e38f}) {
    EXPECT_EQ(First(SignOf(Floats(x))), std::copysign(1.0f, x)) << x;
  }
}

}  // namespace
}  // namespace solid::render
