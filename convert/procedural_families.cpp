#include "procedural_families.h"

#include <cmath>

namespace solid::convert {
namespace {

using namespace kit;
using P2 = std::array<double, 2>;

// Draws happen in statement order (one per statement or braced list), never inside a
// function's argument list, whose evaluation order C++ leaves open.
struct Draw {
  Rng& rng;
  double U(double lo, double hi) { return rng.Uniform(lo, hi); }
  int I(int lo, int hi) { return rng.Int(lo, hi); }
  bool C(double p) { return rng.Chance(p); }
  template <typename T>
  T Pick(std::initializer_list<T> options) {
    const int k = rng.Int(0, static_cast<int>(options.size()) - 1);
    return *(options.begin() + k);
  }
};

// A square-section bar from a to b (legs, rails, slats), `half` its half width and depth.
Part Bar(Vec3 a, Vec3 b, double half_x, double half_z, int material) {
  const Vec3 d = b - a;
  return BoxPart((a + b) * 0.5, {half_x, Length(d) / 2, half_z}, material, YTo(d));
}

// A leg as a round or square bar, tapered or not.
Part Leg(Vec3 bottom, Vec3 top, double radius, bool round, double taper, int material) {
  if (round) return CylinderPart(bottom, top, radius * taper, radius, material);
  return Bar(bottom, top, radius, radius, material);
}

// Rotates part positions about a pivot (a tilted chair back, an open laptop lid).
void Pivot(std::vector<Part>& parts, size_t from, Vec3 pivot, const Rotation& r) {
  for (size_t k = from; k < parts.size(); ++k) {
    Part& p = parts[k];
    if (p.kind == PartKind::kCylinder) {
      p.a = r.Apply(p.a - pivot) + pivot;
      p.b = r.Apply(p.b - pivot) + pivot;
    } else if (p.kind == PartKind::kTube) {
      for (Vec3& q : p.path) q = r.Apply(q - pivot) + pivot;
    } else {
      p.offset = r.Apply(p.offset - pivot) + pivot;
      p.rotation = r * p.rotation;
    }
  }
}

// A hollow shell of revolution: outer radii r(y) at heights ys (bottom first), a wall of
// `wall` and a bottom of `bottom` thick; open at the top.
std::vector<P2> HollowProfile(const std::vector<P2>& outer, double wall, double bottom) {
  std::vector<P2> profile = {{0, outer.front()[1]}};
  for (const P2& p : outer) profile.push_back(p);
  // Inside, back down from the rim (a flat rim of the wall's width) to the bottom's top.
  const double floor = outer.front()[1] + bottom;
  for (size_t k = outer.size(); k-- > 1;) {
    if (outer[k][1] > floor + 1e-4) profile.push_back({std::max(outer[k][0] - wall, 0.3 * outer[k][0]), outer[k][1]});
  }
  profile.push_back({std::max(outer.front()[0] - wall, 0.3 * outer.front()[0]), floor});
  profile.push_back({0, floor});
  return profile;
}

// ----------------------------------------------------------------------------------------

ModelSpec Chair(Draw d) {
  ModelSpec m;
  m.materials = {{"frame", d.Pick({Surfacing::kWood, Surfacing::kMetal, Surfacing::kPlastic})},
                 {"seat", d.Pick({Surfacing::kFabric, Surfacing::kWood, Surfacing::kLeather, Surfacing::kPlastic})}};
  const double w = d.U(0.42, 0.62), depth = d.U(0.42, 0.56), h = d.U(0.40, 0.50), t = d.U(0.025, 0.08);
  const bool padded = d.C(0.5);
  auto& parts = m.parts;
  parts.push_back(padded ? RoundedBoxPart({0, h, 0}, {w / 2, t / 2 + 0.01, depth / 2}, d.U(0.15, 0.35), 1)
                         : BoxPart({0, h, 0}, {w / 2, t / 2, depth / 2}, 1));
  const double under = h - t / 2 + 0.005;
  const int base = d.I(0, 5);  // 0-3: four legs, 4: pedestal, 5: sled frame
  const double leg_r = d.U(0.012, 0.03);
  if (base <= 3) {
    const bool round = d.C(0.5);
    const double taper = d.C(0.5) ? d.U(0.5, 0.9) : 1.0, splay = d.C(0.4) ? d.U(0.02, 0.07) : 0.0;
    const double inset = d.U(0.02, 0.06);
    for (int k = 0; k < 4; ++k) {
      const double sx = k & 1 ? 1 : -1, sz = k & 2 ? 1 : -1;
      const Vec3 top{sx * (w / 2 - inset), under, sz * (depth / 2 - inset)};
      parts.push_back(Leg({top.x + sx * splay, 0, top.z + sz * splay}, top, leg_r, round, taper, 0));
    }
    if (d.C(0.4)) {
      const double y = d.U(0.1, 0.25);
      for (int side = -1; side <= 1; side += 2) {
        parts.push_back(Bar({side * (w / 2 - inset), y, -(depth / 2 - inset)}, {side * (w / 2 - inset), y, depth / 2 - inset},
                            leg_r * 0.6, leg_r * 0.6, 0));
      }
    }
  } else if (base == 4) {
    const double column_r = d.U(0.02, 0.04), reach = d.U(0.25, 0.33);
    parts.push_back(CylinderPart({0, 0.07, 0}, {0, under, 0}, column_r, column_r, 0));
    const int arms = d.I(4, 5);
    for (int k = 0; k < arms; ++k) {
      const double a = 2 * kPi * k / arms;
      const Vec3 tip{reach * std::cos(a), 0.05, reach * std::sin(a)};
      parts.push_back(Bar({0, 0.09, 0}, tip, 0.02, 0.015, 0));
      parts.push_back(RoundedBoxPart({tip.x, 0.03, tip.z}, {0.025, 0.03, 0.025}, 1.0, 0));
    }
  } else {
    const double r = leg_r * 0.7;
    for (int side = -1; side <= 1; side += 2) {
      const double x = side * (w / 2 - 0.02);
      parts.push_back(TubePart({{x, under, -depth / 2 + 0.04}, {x, r, -depth / 2 + 0.01}, {x, r, depth / 2 + 0.02},
                                {x, under, depth / 2 - 0.02}},
                               r, 0));
    }
  }
  // The back, built upright at the seat's rear edge, then tilted back about that edge.
  if (d.C(0.92)) {
    const double bh = d.U(0.30, 0.50), bt = d.U(0.02, 0.06), tilt = d.U(0.0, 0.25);
    const size_t first = parts.size();
    const double y0 = h + t / 2 - 0.005, z = depth / 2 - bt / 2;
    const int kind = d.I(0, 2);
    if (kind == 0) {
      const double bw = w / 2 * d.U(0.8, 1.0);
      parts.push_back(padded ? RoundedBoxPart({0, y0 + bh / 2, z}, {bw, bh / 2, bt / 2 + 0.01}, 0.25, 1)
                             : BoxPart({0, y0 + bh / 2, z}, {bw, bh / 2, bt / 2}, 1));
    } else {
      const double post = d.U(0.012, 0.025), rail = d.U(0.03, 0.08);
      for (int side = -1; side <= 1; side += 2) {
        parts.push_back(BoxPart({side * (w / 2 - post), y0 + bh / 2, z}, {post, bh / 2, bt / 2}, 0));
      }
      parts.push_back(BoxPart({0, y0 + bh - rail / 2, z}, {w / 2 - 0.001, rail / 2, bt / 2 * 1.1}, kind == 1 ? 1 : 0));
      const int n = kind == 1 ? d.I(2, 6) : d.I(1, 3);
      for (int k = 0; k < n; ++k) {
        if (kind == 1) {
          const double x = -w / 2 + post * 2 + (w - 4 * post) * (k + 0.5) / n, sw = d.U(0.008, 0.03);
          parts.push_back(BoxPart({x, y0 + (bh - rail) / 2, z}, {sw, (bh - rail) / 2 + 0.004, bt / 2 * 0.7}, 0));
        } else {
          const double y = y0 + (bh - rail) * (k + 0.5) / (n + 0.5);
          parts.push_back(BoxPart({0, y, z}, {w / 2 - post, rail / 3, bt / 2 * 0.8}, 1));
        }
      }
    }
    Pivot(parts, first, {0, y0, depth / 2}, RotationX(tilt));
  }
  if (d.C(0.35)) {
    const double ah = d.U(0.17, 0.26), aw = d.U(0.02, 0.05);
    for (int side = -1; side <= 1; side += 2) {
      const double x = side * (w / 2 + aw * 0.8);
      parts.push_back(BoxPart({x, h + ah, 0.02}, {aw, 0.015, depth * 0.42}, 0));
      parts.push_back(Bar({x, h - t / 2, -depth * 0.3}, {x, h + ah - 0.01, -depth * 0.3}, 0.012, 0.012, 0));
    }
  }
  return m;
}

ModelSpec Table(Draw d) {
  ModelSpec m;
  m.materials = {{"top", d.Pick({Surfacing::kWood, Surfacing::kWood, Surfacing::kPaint, Surfacing::kGlass})},
                 {"legs", d.Pick({Surfacing::kWood, Surfacing::kMetal, Surfacing::kPaint})}};
  const int kind = d.I(0, 3);  // dining, coffee, desk, round side
  const double h = kind == 1 ? d.U(0.35, 0.5) : kind == 3 ? d.U(0.5, 0.75) : d.U(0.70, 0.78);
  const bool round = kind == 3 || d.C(0.15);
  const double len = round ? d.U(0.35, 0.6) : kind == 2 ? d.U(1.0, 1.6) : d.U(0.8, 2.0);
  const double wid = round ? len : len * d.U(0.5, 1.0), t = d.U(0.02, 0.06);
  auto& parts = m.parts;
  if (round) {
    const double r = len;
    parts.push_back(LathePart({{0, -t / 2}, {r, -t / 2}, {r, t / 2}, {0, t / 2}}, {0, h - t / 2, 0}, 0));
  } else {
    parts.push_back(d.C(0.3) ? RoundedBoxPart({0, h - t / 2, 0}, {len / 2, t / 2, wid / 2}, 0.12, 0)
                             : BoxPart({0, h - t / 2, 0}, {len / 2, t / 2, wid / 2}, 0));
  }
  const double under = h - t + 0.004;
  const int base = round ? d.I(0, 1) * 2 : d.I(0, 3);  // 0-1: four legs, 2: pedestal, 3: panel ends
  const double leg = d.U(0.015, 0.04);
  const double ix = round ? len * 0.55 : len / 2 - d.U(0.03, 0.12), iz = round ? len * 0.55 : wid / 2 - d.U(0.03, 0.1);
  if (base <= 1) {
    const bool rnd = d.C(0.5);
    const double taper = d.C(0.4) ? d.U(0.5, 0.85) : 1.0;
    for (int k = 0; k < 4; ++k) {
      const double sx = k & 1 ? 1 : -1, sz = k & 2 ? 1 : -1;
      const double x = round ? sx * ix * 0.707 : sx * ix, z = round ? sz * iz * 0.707 : sz * iz;
      parts.push_back(Leg({x, 0, z}, {x, under, z}, leg, rnd, taper, 1));
    }
    if (!round && d.C(0.6)) {
      const double ah = d.U(0.05, 0.12);
      parts.push_back(BoxPart({0, under - ah / 2, -iz}, {ix, ah / 2, 0.01}, 1));
      parts.push_back(BoxPart({0, under - ah / 2, iz}, {ix, ah / 2, 0.01}, 1));
      parts.push_back(BoxPart({-ix, under - ah / 2, 0}, {0.01, ah / 2, iz - 0.011}, 1));
      parts.push_back(BoxPart({ix, under - ah / 2, 0}, {0.01, ah / 2, iz - 0.011}, 1));
    }
    if (!round && d.C(0.25)) parts.push_back(BoxPart({0, d.U(0.1, 0.25), 0}, {ix, 0.01, iz}, 0));
  } else if (base == 2) {
    const double cr = d.U(0.03, 0.08), fr = round ? len * d.U(0.5, 0.8) : std::min(wid, len) * 0.35;
    parts.push_back(CylinderPart({0, 0.02, 0}, {0, under, 0}, cr, cr * d.U(0.6, 1.0), 1));
    parts.push_back(LathePart({{0, 0}, {fr, 0}, {fr * 0.9, 0.03}, {0, 0.04}}, {0, 0, 0}, 1));
  } else {
    const double pt = d.U(0.02, 0.05);
    for (int side = -1; side <= 1; side += 2) {
      parts.push_back(BoxPart({side * ix, under / 2, 0}, {pt, under / 2, iz}, 1));
    }
    if (d.C(0.5)) parts.push_back(BoxPart({0, under * 0.3, 0}, {ix - pt, 0.03, 0.015}, 1));
  }
  return m;
}

ModelSpec Sofa(Draw d) {
  ModelSpec m;
  m.materials = {{"upholstery", d.Pick({Surfacing::kFabric, Surfacing::kFabric, Surfacing::kLeather})},
                 {"cushions", d.Pick({Surfacing::kFabric, Surfacing::kLeather})},
                 {"legs", d.Pick({Surfacing::kWood, Surfacing::kMetal})}};
  const double w = d.U(1.3, 2.4), depth = d.U(0.75, 1.0), seat = d.U(0.38, 0.48), top = d.U(0.7, 0.95);
  const double legs = d.C(0.6) ? d.U(0.04, 0.15) : 0.0, cushion = d.U(0.08, 0.16), back_t = d.U(0.14, 0.25);
  const bool arms = d.C(0.85);
  const double arm_w = arms ? d.U(0.08, 0.25) : 0.0, arm_h = d.U(0.52, 0.7), e = d.U(0.12, 0.3);
  auto& parts = m.parts;
  const double base_top = seat - cushion;
  parts.push_back(RoundedBoxPart({0, (legs + base_top) / 2, 0}, {w / 2, (base_top - legs) / 2 + 0.01, depth / 2}, e, 0));
  parts.push_back(RoundedBoxPart({0, (base_top + top) / 2, depth / 2 - back_t / 2},
                                 {w / 2 - 0.005, (top - base_top) / 2, back_t / 2}, e, 0));
  if (arms) {
    for (int side = -1; side <= 1; side += 2) {
      parts.push_back(RoundedBoxPart({side * (w / 2 - arm_w / 2), (legs + arm_h) / 2 + 0.01, -0.01},
                                     {arm_w / 2, (arm_h - legs) / 2, depth / 2}, e, 0));
    }
  }
  const int n = d.I(1, 3);
  const double inner = w - 2 * arm_w - 0.02, cw = inner / n;
  for (int k = 0; k < n; ++k) {
    const double x = -inner / 2 + cw * (k + 0.5);
    parts.push_back(RoundedBoxPart({x, base_top + cushion / 2, -back_t / 2 + 0.01},
                                   {cw / 2 - 0.008, cushion / 2 + 0.008, (depth - back_t) / 2}, e, 1));
    if (d.C(0.5)) {
      parts.push_back(RoundedBoxPart({x, (seat + top) / 2 + 0.02, depth / 2 - back_t - 0.04},
                                     {cw / 2 - 0.01, (top - seat) / 2 - 0.02, 0.07}, 0.4, 1));
    }
  }
  if (legs > 0) {
    const bool round = d.C(0.5);
    for (int k = 0; k < 4; ++k) {
      const double sx = k & 1 ? 1 : -1, sz = k & 2 ? 1 : -1;
      const Vec3 p{sx * (w / 2 - 0.06), 0, sz * (depth / 2 - 0.06)};
      parts.push_back(Leg(p, {p.x, legs + 0.03, p.z}, 0.02, round, 0.7, 2));
    }
  }
  return m;
}

ModelSpec Bed(Draw d) {
  ModelSpec m;
  m.materials = {{"frame", d.Pick({Surfacing::kWood, Surfacing::kMetal, Surfacing::kPaint})},
                 {"mattress", Surfacing::kFabric},
                 {"pillows", Surfacing::kFabric}};
  const double len = d.U(1.9, 2.2), w = d.C(0.4) ? d.U(0.9, 1.2) : d.U(1.4, 1.9), fh = d.U(0.18, 0.4);
  const double mt = d.U(0.15, 0.3), head = d.U(0.35, 0.9), ht = d.U(0.03, 0.08);
  const double leg = d.C(0.6) ? d.U(0.05, 0.15) : 0.0;
  auto& parts = m.parts;
  parts.push_back(BoxPart({0, (leg + fh) / 2, 0}, {w / 2, (fh - leg) / 2, len / 2}, 0));
  parts.push_back(RoundedBoxPart({0, fh + mt / 2 - 0.01, -0.01}, {w / 2 - 0.02, mt / 2, len / 2 - 0.03}, d.U(0.1, 0.25), 1));
  const double top = fh + mt + head;
  if (d.C(0.5)) {
    parts.push_back(BoxPart({0, top / 2, len / 2 + ht / 2}, {w / 2 + 0.02, top / 2, ht / 2}, 0));
  } else {
    const double post = d.U(0.025, 0.05);
    for (int side = -1; side <= 1; side += 2) parts.push_back(BoxPart({side * (w / 2 + post), top / 2, len / 2 + ht / 2}, {post, top / 2, ht / 2 + 0.005}, 0));
    parts.push_back(BoxPart({0, top - 0.05, len / 2 + ht / 2}, {w / 2, 0.05, ht / 2}, 0));
    const int n = d.I(3, 9);
    for (int k = 0; k < n; ++k) {
      const double x = -w / 2 + w * (k + 0.5) / n;
      parts.push_back(BoxPart({x, (fh + top - 0.1) / 2, len / 2 + ht / 2}, {d.U(0.008, 0.03), (top - 0.1 - fh) / 2 + 0.01, ht / 3}, 0));
    }
  }
  if (d.C(0.4)) {
    const double foot = fh + d.U(0.05, 0.35);
    parts.push_back(BoxPart({0, foot / 2, -len / 2 - ht / 2}, {w / 2 + 0.02, foot / 2, ht / 2}, 0));
  }
  const int pillows = w > 1.3 ? 2 : 1;
  for (int k = 0; k < pillows; ++k) {
    const double x = pillows == 1 ? 0 : (k == 0 ? -w / 4 : w / 4);
    parts.push_back(RoundedBoxPart({x, fh + mt + 0.05, len / 2 - 0.25}, {w / (2 * pillows) - 0.06, 0.07, 0.18}, 0.5, 2));
  }
  if (leg > 0) {
    for (int k = 0; k < 4; ++k) {
      const double sx = k & 1 ? 1 : -1, sz = k & 2 ? 1 : -1;
      const Vec3 p{sx * (w / 2 - 0.05), 0, sz * (len / 2 - 0.05)};
      parts.push_back(CylinderPart(p, {p.x, leg + 0.02, p.z}, 0.025, 0.03, 0));
    }
  }
  return m;
}

ModelSpec Cabinet(Draw d) {
  ModelSpec m;
  m.materials = {{"body", d.Pick({Surfacing::kWood, Surfacing::kPaint, Surfacing::kPlastic})},
                 {"fronts", d.Pick({Surfacing::kWood, Surfacing::kPaint})},
                 {"handles", Surfacing::kMetal}};
  const double w = d.U(0.4, 1.6), h = d.U(0.45, 2.0), dep = d.U(0.35, 0.6), feet = d.C(0.5) ? d.U(0.04, 0.15) : 0.0;
  auto& parts = m.parts;
  parts.push_back(BoxPart({0, feet + (h - feet) / 2, 0}, {w / 2, (h - feet) / 2, dep / 2}, 0));
  if (d.C(0.4)) parts.push_back(BoxPart({0, h + 0.015, -0.01}, {w / 2 + 0.02, 0.016, dep / 2 + 0.02}, 0));
  const int columns = w > 0.8 ? d.I(2, 3) : d.I(1, 2);
  const int rows = d.I(1, std::max(1, static_cast<int>((h - feet) / 0.3)));
  const bool drawers = d.C(0.5);
  const double gap = 0.006, cell_w = w / columns, cell_h = (h - feet) / rows;
  for (int c = 0; c < columns; ++c) {
    for (int r = 0; r < rows; ++r) {
      const double x = -w / 2 + cell_w * (c + 0.5), y = feet + cell_h * (r + 0.5);
      parts.push_back(BoxPart({x, y, -dep / 2 - 0.009}, {cell_w / 2 - gap, cell_h / 2 - gap, 0.01}, 1));
      const bool knob = d.C(0.3);
      const double hx = drawers ? x : x + (c % 2 == 0 ? 1 : -1) * (cell_w / 2 - 0.05);
      const double hy = drawers ? y + cell_h * 0.25 : y;
      if (knob) {
        parts.push_back(CylinderPart({hx, hy, -dep / 2 - 0.018}, {hx, hy, -dep / 2 - 0.04}, 0.008, 0.014, 2));
      } else if (drawers) {
        parts.push_back(TubePart({{hx - 0.06, hy, -dep / 2 - 0.015}, {hx - 0.06, hy, -dep / 2 - 0.04},
                                  {hx + 0.06, hy, -dep / 2 - 0.04}, {hx + 0.06, hy, -dep / 2 - 0.015}},
                                 0.006, 2));
      } else {
        const double len = std::min(0.12, cell_h * 0.3);
        parts.push_back(TubePart({{hx, hy - len, -dep / 2 - 0.015}, {hx, hy - len, -dep / 2 - 0.04},
                                  {hx, hy + len, -dep / 2 - 0.04}, {hx, hy + len, -dep / 2 - 0.015}},
                                 0.006, 2));
      }
    }
  }
  if (feet > 0) {
    for (int k = 0; k < 4; ++k) {
      const double sx = k & 1 ? 1 : -1, sz = k & 2 ? 1 : -1;
      const Vec3 p{sx * (w / 2 - 0.04), 0, sz * (dep / 2 - 0.04)};
      parts.push_back(CylinderPart(p, {p.x, feet + 0.01, p.z}, 0.015, 0.022, 2));
    }
  }
  return m;
}

ModelSpec Bookshelf(Draw d) {
  ModelSpec m;
  m.materials = {{"panels", d.Pick({Surfacing::kWood, Surfacing::kWood, Surfacing::kPaint})},
                 {"books", Surfacing::kPaint},
                 {"books_other", Surfacing::kPaint}};
  const double w = d.U(0.5, 1.8), h = d.U(0.8, 2.2), dep = d.U(0.22, 0.4), t = d.U(0.015, 0.035);
  const int shelves = std::max(1, static_cast<int>(h / d.U(0.28, 0.45)));
  const bool back = d.C(0.75);
  auto& parts = m.parts;
  for (int side = -1; side <= 1; side += 2) parts.push_back(BoxPart({side * (w / 2 - t / 2), h / 2, 0}, {t / 2, h / 2, dep / 2}, 0));
  if (back) parts.push_back(BoxPart({0, h / 2, dep / 2 - 0.005}, {w / 2 - t + 0.002, h / 2 - 0.002, 0.006}, 0));
  const int dividers = w > 1.0 ? d.I(0, 2) : 0;
  const double plinth = d.U(0.0, 0.08);
  for (int s = 0; s <= shelves; ++s) {
    const double y = plinth + t / 2 + (h - plinth - t) * s / shelves;
    parts.push_back(BoxPart({0, y, 0}, {w / 2 - t + 0.003, t / 2, dep / 2 - 0.003}, 0));
    if (s == shelves) break;
    const double gap = (h - plinth - t) / shelves - t;
    for (int k = 1; k <= dividers; ++k) {
      parts.push_back(BoxPart({-w / 2 + w * k / (dividers + 1), y + t / 2 + gap / 2, 0}, {t / 2, gap / 2 + 0.002, dep / 2 - 0.004}, 0));
    }
    // Books on some shelves: a run of upright boxes from the left, some leaning.
    if (d.C(0.6)) {
      double x = -w / 2 + t + 0.01;
      const double end = x + (w - 2 * t) * d.U(0.2, 0.8);
      int placed = 0;
      while (x < end && placed < 14) {
        const double bw = d.U(0.015, 0.045), bh = gap * d.U(0.55, 0.9), bd = dep * d.U(0.6, 0.9);
        const int material = d.C(0.5) ? 1 : 2;
        parts.push_back(BoxPart({x + bw, y + t / 2 + bh / 2 + 0.001, -dep / 2 + bd / 2 + 0.01}, {bw, bh / 2, bd / 2}, material));
        x += 2 * bw + 0.003;
        ++placed;
      }
    }
  }
  return m;
}

ModelSpec Lamp(Draw d) {
  ModelSpec m;
  m.materials = {{"base", d.Pick({Surfacing::kMetal, Surfacing::kCeramic, Surfacing::kWood, Surfacing::kPlastic})},
                 {"shade", d.Pick({Surfacing::kFabric, Surfacing::kPlastic, Surfacing::kMetal})}};
  const bool floor = d.C(0.45);
  const double height = floor ? d.U(1.3, 1.9) : d.U(0.35, 0.7);
  const double base_r = floor ? d.U(0.12, 0.2) : d.U(0.06, 0.13), base_t = d.U(0.015, 0.05);
  auto& parts = m.parts;
  if (d.C(0.75)) {
    parts.push_back(LathePart({{0, 0}, {base_r, 0}, {base_r, base_t * 0.6}, {base_r * 0.7, base_t}, {0, base_t}}, {}, 0));
  } else {
    parts.push_back(BoxPart({0, base_t / 2, 0}, {base_r * 0.8, base_t / 2, base_r * 0.8}, 0));
  }
  const double stem_r = d.U(0.006, 0.018);
  const bool arm = d.C(0.35);
  Vec3 head{0, height, 0};
  if (arm) {
    const double l1 = height * d.U(0.45, 0.6), a1 = d.U(-0.35, 0.35), l2 = height * d.U(0.35, 0.5), a2 = d.U(0.6, 1.4);
    const Vec3 j1{0, base_t + l1 * std::cos(a1), l1 * std::sin(a1)};
    head = j1 + Vec3{0, l2 * std::cos(a2) * 0.3, -l2 * std::sin(a2)};
    parts.push_back(TubePart({{0, base_t - 0.005, 0}, j1, head}, stem_r, 0));
  } else {
    parts.push_back(CylinderPart({0, base_t - 0.005, 0}, {0, height - 0.02, 0}, stem_r, stem_r, 0));
  }
  const int shade = d.I(0, 2);
  const double sr = floor ? d.U(0.15, 0.28) : d.U(0.08, 0.18), sh = sr * d.U(0.6, 1.4), wall = d.U(0.003, 0.008);
  if (shade == 2 || arm) {
    // A dome open at the bottom, hanging from the arm's end (or the stem's top).
    std::vector<P2> profile;
    for (int k = 0; k <= 8; ++k) {
      const double a = kPi / 2 * k / 8;
      profile.push_back({(sr + wall) * std::sin(a), (sh + wall) * std::cos(a)});
    }
    for (int k = 8; k >= 0; --k) {
      const double a = kPi / 2 * k / 8;
      profile.push_back({sr * std::sin(a), sh * std::cos(a)});
    }
    parts.push_back(LathePart(profile, head + Vec3{0, -sh * 0.9, 0}, 1));
  } else {
    const double rb = sr, rt = sr * d.U(0.5, 1.0), y0 = height - sh * d.U(0.5, 0.8);
    parts.push_back(LathePart({{rb, 0}, {rt, sh}, {rt - wall, sh}, {rb - wall, 0}}, {0, y0, 0}, 1));
    // The spider holding the shade on the stem.
    parts.push_back(CylinderPart({-rt + wall, y0 + sh - 0.01, 0}, {rt - wall, y0 + sh - 0.01, 0}, 0.003, 0.003, 0));
    if (d.C(0.7)) parts.push_back(RoundedBoxPart({0, y0 + sh * 0.45, 0}, {0.03, 0.045, 0.03}, 1.0, 0));
  }
  return m;
}

ModelSpec Display(Draw d) {
  ModelSpec m;
  m.materials = {{"body", d.Pick({Surfacing::kPlastic, Surfacing::kMetal})}, {"screen", Surfacing::kScreen}};
  const double w = d.U(0.4, 1.4), aspect = d.Pick({16.0 / 9, 16.0 / 10, 4.0 / 3, 21.0 / 9}), h = w / aspect;
  const double t = d.U(0.012, 0.05), bezel = d.U(0.005, 0.03);
  const int stand = d.I(0, 3);  // 0 neck and plate, 1 neck and disc, 2 two feet, 3 none (wall mount)
  const double lift = stand == 3 ? 0.0 : d.U(0.06, 0.2) + (stand == 2 ? 0.0 : 0.08);
  auto& parts = m.parts;
  const double cy = lift + h / 2 + bezel;
  parts.push_back(BoxPart({0, cy, 0}, {w / 2 + bezel, h / 2 + bezel, t / 2}, 0));
  parts.push_back(BoxPart({0, cy, -t / 2 - 0.001}, {w / 2, h / 2, 0.0015}, 1));
  if (d.C(0.5)) parts.push_back(BoxPart({0, cy, t / 2 + 0.02}, {w * 0.3, h * 0.3, 0.025}, 0));
  if (stand == 0 || stand == 1) {
    const double neck_w = d.U(0.02, 0.06), foot = w * d.U(0.2, 0.35);
    parts.push_back(BoxPart({0, (0.005 + cy) / 2, t / 2 + 0.03}, {neck_w, (cy - 0.005) / 2, 0.012}, 0));
    if (stand == 0) {
      parts.push_back(BoxPart({0, 0.008, 0.03}, {foot, 0.008, foot * 0.7}, 0));
    } else {
      parts.push_back(LathePart({{0, 0}, {foot, 0}, {foot * 0.95, 0.014}, {0, 0.018}}, {0, 0, 0.03}, 0));
    }
  } else if (stand == 2) {
    for (int side = -1; side <= 1; side += 2) {
      const double x = side * w * 0.38;
      parts.push_back(Bar({x, 0.005, -0.05}, {x, lift + bezel + 0.02, 0}, 0.012, 0.01, 0));
      parts.push_back(BoxPart({x, 0.006, 0}, {0.02, 0.006, 0.1}, 0));
    }
  }
  return m;
}

// Side-view outline (x: front at +x, y up) with wheel arches cut into its lower edge.
std::vector<P2> CarSide(double len, double ground, double belt, double nose, double tail, double wheel_r,
                        double front_axle, double rear_axle, double edge) {
  std::vector<P2> pts;
  // Over the top of each arch, from its rear end to its front end: the outline runs
  // counter-clockwise, so its lower edge goes from the tail to the nose.
  const auto arch = [&](double cx) {
    const double r = wheel_r * 1.12;
    const int n = CountFor(kPi * r, edge, 8);
    for (int k = 0; k <= n; ++k) {
      const double a = kPi * (1 - static_cast<double>(k) / n);
      pts.push_back({cx + r * std::cos(a), ground + r * 0.2 + r * std::sin(a)});
    }
  };
  const double half = len / 2;
  // Lower edge from the tail to the nose, then up the nose, back along the belt line.
  pts.push_back({-half + 0.05 * len, ground});
  arch(rear_axle);
  arch(front_axle);
  pts.push_back({half - 0.04 * len, ground});
  pts.push_back({half, ground + (belt - ground) * 0.35});
  pts.push_back({half - 0.015 * len, belt - nose});
  pts.push_back({half - 0.1 * len, belt});
  pts.push_back({-half + 0.06 * len, belt + tail});
  pts.push_back({-half, belt - (belt - ground) * 0.2});
  pts.push_back({-half + 0.01 * len, ground + (belt - ground) * 0.3});
  return pts;
}

ModelSpec Car(Draw d) {
  ModelSpec m;
  m.materials = {{"paint", Surfacing::kPaint},
                 {"glass", Surfacing::kGlass},
                 {"tyres", Surfacing::kRubber},
                 {"trim", Surfacing::kMetal}};
  const double len = d.U(3.6, 5.0), w = len * d.U(0.38, 0.46), suv = d.C(0.3) ? 1.0 : 0.0;
  const double wheel_r = d.U(0.29, 0.38) + 0.05 * suv, ground = d.U(0.12, 0.2) + 0.08 * suv;
  const double belt = ground + d.U(0.55, 0.7) + 0.15 * suv, roof = belt + d.U(0.38, 0.5) + 0.1 * suv;
  const double wheelbase = len * d.U(0.56, 0.64), shift = len * d.U(-0.03, 0.03);
  const double arch_room = len / 2 - 0.05 * len - 1.12 * wheel_r - 0.03;
  const double front_axle = std::min(wheelbase / 2 + shift, arch_room), rear_axle = std::max(-wheelbase / 2 + shift, -arch_room);
  const double nose = d.U(0.05, 0.2), tail = d.U(-0.05, 0.08);
  // The glasshouse: windshield base near the front axle, raked back to the roof.
  const double cab_front = front_axle - d.U(0.0, 0.35) * wheel_r * 2;
  const double cab_rear = d.C(0.3) ? -len / 2 + 0.08 * len : rear_axle - d.U(0.0, 1.0) * wheel_r;
  const double roof_front = cab_front - (roof - belt) * d.U(1.0, 2.2);
  const double roof_rear = std::min(cab_rear + (roof - belt) * d.U(0.2, 1.5), roof_front - 0.3);
  auto& parts = m.parts;
  // Outlines are in (x forward, y up); RotationY(pi/2) maps +x to -z (front) and the
  // extrusion's z to x (across the car).
  const Rotation side = RotationY(kPi / 2);
  parts.push_back(ExtrusionPart(
      [=](double edge) { return CarSide(len, ground, belt, nose, tail, wheel_r, front_axle, rear_axle, edge); }, w / 2,
      {}, 0, side));
  parts.push_back(ExtrusionPart(Polygon({{cab_rear, belt - 0.02}, {cab_front, belt - 0.02}, {roof_front, roof}, {roof_rear, roof}}),
                                w / 2 * d.U(0.8, 0.9), {}, 1, side));
  parts.push_back(ExtrusionPart(Polygon({{roof_rear + 0.02, roof - 0.01}, {roof_front - 0.02, roof - 0.01},
                                         {roof_front - 0.05, roof + 0.03}, {roof_rear + 0.05, roof + 0.03}}),
                                w / 2 * 0.78, {}, 0, side));
  const double tyre_w = d.U(0.17, 0.26), rim = wheel_r * d.U(0.55, 0.7);
  for (int k = 0; k < 4; ++k) {
    const double sx = k & 1 ? 1 : -1, axle = k & 2 ? front_axle : rear_axle;
    const Vec3 centre{sx * (w / 2 - tyre_w * 0.45), wheel_r, -axle};
    const Rotation axis = RotationZ(kPi / 2);
    parts.push_back(LathePart({{rim, -tyre_w / 2}, {wheel_r * 0.96, -tyre_w / 2}, {wheel_r, -tyre_w * 0.35},
                               {wheel_r, tyre_w * 0.35}, {wheel_r * 0.96, tyre_w / 2}, {rim, tyre_w / 2}},
                              centre, 2, axis));
    parts.push_back(LathePart({{0, -tyre_w * 0.42}, {rim + 0.004, -tyre_w * 0.42}, {rim + 0.004, tyre_w * 0.42}, {0, tyre_w * 0.42}},
                              centre, 3, axis));
  }
  for (int side_x = -1; side_x <= 1; side_x += 2) {
    parts.push_back(BoxPart({side_x * w * 0.36, belt - (belt - ground) * 0.3, -len / 2 + 0.01}, {w * 0.1, 0.04, 0.02}, 3));
    parts.push_back(BoxPart({side_x * w * 0.38, belt - (belt - ground) * 0.25, len / 2 - 0.02}, {w * 0.08, 0.035, 0.03}, 3));
    if (d.C(0.7)) parts.push_back(BoxPart({side_x * (w / 2 + 0.06), belt + 0.08, -cab_front - 0.05}, {0.07, 0.04, 0.02}, 0));
  }
  return m;
}

ModelSpec Airplane(Draw d) {
  ModelSpec m;
  m.materials = {{"body", d.Pick({Surfacing::kPaint, Surfacing::kMetal})}, {"tail", Surfacing::kPaint},
                 {"engines", Surfacing::kMetal}};
  const double len = d.U(8, 40), r = len * d.U(0.05, 0.08), span = len * d.U(0.8, 1.2);
  const double nose = d.U(1.5, 3.5) * r, tail_len = d.U(3, 5) * r;
  auto& parts = m.parts;
  // Fuselage along +Y from tail (y = 0) to nose (y = len), then turned so the nose is -z.
  std::vector<P2> profile = {{0, 0}, {r * 0.15, 0.01 * len}};
  for (int k = 1; k <= 4; ++k) profile.push_back({r * (0.15 + 0.85 * std::sin(kPi / 2 * k / 4)), tail_len * k / 4});
  for (int k = 1; k <= 6; ++k) {
    const double a = kPi / 2 * k / 6;
    profile.push_back({r * std::cos(a), len - nose + nose * std::sin(a)});
  }
  profile.back() = {0, len};
  const Rotation forward = RotationX(-kPi / 2);  // +y to -z
  parts.push_back(LathePart(profile, {0, 0, len / 2}, 0, forward));
  // Wings: a planform (x across, y forward) extruded to the wing's thickness, laid flat.
  const double root = len * d.U(0.12, 0.22), taper = d.U(0.25, 0.6), sweep = d.U(0.0, 0.35) * span / 2;
  const double wing_y = -len * d.U(0.0, 0.12), thick = root * d.U(0.04, 0.08), wing_h = d.C(0.6) ? -r * 0.4 : r * 0.5;
  const auto planform = [](double half_span, double root_chord, double tip_chord, double back, double centre) {
    return std::vector<P2>{{0, centre + root_chord / 2}, {-half_span, centre + root_chord / 2 - back},
                           {-half_span, centre + root_chord / 2 - back - tip_chord}, {0, centre - root_chord / 2},
                           {half_span, centre + root_chord / 2 - back - tip_chord}, {half_span, centre + root_chord / 2 - back}};
  };
  const Rotation flat = forward;  // extrusion z to y (thickness), outline y to -z (forward)
  parts.push_back(ExtrusionPart(Polygon(planform(span / 2, root, root * taper, sweep, -wing_y)), thick / 2,
                                {0, wing_h, 0}, 0, flat));
  const double tail_span = span * d.U(0.28, 0.4), tail_root = root * d.U(0.4, 0.6);
  const double tail_z = len / 2 - tail_len * 0.5;
  parts.push_back(ExtrusionPart(Polygon(planform(tail_span / 2, tail_root, tail_root * 0.5, tail_root * 0.5, -tail_z)),
                                thick * 0.35, {0, r * 0.3, 0}, 1, flat));
  const double fin_h = r * d.U(2.5, 4.0), fin_root = tail_root * d.U(1.0, 1.6);
  // Fin outline in (x: forward, y: up), extruded across (RotationY(pi/2): +x to -z).
  parts.push_back(ExtrusionPart(Polygon({{-tail_z - fin_root / 2, r * 0.5}, {-tail_z + fin_root / 2, r * 0.5},
                                         {-tail_z - fin_root * 0.1, r + fin_h}, {-tail_z - fin_root * 0.45, r + fin_h}}),
                                thick * 0.35, {}, 1, RotationY(kPi / 2)));
  if (d.C(0.75)) {
    const int engines = d.C(0.3) ? 4 : 2;
    const double er = r * d.U(0.35, 0.55), el = er * d.U(2.5, 4.0);
    for (int k = 0; k < engines; ++k) {
      const double x = (k % 2 == 0 ? -1 : 1) * span / 2 * (k < 2 ? 0.33 : 0.62);
      const double z = wing_y - root / 2 + std::fabs(x) / (span / 2) * sweep * 0.9 - el * 0.35;
      parts.push_back(LathePart({{0, 0}, {er * 0.8, 0}, {er, el * 0.3}, {er * 0.85, el}, {0, el}},
                                {x, wing_h - er * 1.1, z + el / 2}, 2, forward));
    }
  }
  return m;
}

// A smooth radius profile through random control radii (Catmull-Rom), sampled.
std::vector<P2> SmoothProfile(const std::vector<double>& radii, double y0, double y1, int samples) {
  std::vector<P2> out;
  const auto n = static_cast<int64_t>(radii.size());
  for (int k = 0; k <= samples; ++k) {
    const double t = static_cast<double>(k) / samples, x = t * static_cast<double>(n - 1);
    const int64_t i = std::min<int64_t>(static_cast<int64_t>(x), n - 2);
    const double f = x - static_cast<double>(i);
    const auto r = [&](int64_t j) { return radii[static_cast<size_t>(std::clamp<int64_t>(j, 0, n - 1))]; };
    const double p0 = r(i - 1), p1 = r(i), p2 = r(i + 1), p3 = r(i + 2);
    const double v = 0.5 * (2 * p1 + (p2 - p0) * f + (2 * p0 - 5 * p1 + 4 * p2 - p3) * f * f +
                            (3 * p1 - p0 - 3 * p2 + p3) * f * f * f);
    out.push_back({std::max(v, 0.15 * radii[0]), Lerp(y0, y1, t)});
  }
  return out;
}

ModelSpec Bottle(Draw d) {
  ModelSpec m;
  m.materials = {{"bottle", d.Pick({Surfacing::kGlass, Surfacing::kPlastic, Surfacing::kCeramic})},
                 {"cap", d.Pick({Surfacing::kMetal, Surfacing::kPlastic})}};
  const double r = d.U(0.03, 0.06), body = d.U(0.1, 0.25), shoulder = d.U(0.02, 0.08), neck_r = r * d.U(0.25, 0.45);
  const double neck = d.U(0.02, 0.1);
  std::vector<P2> profile = {{0, 0}, {r * 0.92, 0}, {r, r * 0.1}, {r, body}};
  for (int k = 1; k <= 5; ++k) {
    const double t = k / 5.0;
    profile.push_back({Lerp(r, neck_r, t * t * (3 - 2 * t)), body + shoulder * t});
  }
  profile.push_back({neck_r, body + shoulder + neck});
  profile.push_back({neck_r * 1.15, body + shoulder + neck + 0.004});
  profile.push_back({0, body + shoulder + neck + 0.006});
  m.parts.push_back(LathePart(profile, {}, 0));
  if (d.C(0.7)) {
    const double y = body + shoulder + neck - 0.008, ch = d.U(0.012, 0.03);
    m.parts.push_back(LathePart({{0, 0}, {neck_r * 1.3, 0}, {neck_r * 1.3, ch}, {0, ch}}, {0, y, 0}, 1));
  }
  return m;
}

ModelSpec Vase(Draw d) {
  ModelSpec m;
  m.materials = {{"vase", d.Pick({Surfacing::kCeramic, Surfacing::kGlass, Surfacing::kCeramic})}};
  const int n = d.I(4, 7);
  const double h = d.U(0.2, 0.6);
  std::vector<double> radii;
  for (int k = 0; k < n; ++k) radii.push_back(h * d.U(0.1, 0.35));
  m.parts.push_back(LathePart(HollowProfile(SmoothProfile(radii, 0, h, 14), h * d.U(0.015, 0.03), h * 0.04), {}, 0));
  return m;
}

ModelSpec Mug(Draw d) {
  ModelSpec m;
  m.materials = {{"mug", d.Pick({Surfacing::kCeramic, Surfacing::kCeramic, Surfacing::kMetal, Surfacing::kPlastic})}};
  const double r = d.U(0.035, 0.05), h = r * d.U(1.5, 2.6), flare = d.U(0.9, 1.15), wall = d.U(0.003, 0.007);
  m.parts.push_back(LathePart(HollowProfile({{r * 0.95, 0}, {r, 0.006}, {r * (1 + flare) / 2, h * 0.5}, {r * flare, h}}, wall, 0.008),
                              {}, 0));
  if (d.C(0.85)) {
    const double hr = d.U(0.004, 0.008), reach = d.U(0.015, 0.028), y0 = h * d.U(0.15, 0.3), y1 = h * d.U(0.7, 0.85);
    std::vector<Vec3> path;
    for (int k = 0; k <= 12; ++k) {
      const double a = kPi * k / 12;
      path.push_back({r - wall + reach * std::sin(a), Lerp(y0, y1, 0.5 - 0.5 * std::cos(a)), 0});
    }
    m.parts.push_back(TubePart(path, hr, 0));
  }
  return m;
}

ModelSpec Bowl(Draw d) {
  ModelSpec m;
  m.materials = {{"bowl", d.Pick({Surfacing::kCeramic, Surfacing::kWood, Surfacing::kPlastic, Surfacing::kGlass})}};
  const double r = d.U(0.06, 0.18), h = r * d.U(0.35, 0.8), foot = r * d.U(0.3, 0.55), wall = r * d.U(0.03, 0.07);
  std::vector<P2> outer = {{foot, 0}, {foot, h * 0.06}};
  for (int k = 1; k <= 8; ++k) {
    const double a = kPi / 2 * k / 8;
    outer.push_back({foot + (r - foot) * std::sin(a), h * 0.06 + (h * 0.94) * (1 - std::cos(a))});
  }
  m.parts.push_back(LathePart(HollowProfile(outer, wall, h * 0.08), {}, 0));
  return m;
}

ModelSpec Bench(Draw d) {
  ModelSpec m;
  m.materials = {{"seat", Surfacing::kWood}, {"frame", d.Pick({Surfacing::kMetal, Surfacing::kWood, Surfacing::kPaint})}};
  const double len = d.U(1.0, 2.2), dep = d.U(0.3, 0.5), h = d.U(0.4, 0.48);
  auto& parts = m.parts;
  const bool slats = d.C(0.6);
  if (slats) {
    const int n = d.I(3, 6);
    for (int k = 0; k < n; ++k) {
      const double z = -dep / 2 + dep * (k + 0.5) / n;
      parts.push_back(BoxPart({0, h - 0.015, z}, {len / 2, 0.015, dep / (2 * n) - 0.006}, 0));
    }
  } else {
    parts.push_back(BoxPart({0, h - 0.025, 0}, {len / 2, 0.025, dep / 2}, 0));
  }
  const int ends = d.I(0, 2);  // panels, leg pairs, tube frames
  const double x = len / 2 - d.U(0.05, 0.2);
  for (int side = -1; side <= 1; side += 2) {
    const double sx = side * x;
    if (ends == 0) {
      parts.push_back(BoxPart({sx, (h - 0.03) / 2, 0}, {0.025, (h - 0.03) / 2 + 0.004, dep / 2 - 0.02}, 1));
    } else if (ends == 1) {
      for (int f = -1; f <= 1; f += 2) parts.push_back(Bar({sx, 0, f * (dep / 2 - 0.04)}, {sx, h - 0.028, f * (dep / 2 - 0.05)}, 0.025, 0.025, 1));
      parts.push_back(Bar({sx, 0.12, -(dep / 2 - 0.04)}, {sx, 0.12, dep / 2 - 0.04}, 0.015, 0.015, 1));
    } else {
      parts.push_back(TubePart({{sx, h - 0.035, -dep / 2 + 0.03}, {sx, 0.015, -dep / 2 + 0.01}, {sx, 0.015, dep / 2 - 0.01},
                                {sx, h - 0.035, dep / 2 - 0.03}},
                               0.015, 1));
    }
  }
  if (d.C(0.45)) {
    const double bh = d.U(0.3, 0.45);
    const size_t first = parts.size();
    for (int side = -1; side <= 1; side += 2) parts.push_back(Bar({side * x, h - 0.03, dep / 2 - 0.03}, {side * x, h + bh, dep / 2 - 0.03}, 0.02, 0.02, 1));
    const int n = d.I(2, 4);
    for (int k = 0; k < n; ++k) parts.push_back(BoxPart({0, h + bh * (k + 0.6) / n, dep / 2 - 0.01}, {len / 2, bh / (3 * n), 0.012}, 0));
    Pivot(parts, first, {0, h, dep / 2}, RotationX(d.U(0.05, 0.3)));
    if (d.C(0.5)) {
      for (int side = -1; side <= 1; side += 2) parts.push_back(BoxPart({side * x, h + 0.22, 0}, {0.025, 0.015, dep / 2}, 1));
    }
  }
  return m;
}

ModelSpec TrashBin(Draw d) {
  ModelSpec m;
  m.materials = {{"bin", d.Pick({Surfacing::kPlastic, Surfacing::kMetal, Surfacing::kPaint})},
                 {"lid", d.Pick({Surfacing::kPlastic, Surfacing::kMetal})}};
  const double h = d.U(0.3, 0.9), wall = d.U(0.004, 0.012);
  auto& parts = m.parts;
  double lid_r = 0;
  if (d.C(0.5)) {
    const double r = h * d.U(0.25, 0.45), top = r * d.U(1.0, 1.25);
    lid_r = top;
    parts.push_back(LathePart(HollowProfile({{r, 0}, {r * 1.01, 0.01}, {top, h}}, wall, wall * 1.5), {}, 0));
  } else {
    const double w = h * d.U(0.4, 0.8), dep = w * d.U(0.6, 1.0);
    lid_r = -1;
    parts.push_back(BoxPart({0, wall / 2, 0}, {w / 2, wall / 2, dep / 2}, 0));
    for (int side = -1; side <= 1; side += 2) {
      parts.push_back(BoxPart({side * (w / 2 - wall / 2), h / 2, 0}, {wall / 2, h / 2, dep / 2 - 0.0005}, 0));
      parts.push_back(BoxPart({0, h / 2, side * (dep / 2 - wall / 2)}, {w / 2 - wall + 0.0005, h / 2, wall / 2}, 0));
    }
    if (d.C(0.6)) {
      const double open = d.C(0.5) ? d.U(0.2, 1.2) : 0.0;
      const size_t first = parts.size();
      parts.push_back(BoxPart({0, h + 0.012, 0}, {w / 2 + 0.01, 0.012, dep / 2 + 0.01}, 1));
      Pivot(parts, first, {0, h, dep / 2}, RotationX(open));
    }
    if (d.C(0.4)) parts.push_back(BoxPart({0, 0.03, -dep / 2 - 0.04}, {w * 0.2, 0.012, 0.04}, 1));
  }
  if (lid_r > 0 && d.C(0.5)) {
    parts.push_back(LathePart({{0, 0}, {lid_r + 0.008, 0}, {lid_r + 0.008, 0.015}, {lid_r * 0.6, 0.03 + lid_r * 0.2},
                               {0, 0.035 + lid_r * 0.25}},
                              {0, h + 0.001, 0}, 1));
  }
  return m;
}

double GuitarHalfWidth(double y, double len, double lower, double upper, double waist) {
  // Two bouts, blended through the waist.
  const double y1 = len * 0.3, a1 = len * 0.3, y2 = len * 0.74, a2 = len * 0.26;
  const auto bout = [](double y, double c, double a, double r) {
    const double q = (y - c) / a;
    return std::fabs(q) >= 1 ? 0.0 : r * std::sqrt(1 - q * q);
  };
  const double wa = bout(y, y1, a1, lower), wb = bout(y, y2, a2, upper);
  const double pinch = 1 - (1 - waist) * std::exp(-std::pow((y - len * 0.56) / (len * 0.1), 2));
  return std::max(wa, wb) * pinch;
}

ModelSpec Guitar(Draw d) {
  ModelSpec m;
  m.materials = {{"body", d.Pick({Surfacing::kWood, Surfacing::kPaint})}, {"neck", Surfacing::kWood},
                 {"hardware", Surfacing::kMetal}};
  const bool electric = d.C(0.35);
  const double len = d.U(0.45, 0.55), lower = len * d.U(0.34, 0.42), upper = lower * d.U(0.7, 0.85);
  const double waist = d.U(0.75, 0.9), thick = electric ? d.U(0.035, 0.05) : d.U(0.08, 0.12);
  auto& parts = m.parts;
  parts.push_back(ExtrusionPart(
      [=](double edge) {
        const int n = CountFor(2 * len, edge, 16);
        std::vector<P2> right, pts;
        for (int k = 0; k <= n; ++k) {
          const double y = len * k / n;
          right.push_back({std::max(GuitarHalfWidth(y, len, lower, upper, waist), 0.004), y});
        }
        right.front()[0] = 0.004;
        right.back()[0] = 0.004;
        for (const P2& p : right) pts.push_back(p);
        for (size_t k = right.size(); k-- > 0;) pts.push_back({-right[k][0], right[k][1]});
        return pts;
      },
      thick / 2, {}, 0));
  const double neck_len = d.U(0.4, 0.5), neck_w = d.U(0.022, 0.03);
  parts.push_back(BoxPart({0, len + neck_len / 2 - 0.05, -thick * 0.3}, {neck_w, neck_len / 2 + 0.05, 0.012}, 1));
  const size_t first = parts.size();
  const double head_y = len + neck_len - 0.05;
  parts.push_back(BoxPart({0, head_y + 0.09, -thick * 0.3}, {neck_w * 1.4, 0.09, 0.008}, 1));
  for (int k = 0; k < 6; ++k) {
    const double x = (k < 3 ? -1 : 1) * neck_w * 1.4, y = head_y + 0.03 + 0.05 * (k % 3);
    parts.push_back(CylinderPart({x, y, -thick * 0.3}, {x * 1.6, y, -thick * 0.3}, 0.004, 0.004, 2));
  }
  Pivot(parts, first, {0, head_y, -thick * 0.3}, RotationX(d.U(0.1, 0.3)));
  if (!electric) {
    const double hole = lower * d.U(0.25, 0.35);
    parts.push_back(LathePart({{0, 0}, {hole, 0}, {hole, 0.002}, {0, 0.002}}, {0, len * 0.62, -thick / 2 - 0.0005}, 2,
                              RotationX(-kPi / 2)));
  }
  parts.push_back(BoxPart({0, len * 0.22, -thick / 2 - 0.006}, {lower * 0.35, 0.012, 0.006}, 2));
  for (int k = 0; k < 6; ++k) {
    const double x0 = (k - 2.5) * neck_w * 0.3, x1 = (k - 2.5) * neck_w * 0.25;
    parts.push_back(CylinderPart({x0, len * 0.22, -thick / 2 - 0.011}, {x1, head_y, -thick * 0.3 - 0.0135}, 0.0008, 0.0008, 2));
  }
  return m;
}

ModelSpec Laptop(Draw d) {
  ModelSpec m;
  m.materials = {{"shell", d.Pick({Surfacing::kMetal, Surfacing::kPlastic})}, {"keys", Surfacing::kKeys},
                 {"screen", Surfacing::kScreen}};
  const double w = d.U(0.28, 0.4), dep = w * d.U(0.62, 0.72), t = d.U(0.012, 0.025), lid_t = d.U(0.005, 0.012);
  const double open = d.U(1.4, 2.3);  // radians from closed
  auto& parts = m.parts;
  parts.push_back(BoxPart({0, t / 2, 0}, {w / 2, t / 2, dep / 2}, 0));
  parts.push_back(BoxPart({0, t + 0.0008, 0.02 * dep}, {w * 0.44, 0.0012, dep * 0.25}, 1));
  parts.push_back(BoxPart({0, t + 0.0005, -dep * 0.32}, {w * 0.14, 0.0008, dep * 0.12}, 0));
  const size_t first = parts.size();
  // The lid, closed over the base, then opened about the back edge.
  parts.push_back(BoxPart({0, t + lid_t / 2 + 0.001, 0}, {w / 2, lid_t / 2, dep / 2}, 0));
  parts.push_back(BoxPart({0, t + 0.0005, -0.01 * dep}, {w * 0.46, 0.0006, dep * 0.44}, 2));
  Pivot(parts, first, {0, t, dep / 2}, RotationX(open));
  return m;
}

}  // namespace

ModelSpec MakeFamilySpec(ShapeFamily family, Rng& rng) {
  Draw d{rng};
  switch (family) {
    case ShapeFamily::kChair: return Chair(d);
    case ShapeFamily::kTable: return Table(d);
    case ShapeFamily::kSofa: return Sofa(d);
    case ShapeFamily::kBed: return Bed(d);
    case ShapeFamily::kCabinet: return Cabinet(d);
    case ShapeFamily::kBookshelf: return Bookshelf(d);
    case ShapeFamily::kLamp: return Lamp(d);
    case ShapeFamily::kDisplay: return Display(d);
    case ShapeFamily::kCar: return Car(d);
    case ShapeFamily::kAirplane: return Airplane(d);
    case ShapeFamily::kBottle: return Bottle(d);
    case ShapeFamily::kVase: return Vase(d);
    case ShapeFamily::kMug: return Mug(d);
    case ShapeFamily::kBowl: return Bowl(d);
    case ShapeFamily::kBench: return Bench(d);
    case ShapeFamily::kTrashBin: return TrashBin(d);
    case ShapeFamily::kGuitar: return Guitar(d);
    case ShapeFamily::kLaptop: return Laptop(d);
  }
  return Chair(d);
}

}  // namespace solid::convert
