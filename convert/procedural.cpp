#include "solid/convert/procedural.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "solid/formats/image_codec.h"
#include "solid/formats/random.h"

namespace solid::convert {
// The asset model and its glb codec live in formats (render reads them too).
using namespace solid::gltf;
namespace {

constexpr double kPi = std::numbers::pi;

// ---------------------------------------------------------------------------------------
// Randomness: solid/formats/random.h. Separate streams, so that a change to how
// materials are drawn never changes geometry.
enum Stream : uint64_t {
  kShapeGeometryStream = 1,
  kShapeMaterialStream = 2,
  kRoomGeometryStream = 3,
  kRoomMaterialStream = 4,
};

// ---------------------------------------------------------------------------------------
// Geometry helpers. Everything is built in double and converted to float once, at the end.

struct Vec3 {
  double x = 0, y = 0, z = 0;
};
Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 operator*(Vec3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
double Dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 Cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double Length(Vec3 a) { return std::sqrt(Dot(a, a)); }

double Lerp(double a, double b, double t) { return a + (b - a) * t; }
double SmoothStep(double t) { return t * t * (3 - 2 * t); }
double Fract(double x) { return x - std::floor(x); }

// Rotation as a matrix from a random unit quaternion (Shoemake's uniform method).
struct Rotation {
  std::array<Vec3, 3> rows = {Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}};
  Vec3 Apply(Vec3 v) const { return {Dot(rows[0], v), Dot(rows[1], v), Dot(rows[2], v)}; }
};

Rotation RandomRotation(Rng& rng) {
  const double u1 = rng.Uniform(), u2 = rng.Uniform(), u3 = rng.Uniform();
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  const double w = a * std::sin(2 * kPi * u2), x = a * std::cos(2 * kPi * u2);
  const double y = b * std::sin(2 * kPi * u3), z = b * std::cos(2 * kPi * u3);
  Rotation r;
  r.rows[0] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)};
  r.rows[1] = {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)};
  r.rows[2] = {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
  return r;
}

// Direction in the xz plane at fraction s of a turn about +Y. It turns clockwise seen from
// above, which makes dP/ds x dP/dt point outwards for surfaces whose t runs upwards.
std::pair<double, double> AroundY(double s) { return {std::cos(2 * kPi * s), -std::sin(2 * kPi * s)}; }

// A smoothing group: vertex normals are averaged over the triangles that touch the same
// position within one surface and never across surfaces, so a cap stays flat next to a
// smooth side. Seam and pole vertices are duplicated (for their UVs) at bit-identical
// positions, which is what makes them weld here and in closedness checks.
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
  // Counter-clockwise seen from the side the normal points to.
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
using MaterialFunction = std::function<int(double s, double t)>;

int64_t CountTriangles(const Shape& shape) {
  int64_t n = 0;
  for (const Surface& s : shape) n += static_cast<int64_t>(s.triangle_materials.size());
  return n;
}

enum class GridEnds {
  kOpen,      // rows 0 and `rows` are rims (closed by caps elsewhere)
  kPoles,     // rows 0 and `rows` collapse to one point each (spheres)
  kPeriodic,  // row `rows` is row 0 again (tori)
};

// A surface P(s, t), s in [0, 1) around, t in [0, 1] from bottom to top, with outward
// normal dP/ds x dP/dt. Column `cols` repeats column 0's positions with u = 1 so the texture
// needs no wrap-around; UV v = 1 - t puts the top of the texture at the top of the shape.
Surface GridSurface(int cols, int rows, GridEnds ends, const SurfaceFunction& at,
                    const MaterialFunction& material_at) {
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
    // A pole vertex serves one triangle (the one to its right at the bottom, to its left
    // at the top), so its u is that triangle's middle.
    const double u_offset = !pole ? 0.0 : i == 0 ? 0.5 : -0.5;
    for (int j = 0; j <= cols; ++j) {
      surface.AddVertex(ring[static_cast<size_t>(j % cols)], (j + u_offset) / cols, 1 - t);
    }
  }
  const auto index = [cols](int i, int j) { return static_cast<uint32_t>(i * (cols + 1) + j); };
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < cols; ++j) {
      const int material = material_at((j + 0.5) / cols, (i + 0.5) / rows);
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

// The longest ring (constant t) and the longest meridian (constant s) of a surface,
// sampled; they turn a target edge length into a column and a row count.
struct GridExtent {
  double ring_length = 0, meridian_length = 0;
};

GridExtent MeasureGrid(const SurfaceFunction& at) {
  constexpr int kAround = 64, kAlong = 32;
  GridExtent extent;
  for (int i = 0; i <= kAlong; ++i) {
    double length = 0;
    for (int j = 0; j < kAround; ++j) {
      const double t = static_cast<double>(i) / kAlong;
      length += Length(at(static_cast<double>(j + 1) / kAround, t) - at(static_cast<double>(j) / kAround, t));
    }
    extent.ring_length = std::max(extent.ring_length, length);
  }
  for (int j = 0; j < kAround; j += 4) {
    double length = 0;
    for (int i = 0; i < kAlong; ++i) {
      const double s = static_cast<double>(j) / kAround;
      length += Length(at(s, static_cast<double>(i + 1) / kAlong) - at(s, static_cast<double>(i) / kAlong));
    }
    extent.meridian_length = std::max(extent.meridian_length, length);
  }
  return extent;
}

int CountFor(double length, double edge, int at_least) {
  return std::max(at_least, static_cast<int>(std::lround(length / edge)));
}

Surface ClosedGrid(const SurfaceFunction& at, GridEnds ends, double edge, const MaterialFunction& material_at) {
  const GridExtent extent = MeasureGrid(at);
  const int cols = CountFor(extent.ring_length, edge, 8);
  const int rows = CountFor(extent.meridian_length, edge, ends == GridEnds::kPoles ? 4 : 3);
  return GridSurface(cols, rows, ends, at, material_at);
}

// A flat cap closing the rim of a sweep at t = 0 or 1: concentric copies of the rim
// shrunk towards the axis, so any rim that is star-shaped about the axis triangulates
// without folds. The outermost ring reuses the rim's positions exactly (watertight).
Surface Cap(const SurfaceFunction& at, int cols, int rings, bool top, int material) {
  Surface cap;
  std::vector<Vec3> rim(static_cast<size_t>(cols));
  double radius = 0;
  for (int j = 0; j < cols; ++j) {
    rim[static_cast<size_t>(j)] = at(static_cast<double>(j) / cols, top ? 1.0 : 0.0);
    radius = std::max(radius, std::hypot(rim[static_cast<size_t>(j)].x, rim[static_cast<size_t>(j)].z));
  }
  const Vec3 centre{0, rim[0].y, 0};
  const auto planar_uv = [radius](Vec3 p) {
    return std::array<double, 2>{0.5 + p.x / (2 * radius), 0.5 + p.z / (2 * radius)};
  };
  const auto add = [&](Vec3 p) {
    const auto uv = planar_uv(p);
    return cap.AddVertex(p, uv[0], uv[1]);
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

// A generalised cylinder: the open grid P(s, t) plus flat caps at both ends. Each ring
// must be planar (constant y) and star-shaped about the Y axis.
Shape Sweep(const SurfaceFunction& at, double edge, int side_material, int cap_material) {
  const GridExtent extent = MeasureGrid(at);
  const int cols = CountFor(extent.ring_length, edge, 8);
  const int rows = CountFor(extent.meridian_length, edge, 1);
  const auto rim_radius = [&](double t) {
    double r = 0;
    for (int j = 0; j < 64; ++j) {
      const Vec3 p = at(j / 64.0, t);
      r = std::max(r, std::hypot(p.x, p.z));
    }
    return r;
  };
  Shape shape;
  shape.push_back(GridSurface(cols, rows, GridEnds::kOpen, at, [=](double, double) { return side_material; }));
  shape.push_back(Cap(at, cols, CountFor(rim_radius(0), edge, 1), false, cap_material));
  shape.push_back(Cap(at, cols, CountFor(rim_radius(1), edge, 1), true, cap_material));
  return shape;
}

// ---------------------------------------------------------------------------------------
// Noise. Value noise on a hashed integer lattice: cheap, seedable, and the same bits
// everywhere because it only uses floor, multiplies and adds.

double LatticeValue(uint64_t seed, int64_t x, int64_t y, int64_t z) {
  const uint64_t h = MixSeed(MixSeed(MixSeed(seed, static_cast<uint64_t>(x)), static_cast<uint64_t>(y)),
                          static_cast<uint64_t>(z));
  return static_cast<double>(h >> 11) * 0x1p-52 - 1.0;  // [-1, 1)
}

double Fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }

double ValueNoise3(uint64_t seed, Vec3 p) {
  const double fx = std::floor(p.x), fy = std::floor(p.y), fz = std::floor(p.z);
  const auto x0 = static_cast<int64_t>(fx), y0 = static_cast<int64_t>(fy), z0 = static_cast<int64_t>(fz);
  const double tx = Fade(p.x - fx), ty = Fade(p.y - fy), tz = Fade(p.z - fz);
  double corner[2][2];
  for (int dz = 0; dz < 2; ++dz) {
    for (int dy = 0; dy < 2; ++dy) {
      corner[dz][dy] = Lerp(LatticeValue(seed, x0, y0 + dy, z0 + dz), LatticeValue(seed, x0 + 1, y0 + dy, z0 + dz), tx);
    }
  }
  return Lerp(Lerp(corner[0][0], corner[0][1], ty), Lerp(corner[1][0], corner[1][1], ty), tz);
}

// Periodic in x with period_x lattice cells and in y with period_y, so a texture that
// samples one period tiles seamlessly.
double TileableNoise2(uint64_t seed, double x, double y, int period_x, int period_y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto wrap = [](int64_t i, int period) { return ((i % period) + period) % period; };
  const auto x0 = static_cast<int64_t>(fx), y0 = static_cast<int64_t>(fy);
  const double tx = Fade(x - fx), ty = Fade(y - fy);
  const auto value = [&](int64_t i, int64_t j) { return LatticeValue(seed, wrap(i, period_x), wrap(j, period_y), 0); };
  return Lerp(Lerp(value(x0, y0), value(x0 + 1, y0), tx), Lerp(value(x0, y0 + 1), value(x0 + 1, y0 + 1), tx), ty);
}

// Fractal sum of tileable octaves over u, v in [0, 1]; each octave doubles the periods,
// which keeps it tileable. Roughly in [-1, 1].
double TileableFbm(uint64_t seed, double u, double v, int period_x, int period_y, int octaves) {
  double sum = 0, amplitude = 0.5, norm = 0;
  for (int o = 0; o < octaves; ++o) {
    const int px = period_x << o, py = period_y << o;
    sum += amplitude * TileableNoise2(MixSeed(seed, static_cast<uint64_t>(o)), u * px, v * py, px, py);
    norm += amplitude;
    amplitude *= 0.5;
  }
  return sum / norm;
}

// ---------------------------------------------------------------------------------------
// Shape families. Each draws its parameters once and returns a function from a target
// edge length to a tessellation, so the triangle budget can be met by adjusting the edge.

using Tessellator = std::function<Shape(double edge)>;

MaterialFunction SingleMaterial() {
  return [](double, double) { return 0; };
}

// With two materials, a band of the surface (in t, or in s for variety) gets the second.
MaterialFunction BandMaterial(Rng& rng, int material_count) {
  if (material_count == 1) return SingleMaterial();
  const bool along_t = rng.Chance(0.6);
  const double lo = rng.Uniform(0.1, 0.6), hi = lo + rng.Uniform(0.15, 0.35);
  return [=](double s, double t) {
    const double x = along_t ? t : s;
    return (x >= lo && x < hi) ? 1 : 0;
  };
}

// sign(x) |x|^e, zero near zero so that poles land exactly on the axis.
double SignedPow(double x, double e) {
  if (std::abs(x) < 1e-12) return 0;
  return std::copysign(std::pow(std::abs(x), e), x);
}

Tessellator Superquadric(Rng& rng, int material_count) {
  const Vec3 axes{rng.Uniform(0.4, 1), rng.Uniform(0.4, 1), rng.Uniform(0.4, 1)};
  const double e1 = rng.Uniform(0.2, 3), e2 = rng.Uniform(0.2, 3);
  const MaterialFunction material_at = BandMaterial(rng, material_count);
  const SurfaceFunction at = [=](double s, double t) {
    const double eta = kPi * (t - 0.5), omega = 2 * kPi * s;
    const double ring = SignedPow(std::cos(eta), e1);
    return Vec3{axes.x * ring * SignedPow(std::cos(omega), e2), axes.y * SignedPow(std::sin(eta), e1),
                -axes.z * ring * SignedPow(std::sin(omega), e2)};
  };
  return [=](double edge) { return Shape{ClosedGrid(at, GridEnds::kPoles, edge, material_at)}; };
}

Tessellator NoisySphere(Rng& rng, int material_count) {
  const Vec3 axes{rng.Uniform(0.7, 1), rng.Uniform(0.7, 1), rng.Uniform(0.7, 1)};
  const int octaves = rng.Int(2, 4);
  const double frequency = rng.Uniform(0.8, 2.5), amplitude = rng.Uniform(0.12, 0.35);
  const uint64_t noise_seed = rng.Seed();
  const MaterialFunction material_at = BandMaterial(rng, material_count);
  const SurfaceFunction at = [=](double s, double t) {
    const double eta = kPi * (t - 0.5);
    const auto [cx, cz] = AroundY(s);
    const Vec3 direction{std::cos(eta) * cx, std::sin(eta), std::cos(eta) * cz};
    double radius = 1, f = frequency, a = amplitude;
    for (int o = 0; o < octaves; ++o) {
      radius += a * ValueNoise3(MixSeed(noise_seed, static_cast<uint64_t>(o)), direction * f);
      f *= 2.0;
      a *= 0.5;
    }
    // Keeps the surface star-shaped about the centre, hence free of self-intersections.
    radius = std::max(radius, 0.3);
    return Vec3{axes.x * direction.x * radius, axes.y * direction.y * radius, axes.z * direction.z * radius};
  };
  return [=](double edge) { return Shape{ClosedGrid(at, GridEnds::kPoles, edge, material_at)}; };
}

// An outline radius r(angle) > 0: a few random harmonics (a blob) or rounded lobes (a star).
std::function<double(double)> RandomOutline(Rng& rng) {
  if (rng.Chance(0.5)) {
    std::array<double, 4> amplitude{}, phase{};
    for (size_t k = 0; k < amplitude.size(); ++k) {
      amplitude[k] = rng.Uniform(0, 0.35 / std::sqrt(static_cast<double>(k + 2)));
      phase[k] = rng.Uniform(0, 2 * kPi);
    }
    return [=](double angle) {
      double r = 1;
      for (size_t k = 0; k < amplitude.size(); ++k) r += amplitude[k] * std::cos(static_cast<double>(k + 2) * angle + phase[k]);
      return std::max(r, 0.25);
    };
  }
  const int lobes = rng.Int(3, 8);
  const double inner = rng.Uniform(0.35, 0.75), sharpness = rng.Uniform(1, 4);
  return [=](double angle) {
    return inner + (1 - inner) * std::pow(0.5 + 0.5 * std::cos(lobes * angle), sharpness);
  };
}

Tessellator Extrusion(Rng& rng, int material_count) {
  const std::function<double(double)> outline = RandomOutline(rng);
  const double stretch_x = rng.Uniform(0.6, 1), stretch_z = rng.Uniform(0.6, 1);
  const double height = rng.Uniform(0.15, 1.4);
  const double taper = rng.Chance(0.4) ? rng.Uniform(0, 0.5) : 0.0;
  const double twist = rng.Chance(0.3) ? rng.Uniform(-0.9, 0.9) : 0.0;
  const int cap_material = material_count - 1;
  const SurfaceFunction at = [=](double s, double t) {
    const auto [cx, cz] = AroundY(s);
    const double r = outline(2 * kPi * s) * (1 - taper * t);
    const double x = r * cx * stretch_x, z = r * cz * stretch_z;
    const double c = std::cos(twist * t), sn = std::sin(twist * t);
    return Vec3{c * x - sn * z, height * (t - 0.5), sn * x + c * z};
  };
  return [=](double edge) { return Sweep(at, edge, 0, cap_material); };
}

// Catmull-Rom through random radii: a smooth profile (vases, bottles, lamp bases).
Tessellator Revolution(Rng& rng, int material_count) {
  const int control_count = rng.Int(4, 7);
  std::vector<double> radii(static_cast<size_t>(control_count));
  for (double& r : radii) r = rng.Uniform(0.2, 1);
  const double height = rng.Uniform(0.8, 2.4);
  const int cap_material = material_count - 1;
  const auto profile = [radii](double t) {
    const double x = t * static_cast<double>(radii.size() - 1);
    const auto i = std::min(static_cast<int64_t>(x), static_cast<int64_t>(radii.size()) - 2);
    const double f = x - static_cast<double>(i);
    const auto r = [&](int64_t k) { return radii[static_cast<size_t>(std::clamp<int64_t>(k, 0, static_cast<int64_t>(radii.size()) - 1))]; };
    const double p0 = r(i - 1), p1 = r(i), p2 = r(i + 1), p3 = r(i + 2);
    const double value = 0.5 * (2 * p1 + (p2 - p0) * f + (2 * p0 - 5 * p1 + 4 * p2 - p3) * f * f +
                                (3 * p1 - p0 - 3 * p2 + p3) * f * f * f);
    return std::max(value, 0.08);
  };
  const SurfaceFunction at = [=](double s, double t) {
    const auto [cx, cz] = AroundY(s);
    const double r = profile(t);
    return Vec3{r * cx, height * (t - 0.5), r * cz};
  };
  return [=](double edge) { return Sweep(at, edge, 0, cap_material); };
}

Tessellator Torus(Rng& rng, int material_count) {
  const double major = 1;
  const double tube_radial = rng.Uniform(0.12, 0.6), tube_vertical = tube_radial * rng.Uniform(0.5, 1.8);
  const MaterialFunction material_at = BandMaterial(rng, material_count);
  const SurfaceFunction at = [=](double s, double t) {
    const auto [cx, cz] = AroundY(s);
    const double psi = 2 * kPi * t;
    const double ring = major + tube_radial * std::cos(psi);
    return Vec3{ring * cx, tube_vertical * std::sin(psi), ring * cz};
  };
  return [=](double edge) { return Shape{ClosedGrid(at, GridEnds::kPeriodic, edge, material_at)}; };
}

// Box faces share their border points through integer lattice coordinates, so the six
// faces meet at bit-identical positions; each face is its own surface (flat normals).
Shape Box(Vec3 half, double edge, int material) {
  const std::array<int, 3> n = {CountFor(2 * half.x, edge, 1), CountFor(2 * half.y, edge, 1), CountFor(2 * half.z, edge, 1)};
  const std::array<double, 3> h = {half.x, half.y, half.z};
  const auto point = [&](std::array<int, 3> lattice) {
    std::array<double, 3> p{};
    for (size_t a = 0; a < 3; ++a) p[a] = h[a] * (2.0 * lattice[a] / n[a] - 1);
    return Vec3{p[0], p[1], p[2]};
  };
  Shape shape;
  for (size_t axis = 0; axis < 3; ++axis) {
    // (axis + 1, axis + 2) is a right-handed frame with the face normal +axis.
    const size_t ua = (axis + 1) % 3, va = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      Surface face;
      for (int j = 0; j <= n[va]; ++j) {
        for (int i = 0; i <= n[ua]; ++i) {
          std::array<int, 3> lattice{};
          lattice[axis] = side * n[axis];
          lattice[ua] = i;
          lattice[va] = j;
          face.AddVertex(point(lattice), static_cast<double>(i) / n[ua], 1 - static_cast<double>(j) / n[va]);
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

Tessellator Union(Rng& rng, int material_count) {
  enum class Kind { kBox, kCylinder, kSphere };
  struct Part {
    Kind kind;
    Vec3 size;  // box half extents; cylinder (radius, half height, -); sphere radii
    Rotation rotation;
    Vec3 offset;
    int material;
  };
  std::vector<Part> parts(static_cast<size_t>(rng.Int(2, 5)));
  for (Part& part : parts) {
    part.kind = static_cast<Kind>(rng.Int(0, 2));
    switch (part.kind) {
      case Kind::kBox: part.size = {rng.Uniform(0.08, 0.45), rng.Uniform(0.08, 0.45), rng.Uniform(0.08, 0.45)}; break;
      case Kind::kCylinder: part.size = {rng.Uniform(0.06, 0.3), rng.Uniform(0.1, 0.45), 0}; break;
      case Kind::kSphere: {
        const double r = rng.Uniform(0.1, 0.35);
        part.size = {r, r * rng.Uniform(0.7, 1.3), r};
        break;
      }
    }
    if (rng.Chance(0.6)) part.rotation = RandomRotation(rng);
    // Within a small cube, so that the parts overlap and read as one object.
    part.offset = {rng.Uniform(-0.3, 0.3), rng.Uniform(-0.3, 0.3), rng.Uniform(-0.3, 0.3)};
    part.material = material_count == 2 ? rng.Int(0, 1) : 0;
  }
  return [=](double edge) {
    Shape shape;
    for (const Part& part : parts) {
      Shape piece;
      switch (part.kind) {
        case Kind::kBox: piece = Box(part.size, edge, part.material); break;
        case Kind::kCylinder: {
          const Vec3 size = part.size;
          piece = Sweep([size](double s, double t) {
                          const auto [cx, cz] = AroundY(s);
                          return Vec3{size.x * cx, size.y * (2 * t - 1), size.x * cz};
                        },
                        edge, part.material, part.material);
          break;
        }
        case Kind::kSphere: {
          const Vec3 size = part.size;
          const int material = part.material;
          piece = {ClosedGrid([size](double s, double t) {
                                const double eta = kPi * (t - 0.5);
                                const auto [cx, cz] = AroundY(s);
                                return Vec3{size.x * std::cos(eta) * cx, size.y * std::sin(eta), size.z * std::cos(eta) * cz};
                              },
                              GridEnds::kPoles, edge, [material](double, double) { return material; })};
          break;
        }
      }
      for (Surface& surface : piece) {
        for (Vec3& p : surface.positions) p = part.rotation.Apply(p) + part.offset;
        shape.push_back(std::move(surface));
      }
    }
    return shape;
  };
}

// Shrinks or grows the edge length until the triangle count lands in [min, max];
// triangles scale as 1 / edge^2, and a few rounds absorb the rounding of counts.
Result<Shape> TessellateWithin(const Tessellator& tessellate, int min_triangles, int max_triangles, double goal) {
  double edge = 0.1;
  for (int round = 0; round < 12; ++round) {
    Shape shape = tessellate(edge);
    const int64_t count = CountTriangles(shape);
    if (count >= min_triangles && count <= max_triangles) return shape;
    edge *= std::sqrt(static_cast<double>(count) / goal);
  }
  return InvalidArgumentError(fmt::format("cannot tessellate within [{}, {}] triangles", min_triangles, max_triangles));
}

// ---------------------------------------------------------------------------------------
// Textures. Colours are drawn in sRGB (what the PNG stores); every pattern tiles.

struct Rgb {
  double r = 0, g = 0, b = 0;
};
Rgb Mix(Rgb a, Rgb b, double t) { return {Lerp(a.r, b.r, t), Lerp(a.g, b.g, t), Lerp(a.b, b.b, t)}; }
Rgb Scale(Rgb a, double s) { return {a.r * s, a.g * s, a.b * s}; }

Rgb Hsv(double h, double s, double v) {
  h = Fract(h) * 6;
  const int sector = static_cast<int>(h);
  const double f = h - sector, p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  switch (sector) {
    case 0: return {v, t, p};
    case 1: return {q, v, p};
    case 2: return {p, v, t};
    case 3: return {p, q, v};
    case 4: return {t, p, v};
    default: return {v, p, q};
  }
}

struct Range {
  double lo = 0, hi = 0;
};

// Draws hue, saturation and value in that order. Function arguments are evaluated in an
// unspecified order, so no argument list here ever holds two draws.
Rgb RandomHsv(Rng& rng, Range hue, Range saturation, Range value) {
  const double h = rng.Uniform(hue.lo, hue.hi);
  const double s = rng.Uniform(saturation.lo, saturation.hi);
  const double v = rng.Uniform(value.lo, value.hi);
  return Hsv(h, s, v);
}

uint8_t ToByte(double x) { return static_cast<uint8_t>(std::lround(std::clamp(x, 0.0, 1.0) * 255)); }

using Pattern = std::function<Rgb(double u, double v)>;

Result<std::vector<uint8_t>> RenderPng(const Pattern& pattern, int size) {
  Image8 image{static_cast<uint32_t>(size), static_cast<uint32_t>(size), 3,
               std::vector<uint8_t>(static_cast<size_t>(size) * static_cast<size_t>(size) * 3)};
  size_t k = 0;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const Rgb c = pattern((x + 0.5) / size, (y + 0.5) / size);
      image.pixels[k++] = ToByte(c.r);
      image.pixels[k++] = ToByte(c.g);
      image.pixels[k++] = ToByte(c.b);
    }
  }
  return EncodeImage(image, ImageFormat::kPng);
}

Status AddTexturedMaterial(Asset& asset, const std::string& name, const Pattern& pattern, int texture_size,
                           double roughness) {
  SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> png, RenderPng(pattern, texture_size));
  asset.textures.push_back({name + ".png", "image/png", std::move(png)});
  Material material;
  material.name = name;
  material.roughness = static_cast<float>(roughness);
  material.base_color_texture = static_cast<uint32_t>(asset.textures.size() - 1);
  asset.materials.push_back(std::move(material));
  return Status::Ok();
}

// Two related colours: complementary, analogous or the same hue at another value.
std::pair<Rgb, Rgb> RandomColourPair(Rng& rng) {
  const double h = rng.Uniform(), s = rng.Uniform(0.15, 0.9), v = rng.Uniform(0.25, 0.95);
  const Rgb first = Hsv(h, s, v);
  switch (rng.Int(0, 2)) {
    case 0: return {first, RandomHsv(rng, {h + 0.5, h + 0.5}, {0.1, 0.9}, {0.25, 0.95})};
    case 1: {
      const double hue_shift = rng.Uniform(-0.1, 0.1);
      const double value_shift = rng.Uniform(-0.4, 0.4);
      return {first, Hsv(h + hue_shift, s, std::clamp(v + value_shift, 0.1, 1.0))};
    }
    default: return {first, Hsv(h, s * rng.Uniform(0.3, 1), v < 0.6 ? v + 0.35 : v - 0.35)};
  }
}

Pattern RandomShapePattern(Rng& rng) {
  const auto [a, b] = RandomColourPair(rng);
  const uint64_t noise_seed = rng.Seed();
  const double grain = rng.Uniform(0.02, 0.08);
  const auto grained = [=](Rgb c, double u, double v) {
    return Scale(c, 1 + grain * TileableFbm(noise_seed, u, v, 16, 16, 2));
  };
  switch (rng.Int(0, 3)) {
    case 0: {
      const int cells = 2 * rng.Int(1, 8);
      return [=](double u, double v) {
        const bool odd = ((static_cast<int>(u * cells) + static_cast<int>(v * cells)) & 1) != 0;
        return grained(odd ? a : b, u, v);
      };
    }
    case 1: {
      const int stripes = rng.Int(3, 16);
      const int direction = rng.Int(0, 3);
      const double duty = rng.Uniform(0.25, 0.75);
      return [=](double u, double v) {
        const double w = direction == 0 ? u : direction == 1 ? v : direction == 2 ? u + v : u - v;
        return grained(Fract(w * stripes) < duty ? a : b, u, v);
      };
    }
    case 2: {
      const int period = rng.Int(2, 8);
      const double contrast = rng.Uniform(2, 6);
      return [=](double u, double v) {
        const double n = TileableFbm(noise_seed, u, v, period, period, 4);
        return Mix(a, b, SmoothStep(std::clamp(0.5 + contrast * 0.5 * n, 0.0, 1.0)));
      };
    }
    default:
      return [=](double u, double v) { return grained(a, u, v); };
  }
}

// ---------------------------------------------------------------------------------------
// Output: normals, recentring to the bounding-box centre, scaling to a largest extent of
// 1, and one primitive per material.

// Normals per triangle corner: the area-weighted normals of the triangles around the
// corner's position, leaving out those turned more than 60 degrees from the corner's own
// triangle. Creases (box-like superquadrics, pinched tips, star lobes) thus stay sharp,
// and every normal agrees with the winding of its triangle.
std::vector<Vec3> CornerNormals(const Surface& surface) {
  constexpr double kCosCreaseAngle = 0.5;
  const auto key = [](Vec3 p) { return std::array<double, 3>{p.x, p.y, p.z}; };
  std::vector<Vec3> faces;
  std::map<std::array<double, 3>, std::vector<size_t>> faces_at;
  for (size_t t = 0; t < surface.indices.size() / 3; ++t) {
    const Vec3 a = surface.positions[surface.indices[3 * t]], b = surface.positions[surface.indices[3 * t + 1]],
               c = surface.positions[surface.indices[3 * t + 2]];
    faces.push_back(Cross(b - a, c - a));
    for (const Vec3& p : {a, b, c}) faces_at[key(p)].push_back(t);
  }
  std::vector<Vec3> normals;
  normals.reserve(surface.indices.size());
  for (size_t t = 0; t < faces.size(); ++t) {
    const Vec3 own = faces[t];
    for (size_t k = 0; k < 3; ++k) {
      Vec3 sum;
      for (const size_t f : faces_at[key(surface.positions[surface.indices[3 * t + k]])]) {
        if (Dot(faces[f], own) > kCosCreaseAngle * Length(faces[f]) * Length(own)) sum = sum + faces[f];
      }
      const double length = Length(sum);
      // Only a zero-area triangle has no direction to agree with; +Y beats a NaN.
      normals.push_back(length > 0 ? sum * (1 / length) : Vec3{0, 1, 0});
    }
  }
  return normals;
}

Node ShapeNode(const Shape& shape, const std::string& key, int material_count) {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Surface& s : shape) {
    for (const Vec3& p : s.positions) {
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
  }
  const Vec3 centre = (lo + hi) * 0.5;
  const double scale = 1 / std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});

  std::vector<std::vector<Vec3>> surface_normals;
  for (const Surface& s : shape) surface_normals.push_back(CornerNormals(s));

  Node node;
  node.name = key;
  for (int m = 0; m < material_count; ++m) {
    Primitive primitive;
    primitive.material = static_cast<uint32_t>(m);
    for (size_t si = 0; si < shape.size(); ++si) {
      const Surface& s = shape[si];
      const std::vector<Vec3>& normals = surface_normals[si];
      // A vertex splits where its corners' normals differ (at creases).
      std::map<std::pair<uint32_t, std::array<double, 3>>, uint32_t> output_vertex;
      for (size_t t = 0; t < s.triangle_materials.size(); ++t) {
        if (s.triangle_materials[t] != m) continue;
        for (size_t k = 0; k < 3; ++k) {
          const uint32_t v = s.indices[3 * t + k];
          const Vec3 n = normals[3 * t + k];
          const auto [it, fresh] = output_vertex.try_emplace({v, {n.x, n.y, n.z}},
                                                             static_cast<uint32_t>(primitive.positions.size() / 3));
          if (fresh) {
            const Vec3 p = (s.positions[v] - centre) * scale;
            primitive.positions.insert(primitive.positions.end(),
                                       {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)});
            primitive.normals.insert(primitive.normals.end(),
                                     {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)});
            primitive.uvs.insert(primitive.uvs.end(), {static_cast<float>(s.uvs[v][0]), static_cast<float>(s.uvs[v][1])});
          }
          primitive.indices.push_back(it->second);
        }
      }
    }
    if (!primitive.indices.empty()) node.primitives.push_back(std::move(primitive));
  }
  return node;
}

std::string SeedHex(uint64_t seed) { return fmt::format("{:#018x}", seed); }

// ---------------------------------------------------------------------------------------
// Rooms.

// Grid lines along one axis: the plan's key coordinates, each interval split into steps of
// at most about a metre. Floor, walls and ceiling all use these same doubles, so they meet
// without T-junctions or cracks.
std::vector<double> GridLines(const std::vector<double>& keys) {
  std::vector<double> lines;
  for (size_t k = 0; k + 1 < keys.size(); ++k) {
    const int steps = std::max(1, static_cast<int>(std::ceil(keys[k + 1] - keys[k] - 1e-9)));
    for (int i = 0; i < steps; ++i) lines.push_back(Lerp(keys[k], keys[k + 1], static_cast<double>(i) / steps));
  }
  lines.push_back(keys.back());
  return lines;
}

double RoundToCentimetre(double metres) { return std::round(metres * 100) / 100; }

struct RoomPlan {
  double width = 0, depth = 0, height = 0;  // bounding box, metres
  bool l_shaped = false;
  std::vector<double> x_lines, y_lines, z_lines;
  std::function<bool(double x, double z)> inside;  // for cell centres
};

RoomPlan RandomPlan(Rng& rng) {
  RoomPlan plan;
  plan.width = RoundToCentimetre(rng.Uniform(4, 16));
  plan.depth = RoundToCentimetre(rng.Uniform(4, 16));
  plan.height = RoundToCentimetre(rng.Uniform(2.5, 4));
  plan.l_shaped = rng.Chance(0.5);
  std::vector<double> x_keys = {-plan.width / 2, plan.width / 2}, z_keys = {-plan.depth / 2, plan.depth / 2};
  if (plan.l_shaped) {
    // The removed corner's inner edge: 35-60% of the way across from that corner.
    const int corner = rng.Int(0, 3);
    const double sx = corner & 1 ? 1.0 : -1.0, sz = corner & 2 ? 1.0 : -1.0;
    const double notch_x = RoundToCentimetre(sx * (plan.width / 2 - rng.Uniform(0.35, 0.6) * plan.width));
    const double notch_z = RoundToCentimetre(sz * (plan.depth / 2 - rng.Uniform(0.35, 0.6) * plan.depth));
    x_keys.insert(x_keys.begin() + 1, notch_x);
    z_keys.insert(z_keys.begin() + 1, notch_z);
    plan.inside = [=](double x, double z) { return !(sx * (x - notch_x) > 0 && sz * (z - notch_z) > 0); };
  } else {
    plan.inside = [](double, double) { return true; };
  }
  plan.x_lines = GridLines(x_keys);
  plan.z_lines = GridLines(z_keys);
  plan.y_lines = GridLines({0.0, plan.height});
  return plan;
}

// Floor (normal +Y) or ceiling (normal -Y) over the plan's cells; UVs are metres.
Primitive HorizontalSurface(const RoomPlan& plan, bool ceiling, uint32_t material) {
  Primitive p;
  p.material = material;
  const double y = ceiling ? plan.height : 0.0;
  const float ny = ceiling ? -1.0f : 1.0f;
  const auto add = [&](double x, double z) {
    p.positions.insert(p.positions.end(), {static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)});
    p.normals.insert(p.normals.end(), {0.0f, ny, 0.0f});
    p.uvs.insert(p.uvs.end(), {static_cast<float>(x), static_cast<float>(z)});
    return static_cast<uint32_t>(p.positions.size() / 3 - 1);
  };
  std::map<std::pair<size_t, size_t>, uint32_t> vertex;
  const auto at = [&](size_t i, size_t k) {
    const auto [it, fresh] = vertex.try_emplace({i, k}, 0);
    if (fresh) it->second = add(plan.x_lines[i], plan.z_lines[k]);
    return it->second;
  };
  for (size_t i = 0; i + 1 < plan.x_lines.size(); ++i) {
    for (size_t k = 0; k + 1 < plan.z_lines.size(); ++k) {
      if (!plan.inside(0.5 * (plan.x_lines[i] + plan.x_lines[i + 1]), 0.5 * (plan.z_lines[k] + plan.z_lines[k + 1]))) continue;
      const uint32_t a = at(i, k), b = at(i + 1, k), c = at(i + 1, k + 1), d = at(i, k + 1);
      if (ceiling) {
        p.indices.insert(p.indices.end(), {a, b, c, a, c, d});
      } else {
        p.indices.insert(p.indices.end(), {a, c, b, a, d, c});
      }
    }
  }
  return p;
}

// One wall panel per boundary side of every plan cell, facing into that cell. u runs
// left to right as seen from inside the room, v down from the ceiling, both in metres.
Primitive Walls(const RoomPlan& plan, uint32_t material) {
  Primitive p;
  p.material = material;
  const size_t nx = plan.x_lines.size() - 1, nz = plan.z_lines.size() - 1;
  const auto cell_inside = [&](int64_t i, int64_t k) {
    if (i < 0 || k < 0 || i >= static_cast<int64_t>(nx) || k >= static_cast<int64_t>(nz)) return false;
    const auto ui = static_cast<size_t>(i), uk = static_cast<size_t>(k);
    return plan.inside(0.5 * (plan.x_lines[ui] + plan.x_lines[ui + 1]), 0.5 * (plan.z_lines[uk] + plan.z_lines[uk + 1]));
  };
  const auto panel = [&](double ax, double az, double bx, double bz, float normal_x, float normal_z) {
    // A to B runs along (-n) x +Y, the viewer's right, so (B - A) x +Y is the normal n.
    const double right_x = normal_z, right_z = -normal_x;
    const auto base = static_cast<uint32_t>(p.positions.size() / 3);
    for (const double y : plan.y_lines) {
      for (const auto& [x, z] : {std::pair{ax, az}, std::pair{bx, bz}}) {
        p.positions.insert(p.positions.end(), {static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)});
        p.normals.insert(p.normals.end(), {normal_x, 0.0f, normal_z});
        p.uvs.insert(p.uvs.end(), {static_cast<float>(x * right_x + z * right_z), static_cast<float>(plan.height - y)});
      }
    }
    for (uint32_t r = 0; r + 1 < plan.y_lines.size(); ++r) {
      const uint32_t a0 = base + 2 * r, b0 = a0 + 1, a1 = a0 + 2, b1 = a0 + 3;
      p.indices.insert(p.indices.end(), {a0, b0, b1, a0, b1, a1});
    }
  };
  for (size_t i = 0; i < nx; ++i) {
    for (size_t k = 0; k < nz; ++k) {
      const auto si = static_cast<int64_t>(i), sk = static_cast<int64_t>(k);
      if (!cell_inside(si, sk)) continue;
      const double x0 = plan.x_lines[i], x1 = plan.x_lines[i + 1], z0 = plan.z_lines[k], z1 = plan.z_lines[k + 1];
      if (!cell_inside(si - 1, sk)) panel(x0, z1, x0, z0, 1, 0);
      if (!cell_inside(si + 1, sk)) panel(x1, z0, x1, z1, -1, 0);
      if (!cell_inside(si, sk - 1)) panel(x0, z0, x1, z0, 0, 1);
      if (!cell_inside(si, sk + 1)) panel(x1, z1, x0, z1, 0, -1);
    }
  }
  return p;
}

// Texture patterns covering one square metre (UVs are metres, so one repeat per metre).
Pattern FloorPattern(Rng& rng) {
  const uint64_t noise_seed = rng.Seed();
  if (rng.Chance(0.5)) {
    // Wood planks a metre long, rows staggered by a random offset per row.
    const int rows = rng.Int(4, 8);
    const Rgb wood = RandomHsv(rng, {0.04, 0.11}, {0.35, 0.75}, {0.3, 0.8});
    std::vector<double> joint(static_cast<size_t>(rows)), tint(static_cast<size_t>(2 * rows));
    for (double& j : joint) j = rng.Uniform();
    for (double& t : tint) t = rng.Uniform(0.8, 1.15);
    return [=](double u, double v) {
      const double row_f = v * rows;
      const auto row = static_cast<size_t>(std::min(static_cast<int>(row_f), rows - 1));
      const double along = Fract(u - joint[row]);
      const double across = row_f - static_cast<double>(row);
      const double grain = TileableFbm(noise_seed, u, v, 2, 8 * rows, 3);
      Rgb c = Scale(wood, tint[2 * row + (u < joint[row] ? 0 : 1)] * (1 + 0.18 * grain));
      if (across < 0.04 || across > 0.96 || along < 0.004 || along > 0.996) c = Scale(c, 0.45);
      return c;
    };
  }
  // Square tiles with grout lines, optionally in two alternating colours.
  const int tiles = rng.Int(2, 5);
  const auto [a, b] = RandomColourPair(rng);
  const bool alternate = rng.Chance(0.3);
  const Rgb grout = Hsv(0, 0, rng.Uniform(0.3, 0.85));
  const double grout_width = rng.Uniform(0.02, 0.06);
  return [=](double u, double v) {
    const double fu = Fract(u * tiles), fv = Fract(v * tiles);
    if (fu < grout_width || fv < grout_width) return grout;
    const bool odd = ((static_cast<int>(u * tiles) + static_cast<int>(v * tiles)) & 1) != 0;
    return Scale(alternate && odd ? b : a, 1 + 0.05 * TileableFbm(noise_seed, u, v, 4 * tiles, 4 * tiles, 2));
  };
}

Pattern WallPattern(Rng& rng) {
  const uint64_t noise_seed = rng.Seed();
  const double hue = rng.Uniform();
  const Rgb base = RandomHsv(rng, {hue, hue}, {0.03, 0.35}, {0.6, 0.95});
  if (rng.Chance(0.6)) {
    // Plaster: low-contrast cloudy noise.
    const double strength = rng.Uniform(0.04, 0.12);
    return [=](double u, double v) { return Scale(base, 1 + strength * TileableFbm(noise_seed, u, v, 4, 4, 5)); };
  }
  // Striped wallpaper, vertical since walls are papered in vertical strips.
  const int stripes = rng.Int(3, 10);
  const Rgb other = RandomHsv(rng, {hue - 0.08, hue + 0.08}, {0.05, 0.5}, {0.45, 0.95});
  const double duty = rng.Uniform(0.2, 0.6);
  return [=](double u, double v) {
    const Rgb c = Fract(u * stripes) < duty ? other : base;
    return Scale(c, 1 + 0.03 * TileableFbm(noise_seed, u, v, 8, 8, 2));
  };
}

Pattern CeilingPattern(Rng& rng) {
  const uint64_t noise_seed = rng.Seed();
  const Rgb base = RandomHsv(rng, {0, 1}, {0, 0.05}, {0.85, 0.97});
  return [=](double u, double v) { return Scale(base, 1 + 0.03 * TileableFbm(noise_seed, u, v, 8, 8, 3)); };
}

}  // namespace

std::string_view ShapeFamilyName(ShapeFamily f) {
  switch (f) {
    case ShapeFamily::kSuperquadric: return "superquadric";
    case ShapeFamily::kNoisySphere: return "noisy_sphere";
    case ShapeFamily::kExtrusion: return "extrusion";
    case ShapeFamily::kRevolution: return "revolution";
    case ShapeFamily::kTorus: return "torus";
    case ShapeFamily::kUnion: return "union";
  }
  return "unknown";
}

Status CheckProceduralShapeOptions(const ProceduralShapeOptions& options) {
  if (options.min_triangles < kMinProceduralTriangles ||
      static_cast<double>(options.max_triangles) < 1.25 * options.min_triangles ||
      options.max_triangles > kMaxProceduralTriangles) {
    return InvalidArgumentError(fmt::format("triangle range [{}, {}] must satisfy {} <= min, max >= 1.25 min, max <= {}",
                                            options.min_triangles, options.max_triangles, kMinProceduralTriangles,
                                            kMaxProceduralTriangles));
  }
  if (options.texture_size < 4 || options.texture_size > 4096) {
    return InvalidArgumentError(fmt::format("texture_size {} outside [4, 4096]", options.texture_size));
  }
  return Status::Ok();
}

Result<Asset> MakeProceduralShape(uint64_t seed, int index, const std::string& key,
                                  const ProceduralShapeOptions& options) {
  const std::string where = fmt::format("procedural shape {} (seed {})", index, SeedHex(seed));
  if (index < 0) return InvalidArgumentError(where + ": index must be >= 0");
  SOLID_RETURN_IF_ERROR(CheckProceduralShapeOptions(options).WithContext(where));

  const uint64_t item = MixSeed(seed, static_cast<uint64_t>(index));
  Rng geometry(item, kShapeGeometryStream);
  Rng look(item, kShapeMaterialStream);
  const auto family = static_cast<ShapeFamily>(index % kShapeFamilyCount);
  const int material_count = look.Chance(0.35) ? 2 : 1;

  Tessellator tessellate;
  switch (family) {
    case ShapeFamily::kSuperquadric: tessellate = Superquadric(geometry, material_count); break;
    case ShapeFamily::kNoisySphere: tessellate = NoisySphere(geometry, material_count); break;
    case ShapeFamily::kExtrusion: tessellate = Extrusion(geometry, material_count); break;
    case ShapeFamily::kRevolution: tessellate = Revolution(geometry, material_count); break;
    case ShapeFamily::kTorus: tessellate = Torus(geometry, material_count); break;
    case ShapeFamily::kUnion: tessellate = Union(geometry, material_count); break;
  }
  // Log-uniform inside the range, away from its ends so the rounding of counts has room.
  const double goal = std::exp(geometry.Uniform(std::log(options.min_triangles * 1.1),
                                                std::log(options.max_triangles / 1.1)));
  Result<Shape> shape = TessellateWithin(tessellate, options.min_triangles, options.max_triangles, goal);
  if (!shape.ok()) return shape.status().WithContext(where);

  Asset asset;
  asset.nodes.push_back(ShapeNode(*shape, key, material_count));
  static constexpr std::array<const char*, 2> kMaterialNames = {"body", "accent"};
  for (int m = 0; m < material_count; ++m) {
    const Pattern pattern = RandomShapePattern(look);
    SOLID_RETURN_IF_ERROR(AddTexturedMaterial(asset, kMaterialNames[static_cast<size_t>(m)], pattern,
                                              options.texture_size, look.Uniform(0.3, 1))
                              .WithContext(where));
  }
  asset.extras = {{"generator", "solid procedural"},
                  {"family", ShapeFamilyName(family)},
                  {"seed", SeedHex(seed)},
                  {"index", index}};
  return asset;
}

Result<Asset> MakeProceduralRoom(uint64_t seed, int index, const std::string& key,
                                 const ProceduralRoomOptions& options) {
  const std::string where = fmt::format("procedural room {} (seed {})", index, SeedHex(seed));
  if (index < 0) return InvalidArgumentError(where + ": index must be >= 0");
  if (options.texture_size < 4 || options.texture_size > 4096) {
    return InvalidArgumentError(fmt::format("{}: texture_size {} outside [4, 4096]", where, options.texture_size));
  }
  const uint64_t item = MixSeed(seed, static_cast<uint64_t>(index));
  Rng geometry(item, kRoomGeometryStream);
  Rng look(item, kRoomMaterialStream);
  const RoomPlan plan = RandomPlan(geometry);

  struct Surfacing {
    const char* name;
    std::function<Pattern(Rng&)> pattern;
    Range roughness;
  };
  const std::array<Surfacing, 3> surfacings = {Surfacing{"floor", FloorPattern, {0.3, 0.8}},
                                               Surfacing{"wall", WallPattern, {0.7, 1}},
                                               Surfacing{"ceiling", CeilingPattern, {0.8, 1}}};
  Asset asset;
  for (const Surfacing& surfacing : surfacings) {
    const Pattern pattern = surfacing.pattern(look);
    const double roughness = look.Uniform(surfacing.roughness.lo, surfacing.roughness.hi);
    SOLID_RETURN_IF_ERROR(AddTexturedMaterial(asset, surfacing.name, pattern, options.texture_size, roughness)
                              .WithContext(where));
  }
  // extras.structure is how the renderer tells shell pieces apart, as for SceneNet rooms.
  asset.nodes.push_back({"floor", {HorizontalSurface(plan, false, 0)}, {{"structure", "floor"}}});
  asset.nodes.push_back({"wall", {Walls(plan, 1)}, {{"structure", "wall"}}});
  asset.nodes.push_back({"ceiling", {HorizontalSurface(plan, true, 2)}, {{"structure", "ceiling"}}});
  asset.extras = {{"generator", "solid procedural"},
                  {"family", "room"},
                  {"plan", plan.l_shaped ? "L" : "box"},
                  {"size_m", {plan.width, plan.height, plan.depth}},
                  {"seed", SeedHex(seed)},
                  {"index", index},
                  {"key", key}};
  return asset;
}

}  // namespace solid::convert
