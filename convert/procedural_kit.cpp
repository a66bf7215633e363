#include "procedural_kit.h"

namespace solid::convert::kit {
namespace {

// sign(x) |x|^e, zero near zero so that poles land exactly on the axis.
double SignedPow(double x, double e) {
  if (std::abs(x) < 1e-12) return 0;
  return std::copysign(std::pow(std::abs(x), e), x);
}

// Box faces share their border points through integer lattice coordinates, so the six
// faces meet at bit-identical positions; each face is its own surface (flat normals).
Shape Box(Vec3 half, double edge, int material) {
  const std::array<int, 3> n = {CountFor(2 * half.x, edge, 1), CountFor(2 * half.y, edge, 1),
                                CountFor(2 * half.z, edge, 1)};
  const std::array<double, 3> h = {half.x, half.y, half.z};
  const auto point = [&](std::array<int, 3> lattice) {
    std::array<double, 3> p{};
    for (size_t a = 0; a < 3; ++a) p[a] = h[a] * (2.0 * lattice[a] / n[a] - 1);
    return Vec3{p[0], p[1], p[2]};
  };
  Shape shape;
  for (size_t axis = 0; axis < 3; ++axis) {
    const size_t ua = (axis + 1) % 3, va = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      Surface face;
      for (int j = 0; j <= n[va]; ++j) {
        for (int i = 0; i <= n[ua]; ++i) {
          std::array<int, 3> lattice{};
          lattice[axis] = side * n[axis];
          lattice[ua] = i;
          lattice[va] = j;
          // UVs in metres (textures repeat per metre, like the rooms').
          face.AddVertex(point(lattice), 2 * h[ua] * i / n[ua], 2 * h[va] * (1 - static_cast<double>(j) / n[va]));
        }
      }
      const auto index = [&](int i, int j) { return static_cast<uint32_t>(j * (n[ua] + 1) + i); };
      for (int j = 0; j < n[va]; ++j) {
        for (int i = 0; i < n[ua]; ++i) {
          const uint32_t a = index(i, j), b = index(i + 1, j), c = index(i + 1, j + 1), d = index(i, j + 1);
          side == 1 ? face.AddQuad(a, b, c, d, material) : face.AddQuad(a, d, c, b, material);
        }
      }
      shape.push_back(std::move(face));
    }
  }
  return shape;
}

Shape RoundedBox(Vec3 half, double e, double edge, int material) {
  const SurfaceFunction at = [=](double s, double t) {
    const double eta = kPi * (t - 0.5), omega = 2 * kPi * s;
    const double ring = SignedPow(std::cos(eta), e);
    return Vec3{half.x * ring * SignedPow(std::cos(omega), e), half.y * SignedPow(std::sin(eta), e),
                -half.z * ring * SignedPow(std::sin(omega), e)};
  };
  const GridExtent extent = MeasureGrid(at);
  return {GridSurface(CountFor(extent.ring_length, edge, 8), CountFor(extent.meridian_length, edge, 4),
                      GridEnds::kPoles, at, material)};
}

// A generalised cylinder along +Y from 0 to `length`: the side plus two flat caps.
Shape Sweep(const SurfaceFunction& at, double edge, int material) {
  const GridExtent extent = MeasureGrid(at);
  const int cols = CountFor(extent.ring_length, edge, 8);
  const int rows = CountFor(extent.meridian_length, edge, 1);
  const auto rim_radius = [&](double t) {
    const Vec3 c = at(0, t), o = at(0.5, t);
    return Length(c - o) / 2;
  };
  Shape shape;
  shape.push_back(GridSurface(cols, rows, GridEnds::kOpen, at, material));
  shape.push_back(Cap(at, cols, CountFor(rim_radius(0), edge, 1), false, material));
  shape.push_back(Cap(at, cols, CountFor(rim_radius(1), edge, 1), true, material));
  return shape;
}

// Points along a polyline (closed or not), with at most `edge` between consecutive ones;
// the given points are kept exactly (they are the profile's corners).
std::vector<std::array<double, 2>> Resample(const std::vector<std::array<double, 2>>& points, bool closed,
                                            double edge) {
  std::vector<std::array<double, 2>> out;
  const size_t n = points.size(), segments = closed ? n : n - 1;
  for (size_t k = 0; k < segments; ++k) {
    const auto& p = points[k];
    const auto& q = points[(k + 1) % n];
    const int steps = CountFor(std::hypot(q[0] - p[0], q[1] - p[1]), edge, 1);
    for (int i = 0; i < steps; ++i) {
      const double t = static_cast<double>(i) / steps;
      out.push_back({Lerp(p[0], q[0], t), Lerp(p[1], q[1], t)});
    }
  }
  if (!closed) out.push_back(points.back());
  return out;
}

Shape Lathe(const std::vector<std::array<double, 2>>& profile, double edge, int material) {
  const bool poles = profile.front()[0] == 0 && profile.back()[0] == 0;
  const std::vector<std::array<double, 2>> points = Resample(profile, !poles, edge);
  double r_max = 0;
  for (const auto& p : points) r_max = std::max(r_max, p[0]);
  const int cols = CountFor(2 * kPi * r_max, edge, 8);
  const int rows = static_cast<int>(poles ? points.size() - 1 : points.size());
  const SurfaceFunction at = [&](double s, double t) {
    const auto i = static_cast<size_t>(std::lround(t * rows)) % points.size();
    const auto [cx, cz] = AroundY(s);
    return Vec3{points[i][0] * cx, points[i][1], points[i][0] * cz};
  };
  return {GridSurface(cols, rows, poles ? GridEnds::kPoles : GridEnds::kPeriodic, at, material)};
}

double Cross2(std::array<double, 2> o, std::array<double, 2> a, std::array<double, 2> b) {
  return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

// Ear clipping of a simple counter-clockwise polygon; a vertex on an ear's border blocks
// it, so no T-junction can appear.
std::vector<std::array<uint32_t, 3>> Triangulate(const std::vector<std::array<double, 2>>& polygon) {
  std::vector<uint32_t> left(polygon.size());
  for (size_t i = 0; i < left.size(); ++i) left[i] = static_cast<uint32_t>(i);
  std::vector<std::array<uint32_t, 3>> triangles;
  while (left.size() > 3) {
    const size_t n = left.size();
    size_t best = n;
    double best_area = 0;
    for (size_t k = 0; k < n; ++k) {
      const auto &a = polygon[left[(k + n - 1) % n]], &b = polygon[left[k]], &c = polygon[left[(k + 1) % n]];
      const double area = Cross2(a, b, c);
      if (!(area > 1e-14)) continue;
      bool blocked = false;
      for (size_t m = 0; m < n && !blocked; ++m) {
        if (m == k || m == (k + 1) % n || m == (k + n - 1) % n) continue;
        const auto& p = polygon[left[m]];
        blocked = Cross2(a, b, p) >= 0 && Cross2(b, c, p) >= 0 && Cross2(c, a, p) >= 0;
      }
      if (blocked) continue;
      // Of the ears, the fattest: fewer slivers on curved outlines.
      if (best == n || area > best_area) {
        best = k;
        best_area = area;
      }
    }
    if (best == n) break;  // only for non-simple input; callers give simple polygons
    triangles.push_back({left[(best + n - 1) % n], left[best], left[(best + 1) % n]});
    left.erase(left.begin() + static_cast<std::ptrdiff_t>(best));
  }
  if (left.size() == 3) triangles.push_back({left[0], left[1], left[2]});
  return triangles;
}

Shape Extrusion(std::vector<std::array<double, 2>> outline, double depth, double edge, int material) {
  const size_t n = outline.size();
  double twice_area = 0;
  for (size_t k = 0; k < n; ++k) twice_area += Cross2({0, 0}, outline[k], outline[(k + 1) % n]);
  if (twice_area < 0) std::reverse(outline.begin(), outline.end());
  const int rows = CountFor(2 * depth, edge, 1);
  Surface side;
  double u = 0;
  std::vector<double> us;
  for (size_t k = 0; k <= n; ++k) {
    us.push_back(u);
    const auto& p = outline[k % n];
    const auto& q = outline[(k + 1) % n];
    u += std::hypot(q[0] - p[0], q[1] - p[1]);
  }
  for (int r = 0; r <= rows; ++r) {
    const double z = -depth + 2 * depth * r / rows;
    for (size_t k = 0; k <= n; ++k) side.AddVertex({outline[k % n][0], outline[k % n][1], z}, us[k], z + depth);
  }
  const auto index = [n](int r, size_t k) { return static_cast<uint32_t>(static_cast<size_t>(r) * (n + 1) + k); };
  for (int r = 0; r < rows; ++r) {
    for (size_t k = 0; k < n; ++k) {
      side.AddQuad(index(r, k), index(r, k + 1), index(r + 1, k + 1), index(r + 1, k), material);
    }
  }
  Shape shape{std::move(side)};
  const std::vector<std::array<uint32_t, 3>> triangles = Triangulate(outline);
  for (const double z : {-depth, depth}) {
    Surface cap;
    for (const auto& p : outline) cap.AddVertex({p[0], p[1], z}, p[0], p[1]);
    for (const auto& t : triangles) {
      z > 0 ? cap.AddTriangle(t[0], t[1], t[2], material) : cap.AddTriangle(t[0], t[2], t[1], material);
    }
    shape.push_back(std::move(cap));
  }
  return shape;
}

// Rings along the path in parallel-transported frames, so the tube never twists.
Shape Tube(const std::vector<Vec3>& control, double radius, double edge, int material) {
  std::vector<Vec3> path;
  for (size_t k = 0; k + 1 < control.size(); ++k) {
    const int steps = CountFor(Length(control[k + 1] - control[k]), edge, 1);
    for (int i = 0; i < steps; ++i) path.push_back(control[k] + (control[k + 1] - control[k]) * (static_cast<double>(i) / steps));
  }
  path.push_back(control.back());
  const size_t m = path.size();
  const int cols = CountFor(2 * kPi * radius, edge, 8);
  std::vector<Vec3> tangents(m), normals(m);
  for (size_t i = 0; i < m; ++i) tangents[i] = Normalized(path[std::min(i + 1, m - 1)] - path[i == 0 ? 0 : i - 1]);
  normals[0] = Normalized(Cross(tangents[0], std::fabs(tangents[0].y) < 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0}));
  for (size_t i = 1; i < m; ++i) normals[i] = Normalized(normals[i - 1] - tangents[i] * Dot(normals[i - 1], tangents[i]));
  Surface side;
  std::vector<std::vector<Vec3>> rings(m);
  for (size_t i = 0; i < m; ++i) {
    const Vec3 binormal = Cross(tangents[i], normals[i]);
    for (int j = 0; j < cols; ++j) {
      const double a = 2 * kPi * j / cols;
      rings[i].push_back(path[i] + (normals[i] * std::cos(a) + binormal * std::sin(a)) * radius);
    }
    for (int j = 0; j <= cols; ++j) side.AddVertex(rings[i][static_cast<size_t>(j % cols)], static_cast<double>(j) / cols, static_cast<double>(i) / static_cast<double>(m - 1));
  }
  const auto index = [cols](size_t i, int j) { return static_cast<uint32_t>(i * static_cast<size_t>(cols + 1) + static_cast<size_t>(j)); };
  for (size_t i = 0; i + 1 < m; ++i) {
    for (int j = 0; j < cols; ++j) side.AddQuad(index(i, j), index(i, j + 1), index(i + 1, j + 1), index(i + 1, j), material);
  }
  Shape shape{std::move(side)};
  for (const bool end : {false, true}) {
    const size_t i = end ? m - 1 : 0;
    Surface cap;
    const uint32_t centre = cap.AddVertex(path[i], 0.5, 0.5);
    for (int j = 0; j < cols; ++j) {
      const double a = 2 * kPi * j / cols;
      cap.AddVertex(rings[i][static_cast<size_t>(j)], 0.5 + 0.5 * std::cos(a), 0.5 + 0.5 * std::sin(a));
    }
    for (int j = 0; j < cols; ++j) {
      const auto r0 = static_cast<uint32_t>(1 + j), r1 = static_cast<uint32_t>(1 + (j + 1) % cols);
      end ? cap.AddTriangle(centre, r0, r1, material) : cap.AddTriangle(centre, r1, r0, material);
    }
    shape.push_back(std::move(cap));
  }
  return shape;
}

}  // namespace

double SignedVolume(const Shape& shape) {
  double six = 0;
  for (const Surface& s : shape) {
    for (size_t t = 0; t + 2 < s.indices.size(); t += 3) {
      six += Dot(s.positions[s.indices[t]], Cross(s.positions[s.indices[t + 1]], s.positions[s.indices[t + 2]]));
    }
  }
  return six / 6;
}

Shape BuildPart(const Part& part, double edge) {
  Shape shape;
  switch (part.kind) {
    case PartKind::kBox: shape = Box(part.size, edge, part.material); break;
    case PartKind::kRoundedBox: shape = RoundedBox(part.size, part.roundness, edge, part.material); break;
    case PartKind::kCylinder: {
      const double length = Length(part.b - part.a), r0 = part.size.x, r1 = part.size.y;
      shape = Sweep(
          [=](double s, double t) {
            const auto [cx, cz] = AroundY(s);
            const double r = Lerp(r0, r1, t);
            return Vec3{r * cx, length * t, r * cz};
          },
          edge, part.material);
      const Rotation to = YTo(part.b - part.a);
      for (Surface& s : shape) {
        for (Vec3& p : s.positions) p = to.Apply(p) + part.a;
      }
      break;
    }
    case PartKind::kLathe: shape = Lathe(part.profile, edge, part.material); break;
    case PartKind::kExtrusion: shape = Extrusion(part.outline(edge), part.depth, edge, part.material); break;
    case PartKind::kTube: shape = Tube(part.path, part.size.x, edge, part.material); break;
  }
  for (Surface& s : shape) {
    for (Vec3& p : s.positions) p = part.rotation.Apply(p) + part.offset;
  }
  if (SignedVolume(shape) < 0) {
    for (Surface& s : shape) {
      for (size_t t = 0; t + 2 < s.indices.size(); t += 3) std::swap(s.indices[t + 1], s.indices[t + 2]);
    }
  }
  return shape;
}

}  // namespace solid::convert::kit
