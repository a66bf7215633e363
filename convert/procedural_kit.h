// Internal to convert/: the geometry of the procedural assets. Models are unions of
// closed parts (boxes, rounded boxes, ellipsoids, cylinders, lathes, extrusions, tubes),
// each tessellated to a target edge length, so that a model's triangle budget is met by
// choosing one number. Everything is double until the output; no fused multiply-adds
// (the files that include this are built with -ffp-contract=off), no <random>.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "solid/formats/random.h"

namespace solid::convert::kit {

inline constexpr double kPi = std::numbers::pi;

struct Vec3 {
  double x = 0, y = 0, z = 0;
};
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(Vec3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline double Dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 Cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double Length(Vec3 a) { return std::sqrt(Dot(a, a)); }
inline Vec3 Normalized(Vec3 a) {
  const double l = Length(a);
  return l > 0 ? a * (1 / l) : Vec3{0, 1, 0};
}
inline double Lerp(double a, double b, double t) { return a + (b - a) * t; }

struct Rotation {
  std::array<Vec3, 3> rows = {Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}};
  Vec3 Apply(Vec3 v) const { return {Dot(rows[0], v), Dot(rows[1], v), Dot(rows[2], v)}; }
};
inline Rotation operator*(const Rotation& a, const Rotation& b) {
  Rotation r;
  for (size_t i = 0; i < 3; ++i) {
    const Vec3 c0{b.rows[0].x, b.rows[1].x, b.rows[2].x}, c1{b.rows[0].y, b.rows[1].y, b.rows[2].y},
        c2{b.rows[0].z, b.rows[1].z, b.rows[2].z};
    r.rows[i] = {Dot(a.rows[i], c0), Dot(a.rows[i], c1), Dot(a.rows[i], c2)};
  }
  return r;
}
inline Rotation RotationX(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {{Vec3{1, 0, 0}, Vec3{0, c, -s}, Vec3{0, s, c}}};
}
inline Rotation RotationY(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {{Vec3{c, 0, s}, Vec3{0, 1, 0}, Vec3{-s, 0, c}}};
}
inline Rotation RotationZ(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {{Vec3{c, -s, 0}, Vec3{s, c, 0}, Vec3{0, 0, 1}}};
}
// A rotation taking +Y to the unit vector d.
inline Rotation YTo(Vec3 d) {
  const Vec3 y = Normalized(d);
  const Vec3 helper = std::fabs(y.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 0, 1};
  const Vec3 x = Normalized(Cross(y, helper)), z = Cross(x, y);
  return {{Vec3{x.x, y.x, z.x}, Vec3{x.y, y.y, z.y}, Vec3{x.z, y.z, z.z}}};
}

// Direction in the xz plane at fraction s of a turn about +Y, clockwise seen from above.
inline std::pair<double, double> AroundY(double s) { return {std::cos(2 * kPi * s), -std::sin(2 * kPi * s)}; }

// A smoothing group: normals average within a surface, never across surfaces. Seam and
// pole vertices are duplicated at bit-identical positions, which welds them.
struct Surface {
  std::vector<Vec3> positions;
  std::vector<std::array<double, 2>> uvs;
  std::vector<uint32_t> indices;
  std::vector<int> triangle_materials;

  uint32_t AddVertex(Vec3 p, double u, double v) {
    positions.push_back(p);
    uvs.push_back({u, v});
    return static_cast<uint32_t>(positions.size() - 1);
  }
  void AddTriangle(uint32_t a, uint32_t b, uint32_t c, int material) {
    indices.insert(indices.end(), {a, b, c});
    triangle_materials.push_back(material);
  }
  void AddQuad(uint32_t a, uint32_t b, uint32_t c, uint32_t d, int material) {
    AddTriangle(a, b, c, material);
    AddTriangle(a, c, d, material);
  }
};

using Shape = std::vector<Surface>;
using SurfaceFunction = std::function<Vec3(double s, double t)>;

inline int64_t CountTriangles(const Shape& shape) {
  int64_t n = 0;
  for (const Surface& s : shape) n += static_cast<int64_t>(s.triangle_materials.size());
  return n;
}

inline int CountFor(double length, double edge, int at_least) {
  return std::max(at_least, static_cast<int>(std::lround(length / edge)));
}

enum class GridEnds {
  kOpen,      // rows 0 and `rows` are rims, closed by caps elsewhere
  kPoles,     // rows 0 and `rows` collapse to one point each
  kPeriodic,  // row `rows` is row 0 again
};

// P(s, t), s in [0, 1) around, t in [0, 1]; column `cols` repeats column 0 with u = 1.
inline Surface GridSurface(int cols, int rows, GridEnds ends, const SurfaceFunction& at, int material) {
  Surface surface;
  std::vector<Vec3> ring(static_cast<size_t>(cols)), first_ring;
  for (int i = 0; i <= rows; ++i) {
    const double t = static_cast<double>(i) / rows;
    const bool pole = ends == GridEnds::kPoles && (i == 0 || i == rows);
    if (ends == GridEnds::kPeriodic && i == rows) {
      ring = first_ring;
    } else if (pole) {
      std::fill(ring.begin(), ring.end(), at(0, t));
    } else {
      for (int j = 0; j < cols; ++j) ring[static_cast<size_t>(j)] = at(static_cast<double>(j) / cols, t);
    }
    if (i == 0) first_ring = ring;
    const double u_offset = !pole ? 0.0 : i == 0 ? 0.5 : -0.5;
    for (int j = 0; j <= cols; ++j) {
      surface.AddVertex(ring[static_cast<size_t>(j % cols)], (j + u_offset) / cols, 1 - t);
    }
  }
  const auto index = [cols](int i, int j) { return static_cast<uint32_t>(i * (cols + 1) + j); };
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < cols; ++j) {
      const uint32_t a = index(i, j), b = index(i, j + 1), c = index(i + 1, j + 1), d = index(i + 1, j);
      if (ends == GridEnds::kPoles && i == 0) {
        surface.AddTriangle(a, c, d, material);
      } else if (ends == GridEnds::kPoles && i == rows - 1) {
        surface.AddTriangle(a, b, c, material);
      } else {
        surface.AddQuad(a, b, c, d, material);
      }
    }
  }
  return surface;
}

struct GridExtent {
  double ring_length = 0, meridian_length = 0;
};

inline GridExtent MeasureGrid(const SurfaceFunction& at) {
  constexpr int kAround = 48, kAlong = 24;
  GridExtent extent;
  for (int i = 0; i <= kAlong; ++i) {
    double length = 0;
    const double t = static_cast<double>(i) / kAlong;
    for (int j = 0; j < kAround; ++j) {
      length += Length(at(static_cast<double>(j + 1) / kAround, t) - at(static_cast<double>(j) / kAround, t));
    }
    extent.ring_length = std::max(extent.ring_length, length);
  }
  for (int j = 0; j < kAround; j += 4) {
    double length = 0;
    const double s = static_cast<double>(j) / kAround;
    for (int i = 0; i < kAlong; ++i) {
      length += Length(at(s, static_cast<double>(i + 1) / kAlong) - at(s, static_cast<double>(i) / kAlong));
    }
    extent.meridian_length = std::max(extent.meridian_length, length);
  }
  return extent;
}

// A flat cap over the planar rim at t = 0 or 1 of a sweep: concentric shrunken copies of
// the rim, which triangulate without folds for rims star-shaped about the rim's centre.
inline Surface Cap(const SurfaceFunction& at, int cols, int rings, bool top, int material) {
  Surface cap;
  std::vector<Vec3> rim(static_cast<size_t>(cols));
  Vec3 centre;
  for (int j = 0; j < cols; ++j) {
    rim[static_cast<size_t>(j)] = at(static_cast<double>(j) / cols, top ? 1.0 : 0.0);
    centre = centre + rim[static_cast<size_t>(j)] * (1.0 / cols);
  }
  double radius = 1e-9;
  for (const Vec3& r : rim) radius = std::max(radius, Length(r - centre));
  const auto add = [&](Vec3 p) {
    const Vec3 d = p - centre;
    return cap.AddVertex(p, 0.5 + d.x / (2 * radius), 0.5 + (d.z + d.y) / (2 * radius));
  };
  const uint32_t centre_index = add(centre);
  std::vector<uint32_t> inner, outer;
  for (int q = 1; q <= rings; ++q) {
    outer.clear();
    for (int j = 0; j < cols; ++j) {
      const Vec3& r = rim[static_cast<size_t>(j)];
      outer.push_back(add(q == rings ? r : centre + (r - centre) * (static_cast<double>(q) / rings)));
    }
    for (int j = 0; j < cols; ++j) {
      const uint32_t o0 = outer[static_cast<size_t>(j)], o1 = outer[static_cast<size_t>((j + 1) % cols)];
      if (q == 1) {
        top ? cap.AddTriangle(centre_index, o0, o1, material) : cap.AddTriangle(centre_index, o1, o0, material);
      } else {
        const uint32_t i0 = inner[static_cast<size_t>(j)], i1 = inner[static_cast<size_t>((j + 1) % cols)];
        top ? cap.AddQuad(i0, o0, o1, i1, material) : cap.AddQuad(i0, i1, o1, o0, material);
      }
    }
    std::swap(inner, outer);
  }
  return cap;
}

// The closed parts a model is made of. Each is built in its own frame, then rotated and
// moved; a part whose winding comes out inside-out (mirrored parts) is flipped.
enum class PartKind {
  kBox,         // half extents `size`, flat faces
  kRoundedBox,  // half extents `size`, superellipsoid with exponent `roundness` (0.1 boxy .. 1 ellipsoid)
  kCylinder,    // from `a` to `b`, radii size.x at a and size.y at b
  kLathe,       // `profile` (r, y) revolved about Y: from the axis back to the axis, or a loop off it
  kExtrusion,   // `outline(edge)` (x, y), counter-clockwise, from z = -depth to +depth
  kTube,        // a circle of radius size.x swept along `path`, flat ends
};

using Outline = std::function<std::vector<std::array<double, 2>>(double edge)>;

struct Part {
  PartKind kind = PartKind::kBox;
  int material = 0;
  Vec3 size;
  double roundness = 0.3;
  Vec3 a, b;
  std::vector<std::array<double, 2>> profile;
  Outline outline;
  double depth = 0;
  std::vector<Vec3> path;
  Rotation rotation;
  Vec3 offset;
};

inline Part BoxPart(Vec3 centre, Vec3 half, int material, Rotation rotation = {}) {
  Part p;
  p.kind = PartKind::kBox;
  p.size = half;
  p.offset = centre;
  p.rotation = rotation;
  p.material = material;
  return p;
}
inline Part RoundedBoxPart(Vec3 centre, Vec3 half, double roundness, int material, Rotation rotation = {}) {
  Part p = BoxPart(centre, half, material, rotation);
  p.kind = PartKind::kRoundedBox;
  p.roundness = roundness;
  return p;
}
inline Part CylinderPart(Vec3 a, Vec3 b, double r0, double r1, int material) {
  Part p;
  p.kind = PartKind::kCylinder;
  p.a = a;
  p.b = b;
  p.size = {r0, r1, 0};
  p.material = material;
  return p;
}
inline Part LathePart(std::vector<std::array<double, 2>> profile, Vec3 offset, int material, Rotation rotation = {}) {
  Part p;
  p.kind = PartKind::kLathe;
  p.profile = std::move(profile);
  p.offset = offset;
  p.rotation = rotation;
  p.material = material;
  return p;
}
inline Part ExtrusionPart(Outline outline, double depth, Vec3 offset, int material, Rotation rotation = {}) {
  Part p;
  p.kind = PartKind::kExtrusion;
  p.outline = std::move(outline);
  p.depth = depth;
  p.offset = offset;
  p.rotation = rotation;
  p.material = material;
  return p;
}
inline Part TubePart(std::vector<Vec3> path, double radius, int material) {
  Part p;
  p.kind = PartKind::kTube;
  p.path = std::move(path);
  p.size = {radius, 0, 0};
  p.material = material;
  return p;
}

// An outline of straight edges, whatever the edge length.
inline Outline Polygon(std::vector<std::array<double, 2>> points) {
  return [points = std::move(points)](double) { return points; };
}
Shape BuildPart(const Part& part, double edge);
// Signed volume of a closed shape: positive when its winding faces outwards.
double SignedVolume(const Shape& shape);

}  // namespace solid::convert::kit
