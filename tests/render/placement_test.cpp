// The placer's candidates and draws (render/placement.h): the candidates hold every lattice
// point the camera's tests pass, and the draws have plain rejection sampling's law.
#include "placement.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <tuple>

#include "render/test_assets.h"
#include "room.h"
#include "solid/render/layout.h"

namespace solid::render {
namespace {

// The camera's tests of a proposal centre c over column (i, j), as the placer applies them.
bool PassesCameraTests(const LayoutParams& p, const Camera& camera, const RoomShell& room, int i, int j, Vec3 c,
                       bool floor) {
  if (!room.Covered(i, j)) return false;
  if (!floor && (c.z < room.FloorZ(i, j) || c.z > room.CeilingZ(i, j))) return false;
  double u = 0, v = 0;
  if (!Project(camera, c, p.camera_near_m, &u, &v)) return false;
  if (std::fabs(u - camera.cx) > p.frustum_inset * camera.cx || std::fabs(v - camera.cy) > p.frustum_inset * camera.cy) {
    return false;
  }
  const Vec3 eye = CameraPosition(camera);
  return std::hypot(c.x - eye.x, c.y - eye.y) > p.min_hdist_m;
}

// Layouts of `params` on the procedural rooms: each a room and a camera to list candidates for.
std::vector<Layout> Cameras(const LayoutParams& params, int count) {
  const auto sampler = LayoutSampler::Create(params, testing::ProceduralLibrary()).value();
  std::vector<Layout> out;
  for (int index = 0; static_cast<int>(out.size()) < count; ++index) {
    Layout l = sampler->Sample(3, index, 0).value();
    if (l.rejection.empty()) out.push_back(std::move(l));
  }
  return out;
}

LayoutParams Coarse(Support support) {
  LayoutParams p;
  p.support = support;
  p.grid_points_per_axis = 72;  // every lattice point is tested below
  return p;
}

TEST(Placement, FloatingCandidatesHoldEveryPointTheCameraPasses) {
  const LayoutParams p = Coarse(Support::kFloating);
  for (const Layout& l : Cameras(p, 6)) {
    const RoomShell& room = *l.room;
    const PlacementCandidates candidates = ListCandidates(p, room, l.camera);
    std::set<std::tuple<int, int, int>> listed;
    for (const LatticePoint& c : candidates.points) listed.insert({c.i, c.j, c.k});
    EXPECT_EQ(listed.size(), candidates.points.size()) << "a point listed twice";
    int64_t passing = 0;
    for (int k = 0; k <= room.TopLevel(); ++k) {
      for (int j = 0; j < room.points(); ++j) {
        for (int i = 0; i < room.points(); ++i) {
          if (!PassesCameraTests(p, l.camera, room, i, j, {room.X(i), room.Y(j), room.Z(k)}, false)) continue;
          ++passing;
          EXPECT_TRUE(listed.count({i, j, k})) << "layout " << l.index << " point " << i << " " << j << " " << k;
        }
      }
    }
    EXPECT_GT(passing, 0);
    // A superset by rounding only: the list is what the sampler draws from, so its excess is
    // draws wasted (a frustum boundary cell here and there).
    EXPECT_LE(static_cast<double>(candidates.points.size()), 1.02 * static_cast<double>(passing) + 16)
        << "layout " << l.index;
  }
}

TEST(Placement, FloorColumnsHoldEveryColumnTheCameraPassesForEachHalfHeight) {
  const LayoutParams p = Coarse(Support::kFloor);
  for (const Layout& l : Cameras(p, 6)) {
    const RoomShell& room = *l.room;
    const PlacementCandidates candidates = ListCandidates(p, room, l.camera);
    for (const double zhalf : {0.02, 0.3, 0.9, 1.7}) {
      std::set<std::pair<int, int>> listed;
      for (const FloorColumn& c : candidates.floor_columns) {
        if (c.lo <= zhalf && zhalf <= c.hi) listed.insert({c.i, c.j});
      }
      int64_t passing = 0;
      for (int j = 0; j < room.points(); ++j) {
        for (int i = 0; i < room.points(); ++i) {
          if (!room.Covered(i, j)) continue;
          const Vec3 c{room.X(i), room.Y(j), room.FloorZ(i, j) + zhalf + kFloorGap};
          if (!PassesCameraTests(p, l.camera, room, i, j, c, true)) continue;
          ++passing;
          EXPECT_TRUE(listed.count({i, j})) << "layout " << l.index << " column " << i << " " << j << " half-height "
                                            << zhalf;
        }
      }
      EXPECT_LE(static_cast<double>(listed.size()), 1.02 * static_cast<double>(passing) + 8)
          << "layout " << l.index << " half-height " << zhalf;
    }
  }
}

// 200,000 tries of `budget` draws from `drawn_from` points, of which the first `accepted` of
// the `candidates` pass: the share of tries that place, which candidate, and after how many
// draws, against the law of drawing them one by one.
struct Law {
  double placed = 0;
  std::vector<double> share_of_each;  // of the placed tries, per accepted candidate
  double mean_draws_when_placed = 0;
};

Law DrawMany(uint64_t candidates, uint64_t drawn_from, int64_t budget, uint64_t accepted, int tries) {
  Law law;
  law.share_of_each.assign(accepted, 0);
  Rng rng(17, 5);
  int64_t placed = 0, draws = 0;
  for (int t = 0; t < tries; ++t) {
    int64_t spent = 0;
    uint64_t chosen = 0;
    if (DrawCandidates(candidates, drawn_from, budget, rng,
                       [&](uint64_t index) {
                         chosen = index;
                         return index < accepted;
                       },
                       &spent)) {
      ++placed;
      draws += spent;
      law.share_of_each[chosen] += 1;
    } else {
      EXPECT_EQ(spent, budget);
    }
  }
  law.placed = static_cast<double>(placed) / tries;
  for (double& s : law.share_of_each) s /= static_cast<double>(placed);
  law.mean_draws_when_placed = static_cast<double>(draws) / static_cast<double>(placed);
  return law;
}

TEST(Placement, DrawsHaveTheLawOfDrawingEveryPoint) {
  // One draw in 500 hits the 40 candidates, one in 2,000 one of the 10 that pass; 4,000
  // draws a try: P(placed) = 1 - (1 - 1/2000)^4000 = 0.865.
  constexpr uint64_t kCandidates = 40, kDrawnFrom = 20000, kAccepted = 10;
  constexpr int64_t kBudget = 4000;
  constexpr int kTries = 200000;
  const Law law = DrawMany(kCandidates, kDrawnFrom, kBudget, kAccepted, kTries);
  const double q = static_cast<double>(kAccepted) / kDrawnFrom;
  const double placed = 1 - std::pow(1 - q, kBudget);
  // Binomial standard error of the share: 4 of them (a one-in-15,000 miss by chance).
  EXPECT_NEAR(law.placed, placed, 4 * std::sqrt(placed * (1 - placed) / kTries));
  // Each accepted candidate equally likely: chi-square over 10 cells, 9 degrees of freedom,
  // below 33.7 (p = 1e-4).
  double chi2 = 0;
  const double n = law.placed * kTries, expected = n / kAccepted;
  for (double s : law.share_of_each) chi2 += (s * n - expected) * (s * n - expected) / expected;
  EXPECT_LT(chi2, 33.7);
  // The draws of a placed try: a geometric count truncated at the budget, with mean
  // (1/q - B (1-q)^B / (1 - (1-q)^B)); its standard deviation is below 1/q, so 4 standard
  // errors of the mean are under 4 / (q sqrt(n)).
  const double miss_all = std::pow(1 - q, kBudget);
  const double mean = 1 / q - kBudget * miss_all / (1 - miss_all);
  EXPECT_NEAR(law.mean_draws_when_placed, mean, 4 / (q * std::sqrt(n)));
}

TEST(Placement, EveryDrawACandidateWhenTheyAreTheWholeSet) {
  // hit = 1: no draw is skipped, so a try that accepts its third candidate spent 3 draws.
  Rng rng(1, 2);
  int calls = 0;
  int64_t spent = 0;
  EXPECT_TRUE(DrawCandidates(8, 8, 100, rng, [&](uint64_t) { return ++calls == 3; }, &spent));
  EXPECT_EQ(spent, 3);
  calls = 0;
  EXPECT_FALSE(DrawCandidates(8, 8, 5, rng, [&](uint64_t) { return ++calls > 100; }, &spent));
  EXPECT_EQ(calls, 5);
  EXPECT_EQ(spent, 5);
}

}  // namespace
}  // namespace solid::render
