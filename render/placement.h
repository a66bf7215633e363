// The candidates of object placement, internal to the stage (layout.cpp's placer).
//
// A pose try is max_proposals draws of a lattice point, uniform over the lattice or over
// the union of the cluster cubes, the first that passes every test giving the centre
// (solid-method.md 2.4). Most draws fail tests that depend on the camera alone (a covered
// column, between floor and ceiling, inside the inset frustum, far enough from the
// camera): 98% of those the cluster cubes keep, at the more-objects row's fitted point. So
// the placer lists, once per layout, a superset of the points that pass those tests (the
// candidates), draws how many of a try's draws miss the list (a geometric count), and tests
// only those that hit it, each a uniform candidate. Every lattice point keeps its
// probability per draw, one over the drawn set's size, so a layout has the law of plain
// rejection sampling, there at a fifth of its cost (docs/benchmarks.md); the draws
// themselves are others.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "room.h"
#include "solid/formats/random.h"
#include "solid/render/params.h"

namespace solid::render {

struct LatticePoint {
  uint16_t i, j, k;
};

// A covered column where a floor-supported centre can pass the camera's tests, for the
// box half-heights in [lo, hi] (the centre stands that much above the floor).
struct FloorColumn {
  uint16_t i, j;
  double lo, hi;
};

struct PlacementCandidates {
  std::vector<LatticePoint> points;         // floating support: levels 0..room.TopLevel()
  std::vector<FloorColumn> floor_columns;   // floor support
};

// Objects resting on the floor float this far above it: the shell test counts touching
// as intersecting.
constexpr double kFloorGap = 1e-3;

// A superset, by a margin above rounding, of the lattice points (or the floor columns)
// whose centre is over a covered column, between its floor and ceiling, more than
// min_hdist_m from the camera horizontally, in front of it by more than near_m, and
// projects within frustum_inset of the image centre.
PlacementCandidates ListCandidates(const LayoutParams& params, const RoomShell& room, const Camera& camera);

// The draws of one pose try over `drawn_from` lattice points, of which only the
// `candidates` can pass: the draws before each hit of the list are geometric in number,
// the candidate hit is uniform, and `accept(index)` tests it. True on the first accepted
// candidate, with *spent the draws it took; false after `budget` draws (*spent = budget).
// Requires 0 < candidates <= drawn_from.
template <class Accept>
bool DrawCandidates(uint64_t candidates, uint64_t drawn_from, int64_t budget, Rng& rng, Accept&& accept,
                    int64_t* spent) {
  const double hit = static_cast<double>(candidates) / static_cast<double>(drawn_from);
  const double log_miss = std::log1p(-hit);
  const IndexRange pick(candidates);
  *spent = 0;
  while (*spent < budget) {
    double misses = 0;
    if (hit < 1) misses = std::floor(std::log(1.0 - rng.Uniform()) / log_miss);
    if (misses >= static_cast<double>(budget - *spent)) break;
    *spent += static_cast<int64_t>(misses) + 1;
    if (accept(rng.Index(pick))) return true;
  }
  *spent = budget;
  return false;
}

}  // namespace solid::render
