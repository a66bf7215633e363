#include "solid/convert/procedural.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "procedural_families.h"
#include "procedural_kit.h"
#include "solid/formats/image_codec.h"
#include "solid/formats/random.h"

namespace solid::convert {
// The asset model and its glb codec live in formats (render reads them too).
using namespace solid::gltf;
using namespace solid::convert::kit;
namespace {

// ---------------------------------------------------------------------------------------
// Randomness: solid/formats/random.h. Separate streams, so that a change to how
// materials are drawn never changes geometry.
enum Stream : uint64_t {
  kShapeGeometryStream = 1,
  kShapeMaterialStream = 2,
  kRoomGeometryStream = 3,
  kRoomMaterialStream = 4,
};

double Fract(double x) { return x - std::floor(x); }

// ---------------------------------------------------------------------------------------
// Noise. Value noise on a hashed integer lattice: cheap, seedable, and the same bits
// everywhere because it only uses floor, multiplies and adds.

double LatticeValue(uint64_t seed, int64_t x, int64_t y, int64_t z) {
  const uint64_t h = MixSeed(MixSeed(MixSeed(seed, static_cast<uint64_t>(x)), static_cast<uint64_t>(y)),
                          static_cast<uint64_t>(z));
  return static_cast<double>(h >> 11) * 0x1p-52 - 1.0;  // [-1, 1)
}

double Fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }
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
// Textures. Colours are drawn in sRGB (what the PNG stores); every pattern tiles.

struct Rgb {
  double r = 0, g = 0, b = 0;
};
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


// The texture of a model's material slot, by what the part is made of; `roughness` is
// drawn with it. Patterns tile over UVs in metres (boxes) or per turn (lathes, tubes).
Pattern SurfacePattern(Surfacing surfacing, Rng& rng, double* roughness) {
  const uint64_t noise_seed = rng.Seed();
  const auto grained = [noise_seed](Rgb c, double amount) {
    return [=](double u, double v) { return Scale(c, 1 + amount * TileableFbm(noise_seed, u, v, 8, 8, 3)); };
  };
  switch (surfacing) {
    case Surfacing::kWood: {
      const Rgb base = RandomHsv(rng, {0.04, 0.11}, {0.35, 0.75}, {0.25, 0.8});
      const int rings = rng.Int(3, 12);
      const double contrast = rng.Uniform(0.1, 0.3);
      *roughness = rng.Uniform(0.5, 0.8);
      return [=](double u, double v) {
        const double warp = 1.5 * TileableFbm(noise_seed, u, v, 2, 4, 3);
        return Scale(base, 1 - contrast + contrast * (1 + std::sin(2 * kPi * (rings * u + warp))));
      };
    }
    case Surfacing::kMetal: {
      const Rgb base = rng.Chance(0.2) ? RandomHsv(rng, {0, 1}, {0.25, 0.6}, {0.3, 0.8})
                                       : RandomHsv(rng, {0, 1}, {0, 0.06}, {0.4, 0.92});
      *roughness = rng.Uniform(0.3, 0.5);
      return [=](double u, double v) { return Scale(base, 1 + 0.07 * TileableFbm(noise_seed, u, v, 1, 32, 2)); };
    }
    case Surfacing::kFabric: {
      const auto [a, b] = RandomColourPair(rng);
      const bool plaid = rng.Chance(0.25);
      const int cells = 2 * rng.Int(8, 24), bands = rng.Int(2, 6);
      *roughness = rng.Uniform(0.85, 1.0);
      return [=](double u, double v) {
        const bool weave = ((static_cast<int>(u * cells) + static_cast<int>(v * cells)) & 1) != 0;
        Rgb c = plaid && (Fract(u * bands) < 0.25 || Fract(v * bands) < 0.25) ? b : a;
        return Scale(c, (weave ? 1.04 : 0.96) * (1 + 0.06 * TileableFbm(noise_seed, u, v, 8, 8, 3)));
      };
    }
    case Surfacing::kLeather: {
      const Rgb base = rng.Chance(0.3) ? RandomHsv(rng, {0, 1}, {0, 0.1}, {0.05, 0.2})
                                       : RandomHsv(rng, {0.02, 0.1}, {0.3, 0.75}, {0.12, 0.5});
      *roughness = rng.Uniform(0.4, 0.7);
      return grained(base, 0.12);
    }
    case Surfacing::kRubber:
      *roughness = 0.9;
      return grained(Hsv(0, 0, rng.Uniform(0.04, 0.12)), 0.1);
    case Surfacing::kScreen: {
      const Rgb base = RandomHsv(rng, {0.55, 0.7}, {0.1, 0.5}, {0.03, 0.14});
      *roughness = 0.2;
      return [=](double u, double v) { return Scale(base, 0.8 + 0.4 * Fract(u + v)); };
    }
    case Surfacing::kGlass: {
      const Rgb base = RandomHsv(rng, {0.2, 0.65}, {0.05, 0.5}, {0.1, 0.5});
      *roughness = 0.1;
      return grained(base, 0.03);
    }
    case Surfacing::kCeramic: {
      const auto [a, b] = RandomColourPair(rng);
      const Rgb white = RandomHsv(rng, {0, 1}, {0, 0.08}, {0.8, 0.97});
      const Rgb base = rng.Chance(0.4) ? white : a;
      const bool banded = rng.Chance(0.4);
      const int bands = rng.Int(2, 8);
      *roughness = rng.Uniform(0.2, 0.5);
      return [=](double u, double v) {
        const Rgb c = banded && Fract(v * bands) < 0.2 ? b : base;
        return Scale(c, 1 + 0.03 * TileableFbm(noise_seed, u, v, 8, 8, 2));
      };
    }
    case Surfacing::kKeys: {
      const Rgb key = Hsv(0, 0, rng.Uniform(0.05, 0.3)), gap = Scale(key, 0.5);
      *roughness = 0.5;
      return [=](double u, double v) {
        return Fract(u * 15) < 0.15 || Fract(v * 5) < 0.18 ? gap : key;
      };
    }
    case Surfacing::kPlastic:
    case Surfacing::kPaint: {
      const Rgb base = rng.Chance(0.35) ? RandomHsv(rng, {0, 1}, {0, 0.05}, {0.05, 0.95})
                                        : RandomHsv(rng, {0, 1}, {0.3, 0.9}, {0.2, 0.9});
      *roughness = surfacing == Surfacing::kPaint ? rng.Uniform(0.3, 0.6) : rng.Uniform(0.35, 0.7);
      return grained(base, 0.03);
    }
  }
  return grained(Hsv(0, 0, 0.5), 0);
}

// Shrinks or grows the edge length until the triangle count lands in [min, max]:
// triangles scale about as 1 / edge^2; bisection between the last edges found too fine
// and too coarse absorbs the jumps of integer segment counts.
Result<Shape> TessellateWithin(const ModelSpec& spec, int min_triangles, int max_triangles, double goal) {
  const auto tessellate = [&spec](double edge) {
    Shape shape;
    for (const Part& part : spec.parts) {
      Shape piece = BuildPart(part, edge);
      for (Surface& s : piece) shape.push_back(std::move(s));
    }
    return shape;
  };
  double edge = 0.05, too_fine = 0, too_coarse = 0;
  for (int round = 0; round < 40; ++round) {
    Shape shape = tessellate(edge);
    const int64_t count = CountTriangles(shape);
    if (count >= min_triangles && count <= max_triangles) return shape;
    if (count > max_triangles) too_fine = edge;
    if (count < min_triangles) too_coarse = edge;
    double next = edge * std::sqrt(static_cast<double>(count) / goal);
    if (too_fine > 0 && too_coarse > 0 && !(next > too_fine && next < too_coarse)) next = std::sqrt(too_fine * too_coarse);
    edge = next;
  }
  return InvalidArgumentError(fmt::format("cannot tessellate within [{}, {}] triangles", min_triangles, max_triangles));
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


// One primitive per material slot, normalised as ShapeNetCore.v2's model_normalized.obj
// is: the mean of the vertices at the origin and a bounding-box diagonal of 1.
Node ShapeNode(const Shape& shape, const std::string& key, size_t material_count) {
  std::vector<std::vector<Vec3>> surface_normals;
  for (const Surface& s : shape) surface_normals.push_back(CornerNormals(s));
  struct Raw {
    std::vector<Vec3> positions, normals;
    std::vector<std::array<double, 2>> uvs;
    std::vector<uint32_t> indices;
  };
  std::vector<Raw> raws(material_count);
  for (size_t si = 0; si < shape.size(); ++si) {
    const Surface& s = shape[si];
    const std::vector<Vec3>& normals = surface_normals[si];
    // A vertex splits where its corners' normals differ (at creases) or its material does.
    std::vector<std::map<std::pair<uint32_t, std::array<double, 3>>, uint32_t>> output_vertex(material_count);
    for (size_t t = 0; t < s.triangle_materials.size(); ++t) {
      const auto m = static_cast<size_t>(s.triangle_materials[t]);
      Raw& raw = raws[m];
      for (size_t k = 0; k < 3; ++k) {
        const uint32_t v = s.indices[3 * t + k];
        const Vec3 n = normals[3 * t + k];
        const auto [it, fresh] =
            output_vertex[m].try_emplace({v, {n.x, n.y, n.z}}, static_cast<uint32_t>(raw.positions.size()));
        if (fresh) {
          raw.positions.push_back(s.positions[v]);
          raw.normals.push_back(n);
          raw.uvs.push_back(s.uvs[v]);
        }
        raw.indices.push_back(it->second);
      }
    }
  }
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300}, sum;
  double count = 0;
  for (const Raw& raw : raws) {
    for (const Vec3& p : raw.positions) {
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
      sum = sum + p;
      count += 1;
    }
  }
  const Vec3 centre = sum * (1 / count);
  const double scale = 1 / Length(hi - lo);
  Node node;
  node.name = key;
  for (size_t m = 0; m < material_count; ++m) {
    const Raw& raw = raws[m];
    if (raw.indices.empty()) continue;
    Primitive primitive;
    primitive.material = static_cast<uint32_t>(m);
    for (size_t v = 0; v < raw.positions.size(); ++v) {
      const Vec3 p = (raw.positions[v] - centre) * scale;
      primitive.positions.insert(primitive.positions.end(),
                                 {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)});
      const Vec3& n = raw.normals[v];
      primitive.normals.insert(primitive.normals.end(),
                               {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)});
      primitive.uvs.insert(primitive.uvs.end(), {static_cast<float>(raw.uvs[v][0]), static_cast<float>(raw.uvs[v][1])});
    }
    primitive.indices = raw.indices;
    node.primitives.push_back(std::move(primitive));
  }
  return node;
}

std::string SeedHex(uint64_t seed) { return fmt::format("{:#018x}", seed); }

// ---------------------------------------------------------------------------------------
// Rooms.
//
// A room is a 2.5D cell complex: the plan is cut by every feature's edges into cells
// (at most about a metre across), and each cell is solid or open between a floor height
// and a ceiling height. Floors, ceilings and the vertical faces between a cell and its
// neighbours (walls, risers, ceiling drops) then form one closed, inward-wound shell,
// provided no two solid regions touch only at a corner (features keep clear of each
// other for that). Vertical faces take every height any neighbouring cell breaks at,
// so faces meet without T-junctions.

// Grid lines along one axis: the sorted keys, each interval split into steps of at most
// about a metre.
std::vector<double> GridLines(std::vector<double> keys) {
  std::sort(keys.begin(), keys.end());
  // Sums of snapped values can miss the 5 cm grid by an ulp: one line, not a sliver.
  keys.erase(std::unique(keys.begin(), keys.end(), [](double a, double b) { return b - a < 1e-6; }), keys.end());
  std::vector<double> lines;
  for (size_t k = 0; k + 1 < keys.size(); ++k) {
    const int steps = std::max(1, static_cast<int>(std::ceil(keys[k + 1] - keys[k] - 1e-9)));
    for (int i = 0; i < steps; ++i) lines.push_back(Lerp(keys[k], keys[k + 1], static_cast<double>(i) / steps));
  }
  lines.push_back(keys.back());
  return lines;
}

double RoundToCentimetre(double metres) { return std::round(metres * 100) / 100; }

// Feature coordinates sit on a 5 cm grid: no sliver cells between nearly equal edges.
double Snap(double metres) { return std::round(metres * 20) / 20; }

struct Rect {
  double x0 = 0, z0 = 0, x1 = 0, z1 = 0;
  bool Contains(double x, double z) const { return x > x0 && x < x1 && z > z0 && z < z1; }
  // Closer than `margin` to `o` (or overlapping).
  bool Near(const Rect& o, double margin) const {
    return x0 < o.x1 + margin && o.x0 < x1 + margin && z0 < o.z1 + margin && o.z0 < z1 + margin;
  }
};

struct RoomPlan {
  double width = 0, depth = 0, height = 0;  // bounding box, metres
  std::string footprint = "box";            // box, L, U, T
  std::vector<std::string> features;
  std::vector<Rect> notches, pillars, thick_walls;
  struct Level {
    Rect r;
    double floor = 0;
    bool wall_top = false;  // a half-height wall: its top belongs to the wall, not the floor
  };
  std::vector<Level> levels;
  struct Lowered {
    Rect r;
    double ceiling = 0;
  };
  std::vector<Lowered> lowered;
  struct Opening {
    Rect r;
    double sill = 0, lintel = 0;
    bool window = false;
  };
  std::vector<Opening> openings;
  double slope_from_x = 0, slope = 0;  // ceiling = height - slope * max(0, x - slope_from_x)
  struct Shelf {
    Vec3 centre, half;
  };
  std::vector<Shelf> shelves;
  std::vector<double> x_lines, z_lines, y_lines;

  double CeilingAt(double x) const { return height - slope * std::max(0.0, x - slope_from_x); }
  bool Solid(double x, double z) const {
    if (!(x > -width / 2 && x < width / 2 && z > -depth / 2 && z < depth / 2)) return true;
    for (const Rect& r : notches) {
      if (r.Contains(x, z)) return true;
    }
    for (const Rect& r : pillars) {
      if (r.Contains(x, z)) return true;
    }
    for (const Rect& r : thick_walls) {
      if (r.Contains(x, z) && OpeningAt(x, z) == nullptr) return true;
    }
    return false;
  }
  const Opening* OpeningAt(double x, double z) const {
    for (const Opening& o : openings) {
      if (o.r.Contains(x, z)) return &o;
    }
    return nullptr;
  }
  // Solid features, for keeping new ones clear of them.
  bool Clear(const Rect& r, double margin) const {
    for (const std::vector<Rect>* rects : {&notches, &pillars, &thick_walls}) {
      for (const Rect& o : *rects) {
        if (r.Near(o, margin)) return false;
      }
    }
    for (const Level& l : levels) {
      if (r.Near(l.r, margin)) return false;
    }
    return true;
  }
};

// One cell of the complex: open between floor and the ceiling at its corners.
struct Cell {
  bool open = false;
  bool opening = false;  // a door or window reveal: its faces belong to the wall
  bool window = false;
  bool wall_top = false;  // the top of a half-height wall
  double floor = 0, cap = 1e300;
};

RoomPlan RandomPlan(Rng& rng) {
  RoomPlan plan;
  // SceneNet's rooms (the bathroom layout of the shared data: 2.7 x 5.9 m, 2.7 m high;
  // bedrooms and offices up to about 7 m): 2.5-7 m across, up to 2.5:1, 2.4-3.1 m high.
  plan.width = 2 * Snap(rng.Uniform(2.5, 7) / 2);
  plan.depth = 2 * Snap(rng.Uniform(2.5, 7) / 2);
  if (plan.depth > 2.5 * plan.width) plan.depth = 2 * Snap(1.25 * plan.width);
  if (plan.width > 2.5 * plan.depth) plan.width = 2 * Snap(1.25 * plan.depth);
  plan.height = Snap(rng.Uniform(2.4, 3.1));
  const double hx = plan.width / 2, hz = plan.depth / 2;
  // Footprint: notches out of the bounding box.
  const int footprint = rng.Int(0, 4);  // box (x2), L, U, T
  const int side = rng.Int(0, 3);       // which side a U or T opens to, which corner an L loses
  const double a = Snap(rng.Uniform(0.3, 0.45)), b = Snap(rng.Uniform(0.35, 0.55));
  const auto side_rect = [&](double from, double to, double deep) {
    // A rectangle on side `side`, spanning [from, to] along it (fractions) and `deep` in.
    switch (side) {
      case 0: return Rect{Snap(-hx + from * plan.width), -hz - 1, Snap(-hx + to * plan.width), Snap(-hz + deep * plan.depth)};
      case 1: return Rect{Snap(-hx + from * plan.width), Snap(hz - deep * plan.depth), Snap(-hx + to * plan.width), hz + 1};
      case 2: return Rect{-hx - 1, Snap(-hz + from * plan.depth), Snap(-hx + deep * plan.width), Snap(-hz + to * plan.depth)};
      default: return Rect{Snap(hx - deep * plan.width), Snap(-hz + from * plan.depth), hx + 1, Snap(-hz + to * plan.depth)};
    }
  };
  if (footprint == 2) {
    plan.footprint = "L";
    plan.notches.push_back(side_rect(1 - a - 0.1, 2, b));
  } else if (footprint == 3) {
    plan.footprint = "U";
    plan.notches.push_back(side_rect(0.5 - a / 2, 0.5 + a / 2, b));
  } else if (footprint == 4) {
    plan.footprint = "T";
    plan.notches.push_back(side_rect(-1, a * 0.8, b));
    plan.notches.push_back(side_rect(1 - a * 0.8, 2, b));
  }
  const auto inside_all = [&](const Rect& r) {
    for (int i = 0; i <= 4; ++i) {
      for (int k = 0; k <= 4; ++k) {
        if (plan.Solid(Lerp(r.x0, r.x1, (i + 0.5) / 5.5), Lerp(r.z0, r.z1, (k + 0.5) / 5.5))) return false;
      }
    }
    return r.x0 > -hx && r.x1 < hx && r.z0 > -hz && r.z1 < hz;
  };
  // A thick wall (the reveals of a door and a window) along one bounding side.
  if (rng.Chance(0.6)) {
    const double t = Snap(rng.Uniform(0.15, 0.3));
    const int wall = rng.Int(0, 3);
    const bool along_x = wall < 2;
    const double len = along_x ? plan.width : plan.depth, sign = wall % 2 == 0 ? -1 : 1;
    const Rect strip = along_x ? Rect{-hx - 1, sign < 0 ? -hz - 1 : hz - t, hx + 1, sign < 0 ? -hz + t : hz + 1}
                         : Rect{sign < 0 ? -hx - 1 : hx - t, -hz - 1, sign < 0 ? -hx + t : hx + 1, hz + 1};
    plan.thick_walls.push_back(strip);
    plan.features.push_back("thick_wall");
    // Openings at positions along the strip where the room is open behind it.
    for (int k = 0; k < 2; ++k) {
      const bool window = k == 1 || rng.Chance(0.3);
      const double w = Snap(window ? rng.Uniform(0.8, 1.8) : rng.Uniform(0.8, 1.0));
      const double at = Snap(rng.Uniform(-len / 2 + 0.4, len / 2 - 0.4 - w));
      Rect r = along_x ? Rect{at, strip.z0, at + w, strip.z1} : Rect{strip.x0, at, strip.x1, at + w};
      const Rect probe = along_x ? Rect{at, sign < 0 ? -hz + t : hz - t - 0.6, at + w, sign < 0 ? -hz + t + 0.6 : hz - t}
                                 : Rect{sign < 0 ? -hx + t : hx - t - 0.6, at, sign < 0 ? -hx + t + 0.6 : hx - t, at + w};
      bool fine = inside_all(probe);
      for (const RoomPlan::Opening& o : plan.openings) fine = fine && !r.Near(o.r, 0.3);
      for (const Rect& n : plan.notches) fine = fine && !r.Near(n, 0.3);
      if (!fine) continue;
      const double sill = window ? Snap(rng.Uniform(0.7, 1.0)) : 0.0;
      const double lintel = Snap(window ? rng.Uniform(1.9, 2.3) : rng.Uniform(1.95, 2.15));
      plan.openings.push_back({r, sill, std::min(lintel, plan.height - 0.2), window});
      plan.features.push_back(window ? "window" : "door");
    }
  }
  // An alcove: a recess in one wall, made by notching the wall on both sides of it.
  if (rng.Chance(0.35)) {
    const double deep = Snap(rng.Uniform(0.4, 0.9)), w = Snap(rng.Uniform(0.9, 2.0));
    const int wall = rng.Int(0, 3);
    const bool along_x = wall < 2;
    const double len = along_x ? plan.width : plan.depth, sign = wall % 2 == 0 ? -1 : 1;
    const double at = Snap(rng.Uniform(-len / 2 + 0.5, len / 2 - 0.5 - w));
    const double e = along_x ? hz : hx;
    const auto strip = [&](double from, double to) {
      return along_x ? Rect{from, sign < 0 ? -e - 1 : e - deep, to, sign < 0 ? -e + deep : e + 1}
                     : Rect{sign < 0 ? -e - 1 : e - deep, from, sign < 0 ? -e + deep : e + 1, to};
    };
    const Rect left = strip(-len / 2 - 1, at), right = strip(at + w, len / 2 + 1);
    if (plan.Clear(strip(at - 0.3, at + w + 0.3), 0.3)) {
      plan.notches.push_back(left);
      plan.notches.push_back(right);
      plan.features.push_back("alcove");
      if (rng.Chance(0.5)) {
        plan.lowered.push_back({strip(at, at + w), Snap(plan.height - rng.Uniform(0.3, 0.6))});
      }
    }
  }
  // Raised floor in a corner, with a step in front of it or not.
  if (rng.Chance(0.55)) {
    const double pw = Snap(rng.Uniform(1.0, 0.5 * plan.width)), pd = Snap(rng.Uniform(1.0, 0.5 * plan.depth));
    const int corner = rng.Int(0, 3);
    const double sx = corner & 1 ? 1 : -1, sz = corner & 2 ? 1 : -1;
    const Rect r{sx < 0 ? -hx - 1 : hx - pw, sz < 0 ? -hz - 1 : hz - pd, sx < 0 ? -hx + pw : hx + 1, sz < 0 ? -hz + pd : hz + 1};
    const double rise = Snap(rng.Uniform(0.15, 0.5));
    const Rect core{std::max(r.x0, -hx + 0.01), std::max(r.z0, -hz + 0.01), std::min(r.x1, hx - 0.01), std::min(r.z1, hz - 0.01)};
    const bool step = rise >= 0.3 && rng.Chance(0.6);
    const double s = 0.35;
    const Rect front{sx < 0 ? r.x1 : r.x0 - s, r.z0, sx < 0 ? r.x1 + s : r.x0, r.z1};
    const Rect reach{std::min(core.x0, front.x0), core.z0, std::max(core.x1, front.x1), core.z1};
    if (inside_all(step ? reach : core) && plan.Clear(step ? reach : core, 0.35)) {
      plan.levels.push_back({r, rise});
      plan.features.push_back("platform");
      if (step) {
        plan.levels.push_back({front, Snap(rise / 2)});
        plan.features.push_back("step");
      }
    }
  }
  // What stands in the room between a camera and what it looks at: pillars and
  // half-height walls in the middle part of the room, wing walls out of a wall.
  // Sizes follow the room's: rooms are stretched to 12 x 12 m for layouts, and a pillar
  // wider than about a fifteenth of the room then fills half a frame. One to three: the
  // unfitted scenenet-background preset then measures 35.1% occlusion against rotation's
  // 31.0% in the white cube (400 layouts), Table 1's gap of 4 points; two to four made it
  // 37.7%, and none to two left no gap beyond the 95% intervals.
  const int occluders = rng.Int(1, 3);
  int placed = 0;
  for (int k = 0; k < 16 && placed < occluders; ++k) {
    const double pick = rng.Uniform();
    const int kind = pick < 0.45 ? 0 : pick < 0.75 ? 2 : 1;
    if (kind == 0) {
      const double s = std::max(0.15, Snap(rng.Uniform(0.05, 0.08) * std::min(plan.width, plan.depth)));
      const double x = Snap(rng.Uniform(-hx * 0.4, hx * 0.4)), z = Snap(rng.Uniform(-hz * 0.4, hz * 0.4));
      const Rect r{x - s / 2, z - s / 2, x + s / 2, z + s / 2};
      if (inside_all(Rect{r.x0 - 0.5, r.z0 - 0.5, r.x1 + 0.5, r.z1 + 0.5}) && plan.Clear(r, 0.5)) {
        plan.pillars.push_back(r);
        plan.features.push_back("pillar");
        ++placed;
      }
      continue;
    }
    // A wall segment across x or z: from a bounding wall (a wing wall, full height) or
    // free-standing (a half-height wall).
    const bool wing = kind == 1, along_x = rng.Chance(0.5);
    const double t = Snap(rng.Uniform(0.1, 0.15)), frac = rng.Uniform(0.2, 0.45), at = rng.Uniform(-0.3, 0.3);
    const double e_along = along_x ? hx : hz, e_across = along_x ? hz : hx;
    const double len = Snap(2 * e_along * frac), pos = Snap(at * e_across);
    const bool from_low = rng.Chance(0.5);
    const double from = wing ? (from_low ? -e_along - 1 : e_along - len) : Snap(rng.Uniform(-0.3, 0.3) * e_along - len / 2);
    const double to = wing ? (from_low ? -e_along + len : e_along + 1) : from + len;
    const Rect r = along_x ? Rect{from, pos - t / 2, to, pos + t / 2} : Rect{pos - t / 2, from, pos + t / 2, to};
    const Rect core{std::max(r.x0, -hx + 0.01), std::max(r.z0, -hz + 0.01), std::min(r.x1, hx - 0.01), std::min(r.z1, hz - 0.01)};
    const Rect room_side = along_x ? Rect{core.x0, core.z0 - 0.5, core.x1, core.z1 + 0.5} : Rect{core.x0 - 0.5, core.z0, core.x1 + 0.5, core.z1};
    if (!inside_all(room_side) || !plan.Clear(core, 0.4)) continue;
    ++placed;
    if (wing) {
      plan.pillars.push_back(r);
      plan.features.push_back("wing_wall");
    } else {
      plan.levels.push_back({r, Snap(rng.Uniform(0.6, 1.0)), true});
      plan.features.push_back("half_wall");
    }
  }
  // Ceiling: a slope along x, a lowered band (soffit), beams across.
  if (rng.Chance(0.25)) {
    plan.slope_from_x = Snap(rng.Uniform(-hx, 0));
    plan.slope = std::min(rng.Uniform(0.15, 0.35), (plan.height - 2.0) / (hx - plan.slope_from_x));
    plan.features.push_back("sloped_ceiling");
  }
  if (rng.Chance(0.3)) {
    const double w = Snap(rng.Uniform(0.6, 1.5));
    const bool along_x = rng.Chance(0.5), low = rng.Chance(0.5);
    const double e = along_x ? hz : hx;
    const Rect band = along_x ? Rect{-hx - 1, low ? -e - 1 : e - w, hx + 1, low ? -e + w : e + 1}
                              : Rect{low ? -e - 1 : e - w, -hz - 1, low ? -e + w : e + 1, hz + 1};
    plan.lowered.push_back({band, Snap(plan.height - rng.Uniform(0.25, 0.5))});
    plan.features.push_back("soffit");
  }
  const int beams = rng.Chance(0.35) ? rng.Int(1, 3) : 0;
  for (int k = 0; k < beams; ++k) {
    const double w = Snap(rng.Uniform(0.2, 0.4)), x = Snap(-hx + plan.width * (k + 1) / (beams + 1));
    plan.lowered.push_back({Rect{x - w / 2, -hz - 1, x + w / 2, hz + 1}, Snap(plan.height - rng.Uniform(0.2, 0.4))});
    plan.features.push_back("beam");
  }
  std::vector<double> x_keys = {-hx, hx}, z_keys = {-hz, hz};
  const auto add_keys = [&](const Rect& r) {
    for (double x : {r.x0, r.x1}) {
      if (x > -hx && x < hx) x_keys.push_back(x);
    }
    for (double z : {r.z0, r.z1}) {
      if (z > -hz && z < hz) z_keys.push_back(z);
    }
  };
  for (const std::vector<Rect>* rects : {&plan.notches, &plan.pillars, &plan.thick_walls}) {
    for (const Rect& r : *rects) add_keys(r);
  }
  for (const RoomPlan::Level& l : plan.levels) add_keys(l.r);
  for (const RoomPlan::Lowered& l : plan.lowered) add_keys(l.r);
  for (const RoomPlan::Opening& o : plan.openings) add_keys(o.r);
  if (plan.slope > 0) x_keys.push_back(plan.slope_from_x);
  plan.x_lines = GridLines(x_keys);
  plan.z_lines = GridLines(z_keys);
  plan.y_lines = GridLines({0.0, plan.height});
  // Shelves on walls that are plain from floor to ceiling over their length.
  const int shelves = rng.Int(0, 2);
  for (int k = 0; k < shelves; ++k) {
    const double len = Snap(rng.Uniform(0.6, 1.4)), deep = rng.Uniform(0.2, 0.3), y = Snap(rng.Uniform(1.0, 1.8));
    const int wall = rng.Int(0, 3);
    const bool along_x = wall < 2;
    const double span = along_x ? plan.width : plan.depth, sign = wall % 2 == 0 ? -1 : 1;
    const double at = rng.Uniform(-span / 2 + 0.3, span / 2 - 0.3 - len);
    const double e = (along_x ? hz : hx) + 0.005;
    const Rect foot = along_x ? Rect{at, sign < 0 ? -e : e - deep, at + len, sign < 0 ? -e + deep : e}
                              : Rect{sign < 0 ? -e : e - deep, at, sign < 0 ? -e + deep : e, at + len};
    // Against the bounding wall: the cells in front of it are open, plain floor.
    bool fine = y < plan.CeilingAt(hx) - 0.4;
    for (int i = 0; i <= 8 && fine; ++i) {
      const double s = (i + 0.5) / 9;
      const double px = along_x ? Lerp(foot.x0, foot.x1, s) : (sign < 0 ? -hx + 0.05 : hx - 0.05);
      const double pz = along_x ? (sign < 0 ? -hz + 0.05 : hz - 0.05) : Lerp(foot.z0, foot.z1, s);
      fine = !plan.Solid(px, pz) && plan.OpeningAt(px, pz) == nullptr;
      for (const RoomPlan::Level& l : plan.levels) fine = fine && !l.r.Near(foot, 0.3);
      for (const RoomPlan::Lowered& l : plan.lowered) fine = fine && !(l.r.Near(foot, 0.1) && l.ceiling < y + 0.4);
    }
    for (const RoomPlan::Shelf& other : plan.shelves) {
      fine = fine && std::fabs(other.centre.y - y) + std::fabs(other.centre.x - (foot.x0 + foot.x1) / 2) +
                             std::fabs(other.centre.z - (foot.z0 + foot.z1) / 2) > 0.5;
    }
    if (!fine) continue;
    plan.shelves.push_back({{(foot.x0 + foot.x1) / 2, y, (foot.z0 + foot.z1) / 2},
                            {(foot.x1 - foot.x0) / 2, 0.015, (foot.z1 - foot.z0) / 2}});
    plan.features.push_back("shelf");
  }
  return plan;
}

// Triangles of one structure class, each with its own three vertices and flat normal.
struct ShellBuilder {
  Primitive floor, wall, ceiling;
  void Add(Primitive& p, Vec3 a, Vec3 b, Vec3 c, std::array<double, 2> ua, std::array<double, 2> ub,
           std::array<double, 2> uc) {
    const Vec3 n = Normalized(Cross(b - a, c - a));
    for (const auto& [q, uv] : {std::pair{a, ua}, std::pair{b, ub}, std::pair{c, uc}}) {
      p.positions.insert(p.positions.end(), {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)});
      p.normals.insert(p.normals.end(), {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)});
      p.uvs.insert(p.uvs.end(), {static_cast<float>(uv[0]), static_cast<float>(uv[1])});
      p.indices.push_back(static_cast<uint32_t>(p.positions.size() / 3 - 1));
    }
  }
};

void BuildShell(const RoomPlan& plan, ShellBuilder& out) {
  const size_t nx = plan.x_lines.size() - 1, nz = plan.z_lines.size() - 1;
  std::vector<Cell> cells(nx * nz);
  for (size_t i = 0; i < nx; ++i) {
    for (size_t k = 0; k < nz; ++k) {
      const double cx = 0.5 * (plan.x_lines[i] + plan.x_lines[i + 1]), cz = 0.5 * (plan.z_lines[k] + plan.z_lines[k + 1]);
      Cell& c = cells[i * nz + k];
      c.open = !plan.Solid(cx, cz);
      if (!c.open) continue;
      if (const RoomPlan::Opening* o = plan.OpeningAt(cx, cz)) {
        c.opening = true;
        c.window = o->window;
        c.floor = o->sill;
        c.cap = o->lintel;
        continue;
      }
      for (const RoomPlan::Level& l : plan.levels) {
        if (!l.r.Contains(cx, cz) || l.floor < c.floor) continue;
        c.floor = l.floor;
        c.wall_top = l.wall_top;
      }
      for (const RoomPlan::Lowered& l : plan.lowered) {
        if (l.r.Contains(cx, cz)) c.cap = std::min(c.cap, l.ceiling);
      }
    }
  }
  const auto cell = [&](int64_t i, int64_t k) -> const Cell* {
    if (i < 0 || k < 0 || i >= static_cast<int64_t>(nx) || k >= static_cast<int64_t>(nz)) return nullptr;
    const Cell& c = cells[static_cast<size_t>(i) * nz + static_cast<size_t>(k)];
    return c.open ? &c : nullptr;
  };
  const auto ceiling = [&](const Cell& c, size_t corner_i) { return std::min(c.cap, plan.CeilingAt(plan.x_lines[corner_i])); };
  // Heights at which faces break on the vertical line through grid point (i, k).
  const auto breaks = [&](size_t i, size_t k) {
    std::vector<double> ys;
    for (int64_t di = -1; di <= 0; ++di) {
      for (int64_t dk = -1; dk <= 0; ++dk) {
        if (const Cell* c = cell(static_cast<int64_t>(i) + di, static_cast<int64_t>(k) + dk)) {
          ys.push_back(c->floor);
          ys.push_back(ceiling(*c, i));
        }
      }
    }
    // Panel lines, except one an ulp from a floor or ceiling height: that would be a sliver.
    const size_t heights = ys.size();
    for (const double y : plan.y_lines) {
      bool near = false;
      for (size_t h = 0; h < heights; ++h) near = near || std::fabs(ys[h] - y) < 1e-6;
      if (!near) ys.push_back(y);
    }
    std::sort(ys.begin(), ys.end());
    ys.erase(std::unique(ys.begin(), ys.end()), ys.end());
    return ys;
  };
  // A vertical face from grid point p to grid point q (the viewer's right seen from the
  // open side), over [lo, hi] at each end, zipped between the two lines' break heights.
  const auto vertical = [&](Primitive& prim, size_t pi, size_t pk, size_t qi, size_t qk, double lo_p, double hi_p,
                            double lo_q, double hi_q) {
    if (!(hi_p > lo_p) && !(hi_q > lo_q)) return;
    const Vec3 p{plan.x_lines[pi], 0, plan.z_lines[pk]}, q{plan.x_lines[qi], 0, plan.z_lines[qk]};
    const auto range = [](const std::vector<double>& ys, double lo, double hi) {
      std::vector<double> r;
      for (double y : ys) {
        if (y >= lo && y <= hi) r.push_back(y);
      }
      return r;
    };
    const std::vector<double> left = range(breaks(pi, pk), lo_p, hi_p), right = range(breaks(qi, qk), lo_q, hi_q);
    const Vec3 along = q - p;
    const double right_x = along.x / Length(along), right_z = along.z / Length(along);
    const auto at = [&](const Vec3& base, double y) { return Vec3{base.x, y, base.z}; };
    const auto uv = [&](const Vec3& v) { return std::array<double, 2>{v.x * right_x + v.z * right_z, plan.height - v.y}; };
    size_t a = 0, b = 0;
    while (a + 1 < left.size() || b + 1 < right.size()) {
      const bool advance_left = b + 1 >= right.size() || (a + 1 < left.size() && left[a + 1] <= right[b + 1]);
      const Vec3 pa = at(p, left[a]), qb = at(q, right[b]);
      const Vec3 next = advance_left ? at(p, left[a + 1]) : at(q, right[b + 1]);
      out.Add(prim, pa, qb, next, uv(pa), uv(qb), uv(next));
      advance_left ? ++a : ++b;
    }
  };
  for (size_t i = 0; i < nx; ++i) {
    for (size_t k = 0; k < nz; ++k) {
      const Cell* c = cell(static_cast<int64_t>(i), static_cast<int64_t>(k));
      if (c == nullptr) continue;
      const double x0 = plan.x_lines[i], x1 = plan.x_lines[i + 1], z0 = plan.z_lines[k], z1 = plan.z_lines[k + 1];
      // Floor (up) and ceiling (down); UVs in metres.
      Primitive& floor = c->window || c->wall_top ? out.wall : out.floor;
      const Vec3 f00{x0, c->floor, z0}, f10{x1, c->floor, z0}, f11{x1, c->floor, z1}, f01{x0, c->floor, z1};
      out.Add(floor, f00, f11, f10, {x0, z0}, {x1, z1}, {x1, z0});
      out.Add(floor, f00, f01, f11, {x0, z0}, {x0, z1}, {x1, z1});
      Primitive& top = c->opening ? out.wall : out.ceiling;
      const double c0 = ceiling(*c, i), c1 = ceiling(*c, i + 1);
      const Vec3 t00{x0, c0, z0}, t10{x1, c1, z0}, t11{x1, c1, z1}, t01{x0, c0, z1};
      out.Add(top, t00, t10, t11, {x0, z0}, {x1, z0}, {x1, z1});
      out.Add(top, t00, t11, t01, {x0, z0}, {x1, z1}, {x0, z1});
      // The four sides: (neighbour offset, side from p to q as seen from inside this cell).
      struct Side {
        int64_t di, dk;
        size_t pi, pk, qi, qk;
      };
      const std::array<Side, 4> sides = {Side{-1, 0, i, k + 1, i, k}, Side{1, 0, i + 1, k, i + 1, k + 1},
                                         Side{0, -1, i, k, i + 1, k}, Side{0, 1, i + 1, k + 1, i, k + 1}};
      for (const Side& s : sides) {
        const Cell* n = cell(static_cast<int64_t>(i) + s.di, static_cast<int64_t>(k) + s.dk);
        const double top_p = ceiling(*c, s.pi), top_q = ceiling(*c, s.qi);
        if (n == nullptr) {
          vertical(out.wall, s.pi, s.pk, s.qi, s.qk, c->floor, top_p, c->floor, top_q);
          continue;
        }
        const bool reveal = c->opening || n->opening;
        // The neighbour's floor above ours: a riser facing us (a step, or the low wall
        // of a raised area).
        if (n->floor > c->floor) {
          Primitive& riser = reveal || n->floor - c->floor > 0.2 ? out.wall : out.floor;
          vertical(riser, s.pi, s.pk, s.qi, s.qk, c->floor, n->floor, c->floor, n->floor);
        }
        // The neighbour's ceiling below ours: a drop facing us (a beam's side, a soffit).
        const double n_top_p = ceiling(*n, s.pi), n_top_q = ceiling(*n, s.qi);
        if (n_top_p < top_p || n_top_q < top_q) {
          vertical(reveal ? out.wall : out.ceiling, s.pi, s.pk, s.qi, s.qk, std::min(n_top_p, top_p), top_p,
                   std::min(n_top_q, top_q), top_q);
        }
      }
    }
  }
  // Shelves: closed boxes against the walls, wound outwards.
  for (const RoomPlan::Shelf& s : plan.shelves) {
    const Vec3 c = s.centre, h = s.half;
    const auto corner = [&](int m) {
      return Vec3{c.x + (m & 1 ? h.x : -h.x), c.y + (m & 2 ? h.y : -h.y), c.z + (m & 4 ? h.z : -h.z)};
    };
    // Faces as corner quadruples, counter-clockwise seen from outside.
    static constexpr std::array<std::array<int, 4>, 6> kFaces = {{{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                                                 {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}}};
    for (const auto& f : kFaces) {
      const Vec3 a = corner(f[0]), b = corner(f[1]), cc = corner(f[2]), d = corner(f[3]);
      out.Add(out.wall, a, b, cc, {a.x + a.z, a.y}, {b.x + b.z, b.y}, {cc.x + cc.z, cc.y});
      out.Add(out.wall, a, cc, d, {a.x + a.z, a.y}, {cc.x + cc.z, cc.y}, {d.x + d.z, d.y});
    }
  }
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

namespace {

struct FamilyInfo {
  ShapeFamily family;
  std::string_view name, synset;  // the ShapeNetCore.v2 synset the family is shaped after
};

constexpr std::array<FamilyInfo, kShapeFamilyCount> kFamilies = {{
    {ShapeFamily::kChair, "chair", "03001627"},       {ShapeFamily::kTable, "table", "04379243"},
    {ShapeFamily::kSofa, "sofa", "04256520"},         {ShapeFamily::kBed, "bed", "02818832"},
    {ShapeFamily::kCabinet, "cabinet", "02933112"},   {ShapeFamily::kBookshelf, "bookshelf", "02871439"},
    {ShapeFamily::kLamp, "lamp", "03636649"},         {ShapeFamily::kDisplay, "display", "03211117"},
    {ShapeFamily::kCar, "car", "02958343"},           {ShapeFamily::kAirplane, "airplane", "02691156"},
    {ShapeFamily::kBottle, "bottle", "02876657"},     {ShapeFamily::kVase, "vase", "03593526"},
    {ShapeFamily::kMug, "mug", "03797390"},           {ShapeFamily::kBowl, "bowl", "02880940"},
    {ShapeFamily::kBench, "bench", "02828884"},       {ShapeFamily::kTrashBin, "trash_bin", "02747177"},
    {ShapeFamily::kGuitar, "guitar", "03467517"},     {ShapeFamily::kLaptop, "laptop", "03642806"},
}};

const FamilyInfo& Info(ShapeFamily f) { return kFamilies[static_cast<size_t>(f)]; }

}  // namespace

std::string_view ShapeFamilyName(ShapeFamily f) { return Info(f).name; }
std::string_view ShapeFamilySynset(ShapeFamily f) { return Info(f).synset; }

Result<std::vector<ShapeFamily>> ParseShapeFamilies(const std::vector<std::string>& names) {
  std::vector<ShapeFamily> families;
  for (const std::string& name : names) {
    const auto it = std::find_if(kFamilies.begin(), kFamilies.end(), [&](const FamilyInfo& i) { return i.name == name; });
    if (it == kFamilies.end()) {
      std::string valid;
      for (const FamilyInfo& i : kFamilies) valid += (valid.empty() ? "" : ", ") + std::string(i.name);
      return InvalidArgumentError(fmt::format("unknown shape family '{}' (families: {})", name, valid));
    }
    families.push_back(it->family);
  }
  return families;
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
  for (size_t i = 0; i < options.families.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (options.families[i] == options.families[j]) {
        return InvalidArgumentError(fmt::format("shape family '{}' listed twice", ShapeFamilyName(options.families[i])));
      }
    }
  }
  return Status::Ok();
}

namespace {

// The default mix: every family once, then more of ShapeNetCore's largest categories
// (tables 8.4k models, chairs 6.8k, airplanes 4.0k, cars 3.5k, sofas 3.2k, lamps 2.3k,
// benches 1.8k), so that a default set's statistics lean the way ShapeNet's do.
constexpr std::array<ShapeFamily, 32> kDefaultCycle = {
    ShapeFamily::kChair,    ShapeFamily::kTable,     ShapeFamily::kSofa,     ShapeFamily::kBed,
    ShapeFamily::kCabinet,  ShapeFamily::kBookshelf, ShapeFamily::kLamp,     ShapeFamily::kDisplay,
    ShapeFamily::kCar,      ShapeFamily::kAirplane,  ShapeFamily::kBottle,   ShapeFamily::kVase,
    ShapeFamily::kMug,      ShapeFamily::kBowl,      ShapeFamily::kBench,    ShapeFamily::kTrashBin,
    ShapeFamily::kGuitar,   ShapeFamily::kLaptop,    ShapeFamily::kTable,    ShapeFamily::kChair,
    ShapeFamily::kTable,    ShapeFamily::kChair,     ShapeFamily::kAirplane, ShapeFamily::kCar,
    ShapeFamily::kSofa,     ShapeFamily::kTable,     ShapeFamily::kChair,    ShapeFamily::kLamp,
    ShapeFamily::kAirplane, ShapeFamily::kCar,       ShapeFamily::kTable,    ShapeFamily::kBench,
};

}  // namespace

ShapeFamily FamilyOfIndex(int index, const ProceduralShapeOptions& options) {
  if (options.families.empty()) return kDefaultCycle[static_cast<size_t>(index) % kDefaultCycle.size()];
  return options.families[static_cast<size_t>(index) % options.families.size()];
}

Result<Asset> MakeProceduralShape(uint64_t seed, int index, const std::string& key,
                                  const ProceduralShapeOptions& options) {
  const std::string where = fmt::format("procedural shape {} (seed {})", index, SeedHex(seed));
  if (index < 0) return InvalidArgumentError(where + ": index must be >= 0");
  SOLID_RETURN_IF_ERROR(CheckProceduralShapeOptions(options).WithContext(where));

  const uint64_t item = MixSeed(seed, static_cast<uint64_t>(index));
  Rng geometry(item, kShapeGeometryStream);
  Rng look(item, kShapeMaterialStream);
  const ShapeFamily family = FamilyOfIndex(index, options);
  const ModelSpec spec = MakeFamilySpec(family, geometry);
  // Log-uniform inside the range, away from its ends so the rounding of counts has room.
  const double goal = std::exp(geometry.Uniform(std::log(options.min_triangles * 1.1),
                                                std::log(options.max_triangles / 1.1)));
  Result<Shape> shape = TessellateWithin(spec, options.min_triangles, options.max_triangles, goal);
  if (!shape.ok()) return shape.status().WithContext(where + " " + std::string(ShapeFamilyName(family)));

  Asset asset;
  asset.nodes.push_back(ShapeNode(*shape, key, spec.materials.size()));
  for (const MaterialSlot& slot : spec.materials) {
    double roughness = 0.5;
    const Pattern pattern = SurfacePattern(slot.surfacing, look, &roughness);
    SOLID_RETURN_IF_ERROR(AddTexturedMaterial(asset, slot.name, pattern, options.texture_size, roughness).WithContext(where));
  }
  // As ShapeNet rows carry their synset (convert.cpp), so the category survives into the catalog.
  asset.extras = {{"generator", "solid procedural"},
                  {"family", ShapeFamilyName(family)},
                  {"synset", ShapeFamilySynset(family)},
                  {"synset_name", ShapeFamilyName(family)},
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
  ShellBuilder shell;
  BuildShell(plan, shell);
  // Notches and thick walls can take a whole side: centre what is left.
  float lo_x = 1e30f, hi_x = -1e30f, lo_z = 1e30f, hi_z = -1e30f;
  for (const Primitive* p : {&shell.floor, &shell.wall, &shell.ceiling}) {
    for (size_t v = 0; v < p->positions.size(); v += 3) {
      lo_x = std::min(lo_x, p->positions[v]);
      hi_x = std::max(hi_x, p->positions[v]);
      lo_z = std::min(lo_z, p->positions[v + 2]);
      hi_z = std::max(hi_z, p->positions[v + 2]);
    }
  }
  const float mid_x = (lo_x + hi_x) / 2, mid_z = (lo_z + hi_z) / 2;
  for (Primitive* p : {&shell.floor, &shell.wall, &shell.ceiling}) {
    for (size_t v = 0; v < p->positions.size(); v += 3) {
      p->positions[v] -= mid_x;
      p->positions[v + 2] -= mid_z;
    }
  }
  shell.floor.material = 0;
  shell.wall.material = 1;
  shell.ceiling.material = 2;
  // extras.structure is how the renderer tells shell pieces apart, as for SceneNet rooms.
  asset.nodes.push_back({"floor", {std::move(shell.floor)}, {{"structure", "floor"}}});
  asset.nodes.push_back({"wall", {std::move(shell.wall)}, {{"structure", "wall"}}});
  asset.nodes.push_back({"ceiling", {std::move(shell.ceiling)}, {{"structure", "ceiling"}}});
  asset.extras = {{"generator", "solid procedural"},
                  {"family", "room"},
                  {"plan", plan.footprint},
                  {"features", plan.features},
                  {"size_m", {RoundToCentimetre(hi_x - lo_x), plan.height, RoundToCentimetre(hi_z - lo_z)}},
                  {"seed", SeedHex(seed)},
                  {"index", index},
                  {"key", key}};
  return asset;
}

}  // namespace solid::convert

