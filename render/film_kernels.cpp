// The shader's inner loops, built once per instruction set (film_kernels.h): SOLID_FILM_ISA
// names this build's namespace.
#include "film_kernels.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <numbers>

#include "instance_scene.h"
#include "lanes.h"
#include "solid/formats/random.h"
#include "streams.h"

#ifndef SOLID_FILM_ISA
#error "SOLID_FILM_ISA names the instruction set this file is built for (render/CMakeLists.txt)"
#endif

namespace solid::render::SOLID_FILM_ISA {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr float kInfinity = std::numeric_limits<float>::infinity();
constexpr float kMaxSampleRadiance = 4.0f;
constexpr float kMaxSpecularExponent = 1024.0f;
// FilterFlatLighting: the least cosine between the normals of two pixels it averages, and
// the base colour below which a pixel's lighting is not used.
constexpr float kFilterNormalCos = 0.906f;  // 25 degrees
constexpr float kDarkAlbedo = 1e-3f;
// FootprintBaseColor: the farthest of its taps from the centre, in texels, that one lookup
// at the centre stands in for.
constexpr float kFootprintTexels = 0.25f;

Vec3f Normalized(Vec3f v) {
  const float len2 = Dot(v, v);
  return len2 > 0 ? v * (1.0f / std::sqrt(len2)) : v;
}

Vec3f Rotate(const float (&m)[9], Vec3f v) {
  return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
          m[6] * v.x + m[7] * v.y + m[8] * v.z};
}

// The strata of n samples: the most square nx x ny = n.
void Strata(int n, int* nx, int* ny) {
  int x = static_cast<int>(std::sqrt(static_cast<double>(n)));
  while (n % x != 0) --x;
  *nx = x;
  *ny = n / x;
}

// A direction of the cosine-weighted hemisphere around unit n, from sample (a0, a1), in
// an orthonormal basis around n (Duff et al. 2017, branchless).
Floats3 CosineDirection(const Floats3& n, const Floats& a0, const Floats& a1) {
  const Floats r = stdx::sqrt(a0);
  const Floats sign = SignOf(n.z);
  const Floats a = -1 / (sign + n.z);
  const Floats c = n.x * n.y * a;
  const Floats3 t{1 + sign * n.x * n.x * a, sign * c, -sign * n.x};
  const Floats3 b{c, sign + n.y * n.y * a, -n.y};
  Floats cos_phi, sin_phi;
  CosSinTurn(a1, &cos_phi, &sin_phi);
  return t * (r * cos_phi) + b * (r * sin_phi) + n * stdx::sqrt(1 - a0);
}

// A triangle of the scene in world space with what shading a point of it needs that does
// not depend on the point. Neighbouring pixels mostly hit the same triangle (a wall is
// two), so the shader keeps the triangles it met last (TriangleCache).
struct WorldTriangle {
  uint32_t instance = UINT32_MAX, prim = 0;
  Vec3f corners[3];
  Vec3f normals[3];  // the vertices' shading normals, rotated, not normalised (zero: none)
  Vec3f geometric_normal;  // unit, on the winding's side
  float corner_uv[6];
  const gltf::Material* material = nullptr;
  const DecodedTextures* textures = nullptr;
  // FootprintBaseColor's terms: the edges from corner 0, their cross product, and the
  // inverse determinant of the barycentric solve (0 for a degenerate triangle).
  Vec3f e1, e2, plane_normal;
  float d00 = 0, d01 = 0, d11 = 0, inverse = 0;
};

WorldTriangle MakeWorldTriangle(const ShadingScene& scene, const SurfaceFrame* frames,
                                uint32_t instance, uint32_t prim) {
  const ShadingSurface& s = scene.surfaces[instance];
  const SurfaceFrame& f = frames[instance];
  const Vec3f translation{f.translation[0], f.translation[1], f.translation[2]};
  const MeshGeometry& m = *s.mesh;
  WorldTriangle t;
  t.instance = instance;
  t.prim = prim;
  const uint32_t corners[3] = {m.indices[3 * prim], m.indices[3 * prim + 1], m.indices[3 * prim + 2]};
  Vec3f object[3];
  for (int k = 0; k < 3; ++k) {
    const uint32_t i = corners[k];
    object[k] = {m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]};
    t.corners[k] = Rotate(f.rotation, object[k] * f.scale) + translation;
    // Instances scale uniformly, so the normals' inverse transpose is the rotation itself.
    t.normals[k] = Rotate(f.rotation, Vec3f{m.normals[3 * i], m.normals[3 * i + 1], m.normals[3 * i + 2]});
    t.corner_uv[2 * k] = m.uvs[2 * i];
    t.corner_uv[2 * k + 1] = m.uvs[2 * i + 1];
  }
  t.geometric_normal = Normalized(Rotate(f.rotation, Cross(object[1] - object[0], object[2] - object[0])));
  const uint32_t material = m.triangle_material[prim];
  if (material < s.materials->size()) t.material = &(*s.materials)[material];
  t.textures = s.textures;
  t.e1 = t.corners[1] - t.corners[0];
  t.e2 = t.corners[2] - t.corners[0];
  t.plane_normal = Cross(t.e1, t.e2);
  t.d00 = Dot(t.e1, t.e1);
  t.d01 = Dot(t.e1, t.e2);
  t.d11 = Dot(t.e2, t.e2);
  const float determinant = t.d00 * t.d11 - t.d01 * t.d01;
  t.inverse = determinant > 0 ? 1 / determinant : 0;
  return t;
}

// The world triangles a thread met last, direct-mapped by (instance, triangle).
class TriangleCache {
 public:
  TriangleCache() : entries_(kEntries) {}
  const WorldTriangle& Get(const ShadingScene& scene, const SurfaceFrame* frames, uint32_t instance,
                           uint32_t prim) {
    const uint32_t slot = ((prim * 0x9E3779B1u) ^ (instance * 0x85EBCA77u)) >> (32 - kBits);
    WorldTriangle& entry = entries_[slot];
    if (entry.instance != instance || entry.prim != prim) entry = MakeWorldTriangle(scene, frames, instance, prim);
    return entry;
  }

 private:
  static constexpr int kBits = 8;
  static constexpr size_t kEntries = size_t{1} << kBits;
  std::vector<WorldTriangle> entries_;
};

struct Hit {
  Vec3f position, geometric_normal, shading_normal;
  float u = 0, v = 0;
  const WorldTriangle* triangle = nullptr;
};

// The point of `t` at barycentrics (b1, b2), seen along dir.
Hit Surface(const WorldTriangle& t, float b1, float b2, Vec3f dir) {
  const float b0 = 1.0f - b1 - b2;
  Hit h;
  h.triangle = &t;
  // From the barycentrics rather than origin + t * dir: the error then does not grow
  // with the distance to the camera, and shadow rays need a smaller offset.
  h.position = t.corners[0] * b0 + t.corners[1] * b1 + t.corners[2] * b2;
  h.geometric_normal = t.geometric_normal;
  const Vec3f ns = t.normals[0] * b0 + t.normals[1] * b1 + t.normals[2] * b2;
  h.shading_normal = Dot(ns, ns) > 1e-12f ? Normalized(ns) : h.geometric_normal;
  // Two-sided: face the viewer; the shading normal stays on the geometric side.
  if (Dot(h.geometric_normal, dir) > 0) h.geometric_normal = h.geometric_normal * -1.0f;
  if (Dot(h.shading_normal, h.geometric_normal) < 0) h.shading_normal = h.shading_normal * -1.0f;
  h.u = t.corner_uv[0] * b0 + t.corner_uv[2] * b1 + t.corner_uv[4] * b2;
  h.v = t.corner_uv[1] * b0 + t.corner_uv[3] * b1 + t.corner_uv[5] * b2;
  return h;
}

void SetRayHit(RTCRayHit16* r, int i, Vec3f origin, Vec3f dir, float tnear, float tfar) {
  SetRayLane(&r->ray, i, origin, dir, tnear, tfar);
  r->hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
  r->hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
}

bool AnyValid(const int* valid) {
  for (int i = 0; i < kLanes; ++i) {
    if (valid[i]) return true;
  }
  return false;
}

// One pixel's sampler: stratified primary jitter, and per further 2D dimension a
// shuffled copy of the same strata, so that light points and ambient directions are
// stratified over the pixel too without correlating with the jitter.
// A stratum's index: std::vector<uint16_t>'s code would be shared with other files (film_kernels.h).
struct Stratum {
  uint16_t index;
};

class PixelSampler {
 public:
  // For up to `samples` samples of each of `dimensions` 2D dimensions.
  PixelSampler(int samples, int dimensions) : dims_(dimensions) {
    perm_.resize(static_cast<size_t>(dimensions) * samples);
  }
  // Starts a pixel of nx x ny samples (at most `samples`) drawing from `rng`.
  void Start(Rng* rng, int nx, int ny) {
    rng_ = rng;
    nx_ = nx;
    ny_ = ny;
    const int n = nx_ * ny_;
    for (int d = 0; d < dims_; ++d) {
      Stratum* p = &perm_[static_cast<size_t>(d) * n];
      for (int i = 0; i < n; ++i) p[i].index = static_cast<uint16_t>(i);
      // Multiply-shift instead of Rng::Index: its two 64-bit divisions per draw cost
      // more than the shading here, and the bias (below 2^-22 for n <= 1024) is harmless.
      for (int i = n - 1; i > 0; --i) {
        const auto j = static_cast<int>((uint64_t{rng->Next()} * static_cast<uint64_t>(i + 1)) >> 32);
        std::swap(p[i], p[j]);
      }
    }
  }
  // Sample s of dimension d (d = -1: the primary jitter), in [0, 1)^2.
  std::array<float, 2> Get(int s, int d) {
    const double u = rng_->Uniform(), v = rng_->Uniform();
    // A flat pixel's one sample has one stratum: no integer division (tens of cycles,
    // four per pixel).
    if (nx_ == 1 && ny_ == 1) return {static_cast<float>(u), static_cast<float>(v)};
    const int stratum = d < 0 ? s : perm_[static_cast<size_t>(d) * nx_ * ny_ + s].index;
    const double a = (stratum % nx_ + u) / nx_;
    const double b = (stratum / nx_ + v) / ny_;
    return {static_cast<float>(a), static_cast<float>(b)};
  }

 private:
  int nx_ = 1, ny_ = 1, dims_;
  std::vector<Stratum> perm_;
  Rng* rng_ = nullptr;
};

// A lane's generator, default-constructible for std::array.
struct LaneRng {
  Rng rng{0, kShadingStream};
};

// ToneMap of kWidth values at once (EncodeFilm's 921,600 per 640x480 image).
Floats ToneMapLanes(const Floats& v) {
  // Narkowicz's fit of the ACES filmic curve: highlights roll off instead of
  // clipping, as under the reference's Filmic view transform.
  const Floats curve = (v * (2.51f * v + 0.03f)) / (v * (2.43f * v + 0.59f) + 0.14f);
  Floats out = 1;
  where(curve < 1, out) = curve;
  where(!(v > 0), out) = 0;
  return out;
}

const DecodedTextures::Texture* TextureOf(const gltf::Material* material, const DecodedTextures* textures) {
  if (material == nullptr || textures == nullptr || !material->base_color_texture.has_value()) return nullptr;
  const uint32_t t = *material->base_color_texture;
  return t < textures->textures.size() ? &textures->textures[t] : nullptr;
}

Vec3f Factor(const gltf::Material* material) {
  if (material == nullptr) return {1, 1, 1};
  return {material->base_color[0], material->base_color[1], material->base_color[2]};
}

// The bilinear, repeating lookup of `tex` at uv, linear.
Vec3f SampleTexture(const DecodedTextures::Texture& tex, float u, float v) {
  if (!std::isfinite(u) || !std::isfinite(v)) u = v = 0;
  // glTF's uv (0, 0) is the top-left corner of the image; texel centres at +0.5.
  const float x = u * tex.width - 0.5f, y = v * tex.height - 0.5f;
  const float fx0 = std::floor(x), fy0 = std::floor(y);
  const float ax = x - fx0, ay = y - fy0;
  // c is a whole number. Most lie within the texture; within int64's range (any uv a
  // mesh holds) the wrap is integer arithmetic; beyond it, fmod gives the same remainder.
  auto wrap = [](float c, int n) {
    if (c >= 0 && c < static_cast<float>(n)) return static_cast<int>(c);
    if (std::fabs(c) < 0x1p62f) {
      const auto r = static_cast<int>(static_cast<int64_t>(c) % n);
      return r < 0 ? r + n : r;
    }
    const double r = std::fmod(static_cast<double>(c), static_cast<double>(n));
    const int i = static_cast<int>(r < 0 ? r + n : r);
    return i >= n ? 0 : i;
  };
  const int x0 = wrap(fx0, tex.width), y0 = wrap(fy0, tex.height);
  const int x1 = x0 + 1 == tex.width ? 0 : x0 + 1, y1 = y0 + 1 == tex.height ? 0 : y0 + 1;
  const std::array<float, 256>& lut = SrgbLinearTable();
  auto texel = [&](int tx, int ty) {
    const uint8_t* p = &tex.rgb[3 * (static_cast<size_t>(ty) * tex.width + tx)];
    return Vec3f{lut[p[0]], lut[p[1]], lut[p[2]]};
  };
  const Vec3f top = texel(x0, y0) * (1 - ax) + texel(x1, y0) * ax;
  const Vec3f bottom = texel(x0, y1) * (1 - ax) + texel(x1, y1) * ax;
  return top * (1 - ay) + bottom * ay;
}

Vec3f BaseColorOf(const gltf::Material* material, const DecodedTextures* textures, float u, float v) {
  const DecodedTextures::Texture* tex = TextureOf(material, textures);
  return tex == nullptr ? Factor(material) : Factor(material) * SampleTexture(*tex, u, v);
}

Vec3f MeanBaseColorOf(const gltf::Material* material, const DecodedTextures* textures) {
  const DecodedTextures::Texture* tex = TextureOf(material, textures);
  return tex == nullptr ? Factor(material) : Factor(material) * tex->mean_linear;
}

// The base colour over the footprint of the pixel whose centre ray from `eye` hit `h`:
// the mean of 2x2 taps at the footprint's quarter points, found by intersecting the rays
// through the neighbouring pixel centres (dir_dx, dir_dy) with the hit's plane (ray
// differentials). A flat pixel traces one camera ray; this filters the texture detail
// within it as an edge pixel's four jittered camera rays do, at the cost of three more
// texture lookups instead of three more camera rays.
Vec3f FootprintBaseColor(const Hit& h, Vec3f eye, Vec3f dir_dx, Vec3f dir_dy) {
  const WorldTriangle& t = *h.triangle;
  const DecodedTextures::Texture* tex = TextureOf(t.material, t.textures);
  if (tex == nullptr) return Factor(t.material);
  if (!(t.inverse > 0)) return BaseColorOf(t.material, t.textures, h.u, h.v);
  const float plane = Dot(t.corners[0] - eye, t.plane_normal);
  auto uv_along = [&](Vec3f dir, float* u, float* v) {
    const float distance = plane / Dot(dir, t.plane_normal);
    if (!(distance > 0) || !std::isfinite(distance)) return false;
    const Vec3f q = eye + dir * distance - t.corners[0];
    const float d20 = Dot(q, t.e1), d21 = Dot(q, t.e2);
    const float b1 = (t.d11 * d20 - t.d01 * d21) * t.inverse, b2 = (t.d00 * d21 - t.d01 * d20) * t.inverse;
    const float b0 = 1 - b1 - b2;
    *u = t.corner_uv[0] * b0 + t.corner_uv[2] * b1 + t.corner_uv[4] * b2;
    *v = t.corner_uv[1] * b0 + t.corner_uv[3] * b1 + t.corner_uv[5] * b2;
    return std::isfinite(*u) && std::isfinite(*v);
  };
  float ux = 0, vx = 0, uy = 0, vy = 0;
  if (!uv_along(dir_dx, &ux, &vx) || !uv_along(dir_dy, &uy, &vy)) return BaseColorOf(t.material, t.textures, h.u, h.v);
  const float dux = ux - h.u, dvx = vx - h.v, duy = uy - h.u, dvy = vy - h.v;
  // Taps within kFootprintTexels of the centre: their mean differs from the centre's
  // bilinear value only by the texture's curvature over a quarter texel (not at all for an
  // axis-aligned footprint inside one texel cell), so one lookup does for four. On
  // bench/render_quality_bench's layouts a third of flat pixels, for 0.02 dB.
  const float reach_u = (std::fabs(dux) + std::fabs(duy)) * 0.25f * static_cast<float>(tex->width);
  const float reach_v = (std::fabs(dvx) + std::fabs(dvy)) * 0.25f * static_cast<float>(tex->height);
  if (reach_u < kFootprintTexels && reach_v < kFootprintTexels) {
    return Factor(t.material) * SampleTexture(*tex, h.u, h.v);
  }
  Vec3f sum;
  for (const float sx : {-0.25f, 0.25f}) {
    for (const float sy : {-0.25f, 0.25f}) {
      sum = sum + SampleTexture(*tex, h.u + sx * dux + sy * duy, h.v + sx * dvx + sy * dvy);
    }
  }
  return Factor(t.material) * (sum * 0.25f);
}

// Where FilterFlatLighting averages: pixels p + d * step for d in [lo, hi] of the pixels
// p, p + 1, ..., that lie on their surfaces (see there). Sums go in ascending d, so that
// every lane adds what the scalar mean (Average) adds in the same order.
struct SurfacePlanes {
  const int32_t* key;
  const float* depth;
  const float* normal[3];
};

// The mean of `in` over the pixels on usable pixel p's surface in [p + lo * step, p + hi * step].
Vec3f Average(const SurfacePlanes& g, const std::array<float*, 3>& in, size_t p, ptrdiff_t step, int lo,
              int hi) {
  Vec3f sum;
  int n = 0;
  for (int d = lo; d <= hi; ++d) {
    const auto q = static_cast<size_t>(static_cast<ptrdiff_t>(p) + d * step);
    if (d != 0) {
      const Vec3f nq{g.normal[0][q], g.normal[1][q], g.normal[2][q]};
      const Vec3f np{g.normal[0][p], g.normal[1][p], g.normal[2][p]};
      if (!(g.key[q] == g.key[p] &&
            std::fabs(g.depth[q] - g.depth[p]) <= kDepthStep * static_cast<float>(std::abs(d)) * g.depth[p] &&
            Dot(nq, np) >= kFilterNormalCos)) {
        continue;
      }
    }
    sum = sum + Vec3f{in[0][q], in[1][q], in[2][q]};
    ++n;
  }
  return sum * (1.0f / static_cast<float>(n));
}

// Average for the kWidth pixels from p on, which share lo and hi; lanes whose pixel is not
// usable hold a value nothing reads.
void AverageLanes(const SurfacePlanes& g, const std::array<float*, 3>& in, size_t p, ptrdiff_t step, int lo,
                  int hi, Floats3* mean) {
  auto load = [](const float* plane, size_t at) { return Floats(plane + at, stdx::element_aligned); };
  auto load_key = [&](size_t at) { return Ints(g.key + at, stdx::element_aligned); };
  const Ints kp = load_key(p);
  const Floats dp = load(g.depth, p);
  const Floats3 np{load(g.normal[0], p), load(g.normal[1], p), load(g.normal[2], p)};
  Floats3 sum{0, 0, 0};
  Floats n = 0;
  for (int d = lo; d <= hi; ++d) {
    const auto q = static_cast<size_t>(static_cast<ptrdiff_t>(p) + d * step);
    const Floats3 value{load(in[0], q), load(in[1], q), load(in[2], q)};
    if (d == 0) {
      sum = sum + value;
      n = n + 1;
      continue;
    }
    // A nonzero integer converts to a nonzero float: the keys are equal where this is 0.
    const FloatMask same = stdx::static_simd_cast<Floats>(load_key(q) ^ kp) == 0 &&
                           stdx::abs(load(g.depth, q) - dp) <= kDepthStep * static_cast<float>(std::abs(d)) * dp &&
                           Dot(Floats3{load(g.normal[0], q), load(g.normal[1], q), load(g.normal[2], q)}, np) >=
                               kFilterNormalCos;
    sum.Where(same, sum + value);
    where(same, n) = n + 1;
  }
  *mean = sum * (1 / n);
}

uint64_t ShadeTiles(const FilmJob& job) {
  const ShadingScene& scene = *job.scene;
  const Camera& camera = *job.camera;
  const int width = job.width, height = job.height;
  const int spp = job.spp;
  const bool adaptive = job.edges != nullptr;
  const MaskPassResult::CentreHit* centre_hits = adaptive ? job.centre_hits : nullptr;
  const int flat_spp = FlatSamples(spp);
  const SurfaceFrame* frames = job.frames;
  const float near = static_cast<float>(job.near);
  Film& film = *job.film;
  FlatGuides& guides = *job.guides;
  int nx = 1, ny = 1, flat_nx = 1, flat_ny = 1;
  Strata(spp, &nx, &ny);
  Strata(flat_spp, &flat_nx, &flat_ny);
  const Vec3f eye = job.eye, direction_at_origin = job.direction_at_origin;
  const Vec3f direction_per_x = job.direction_per_x, direction_per_y = job.direction_per_y;
  const int dims = static_cast<int>(scene.lights.size()) + 1;  // + ambient occlusion
  const int tiles_x = (width + kTile - 1) / kTile, tile_rows = (height + kTile - 1) / kTile;
  // What one lane (pixel) carries from its camera ray's hit to its light and ambient rays
  // that the loops over lanes do not read in columns (LaneColumns).
  struct Lane {
    Vec3f base;
    float depth = 0;
    uint32_t instance = 0;
    int samples = 0;
    bool covered = false, ambient_lit = false, edge = true;
  };

  // What the loops over lanes read of each lane, in columns (lanes.h).
  struct LaneColumns {
    alignas(64) Column3 sum, radiance, diffuse, f0, n, ng, wo, origin, ambient;
    alignas(64) Column exponent, specular_norm;
  };

  RTCIntersectContext primary;
  rtcInitIntersectContext(&primary);
  primary.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  RTCIntersectContext secondary;
  rtcInitIntersectContext(&secondary);
  // Each pixel keeps its own generator and strata, so a pixel's draws do not depend on
  // its tile, its thread or the other pixels' hits.
  std::vector<PixelSampler> samplers(kLanes, PixelSampler(std::max(spp, flat_spp), dims));
  std::array<LaneRng, kLanes> rngs;
  TriangleCache triangles;
  std::array<Lane, kLanes> lanes;
  LaneColumns columns{};
  alignas(64) int inside[kLanes], hit[kLanes], active[kLanes], valid[kLanes], traced[kLanes];
  bool known[kLanes];
  alignas(64) float wi[3][kLanes], irradiance[kLanes], draw[2][kLanes];
  RTCRayHit16 rays;
  RTCRay16 shadow;
  // The shadow rays' fields that never change; the loop over the lights sets the rest.
  for (int i = 0; i < kLanes; ++i) SetRayLane(&shadow, i, Vec3f{}, Vec3f{}, 0.0f);
  uint64_t traced_rays = 0;
  auto count = [&traced_rays](const int* mask) {
    for (int i = 0; i < kLanes; ++i) traced_rays += mask[i] != 0;
  };
  for (int ty; (ty = job.next_tile_row->fetch_add(1, std::memory_order_relaxed)) < tile_rows;) {
    for (int tx = 0; tx < tiles_x; ++tx) {
      int tile_spp = 0;
      for (int i = 0; i < kLanes; ++i) {
        const int x = tx * kTile + i % kTile, y = ty * kTile + i / kTile;
        inside[i] = x < width && y < height ? -1 : 0;
        hit[i] = 0;
        if (!inside[i]) continue;
        rngs[i].rng = Rng(MixSeed(job.seed, static_cast<size_t>(y) * width + x), kShadingStream);
        // The rest of a lane is written by its hit before anything reads it.
        for (int k = 0; k < 3; ++k) columns.sum[k][i] = 0;
        lanes[i].covered = false;
        lanes[i].edge = !adaptive || job.edges[static_cast<size_t>(y) * width + x] != 0;
        lanes[i].samples = lanes[i].edge ? spp : flat_spp;
        if (lanes[i].edge) {
          samplers[i].Start(&rngs[i].rng, nx, ny);
        } else {
          samplers[i].Start(&rngs[i].rng, flat_nx, flat_ny);
        }
        tile_spp = std::max(tile_spp, lanes[i].samples);
      }
      for (int s = 0; s < tile_spp; ++s) {
        // Edge pixels trace a camera ray per sample; flat ones one, through their centre,
        // whose hit all their samples share, or take that ray's hit from the mask pass.
        for (int i = 0; i < kLanes; ++i) {
          traced[i] = inside[i] && (s == 0 || (lanes[i].edge && s < lanes[i].samples)) ? -1 : 0;
          known[i] = traced[i] && !lanes[i].edge && centre_hits != nullptr;
          if (known[i]) traced[i] = 0;
          if (!traced[i]) continue;
          const auto jitter = lanes[i].edge ? samplers[i].Get(s, -1) : std::array<float, 2>{0.5f, 0.5f};
          const int x = tx * kTile + i % kTile, y = ty * kTile + i / kTile;
          const Vec3f dir = Normalized(ToFloat(RayDirection(camera, x + jitter[0], y + jitter[1])));
          SetRayHit(&rays, i, eye, dir, near, kInfinity);
        }
        count(traced);
        if (AnyValid(traced)) Intersect16(traced, scene.scene, &primary, &rays);
        for (int i = 0; i < kLanes; ++i) {
          active[i] = 0;
          if (!inside[i] || s >= lanes[i].samples) continue;
          Lane& lane = lanes[i];
          const int x = tx * kTile + i % kTile, y = ty * kTile + i / kTile;
          const MaskPassResult::CentreHit* centre =
              known[i] ? &centre_hits[static_cast<size_t>(y) * width + x] : nullptr;
          if (traced[i]) hit[i] = rays.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID ? -1 : 0;
          if (known[i]) hit[i] = centre->surface != MaskPassResult::CentreHit::kNothing ? -1 : 0;
          if (!hit[i]) {
            columns.sum[0][i] += scene.background.x;
            columns.sum[1][i] += scene.background.y;
            columns.sum[2][i] += scene.background.z;
            continue;
          }
          active[i] = -1;
          for (int k = 0; k < 3; ++k) columns.radiance[k][i] = 0;
          if (!traced[i] && !known[i]) continue;
          lane.covered = true;
          lane.instance = known[i] ? centre->surface : rays.hit.instID[0][i];
          lane.depth = known[i] ? centre->distance : rays.ray.tfar[i];
          const Vec3f through_centre = direction_at_origin + direction_per_x * (static_cast<float>(x) + 0.5f) +
                                       direction_per_y * (static_cast<float>(y) + 0.5f);
          const Vec3f dir = known[i] ? Normalized(through_centre)
                                     : Vec3f{rays.ray.dir_x[i], rays.ray.dir_y[i], rays.ray.dir_z[i]};
          const WorldTriangle& triangle =
              triangles.Get(scene, frames, lane.instance, known[i] ? centre->triangle : rays.hit.primID[i]);
          const Hit h = known[i] ? Surface(triangle, centre->u, centre->v, dir)
                                 : Surface(triangle, rays.hit.u[i], rays.hit.v[i], dir);
          if (lane.edge) {
            lane.base = BaseColorOf(triangle.material, triangle.textures, h.u, h.v);
          } else {
            lane.base =
                FootprintBaseColor(h, eye, through_centre + direction_per_x, through_centre + direction_per_y);
          }
          const gltf::Material* material = triangle.material;
          const float metallic = material != nullptr ? std::clamp(material->metallic, 0.0f, 1.0f) : 0.0f;
          const float roughness = material != nullptr ? std::clamp(material->roughness, 0.0f, 1.0f) : 1.0f;
          const Vec3f diffuse = lane.base * ((1 - metallic) / kPi);
          const float alpha2 = std::max(roughness * roughness * roughness * roughness, 1e-6f);
          const float exponent = std::clamp(2.0f / alpha2 - 2.0f, 1.0f, kMaxSpecularExponent);
          const float extent = std::max({std::fabs(h.position.x), std::fabs(h.position.y), std::fabs(h.position.z)});
          const Vec3f ambient = scene.ambient + scene.sky * ((1 + h.shading_normal.z) / 2);
          lane.ambient_lit = Dot(ambient, ambient) > 0 && Dot(diffuse, diffuse) > 0;
          SetLane(columns.diffuse, i, diffuse);
          SetLane(columns.f0, i, Vec3f{0.04f, 0.04f, 0.04f} * (1 - metallic) + lane.base * metallic);
          columns.exponent[i] = exponent;
          columns.specular_norm[i] = (exponent + 8) / (8 * kPi);
          SetLane(columns.n, i, h.shading_normal);
          SetLane(columns.ng, i, h.geometric_normal);
          SetLane(columns.wo, i, dir * -1.0f);
          SetLane(columns.origin, i, h.position + h.geometric_normal * (1e-4f * (1 + extent)));
          SetLane(columns.ambient, i, ambient);
        }
        if (!AnyValid(active)) continue;
        for (size_t l = 0; l < scene.lights.size(); ++l) {
          const ShadingLight& light = scene.lights[l];
          const bool area = light.area;
          // An area light's point for each lane: a stratified sample of its square.
          if (area) {
            for (int i = 0; i < kLanes; ++i) {
              if (!active[i]) continue;
              const std::array<float, 2> a = samplers[i].Get(s, static_cast<int>(l));
              draw[0][i] = a[0], draw[1][i] = a[1];
            }
          }
          // What the light sends from its point to each lane's surface point before the
          // shadow ray. Cycles: an area light's radiance is P / (4 A), a point light's
          // intensity P / (4 pi^2). Inactive lanes hold stale values and are masked.
          const float power = area ? light.power_w / 4 : light.power_w / (4 * kPi * kPi);
          for (int c = 0; c < kLanes; c += kWidth) {
            const FloatMask active_lanes = IsSet(active, c);
            if (stdx::none_of(active_lanes)) {
              StoreMask(active_lanes, valid, c);
              continue;
            }
            const Floats3 origin = Load3(columns.origin, c);
            Floats3 point = Splat3(light.position);
            if (area) {
              point = point + Splat3(light.u_axis) * (2 * Load(draw[0], c) - 1) +
                      Splat3(light.v_axis) * (2 * Load(draw[1], c) - 1);
            }
            Floats3 w = point - origin;
            Floats d2 = Dot(w, w);
            where(d2 < 1e-4f, d2) = 1e-4f;
            const Floats d = stdx::sqrt(d2);
            w = w * (1 / d);
            const Floats cos_s = Dot(Load3(columns.n, c), w);
            // Below the geometric surface the shadow ray would hit its own triangle.
            const Floats cos_g = Dot(Load3(columns.ng, c), w);
            const Floats cos_l = -Dot(Splat3(light.normal), w);
            FloatMask lit = active_lanes && !(cos_s <= 0) && !(cos_g <= 0);
            if (area) lit = lit && !(cos_l <= 0);
            StoreMask(lit, valid, c);
            Store((area ? power * cos_l : Floats(power)) * cos_s / d2, irradiance, c);
            Store3(w, wi, c);
            Store3(origin, shadow.org_x, shadow.org_y, shadow.org_z, c);
            Store3(w, shadow.dir_x, shadow.dir_y, shadow.dir_z, c);
            Store(Floats(0), shadow.tnear, c);
            Store(d, shadow.tfar, c);
          }
          const bool shadowed = !light.at_eye && AnyValid(valid);
          if (shadowed) {
            count(valid);
            Occluded16(valid, scene.scene, &secondary, &shadow);
          }
          // Light arriving along wi with this irradiance, reflected towards the camera.
          for (int c = 0; c < kLanes; c += kWidth) {
            FloatMask lit = IsSet(valid, c);
            if (shadowed) lit = lit && !(Load(shadow.tfar, c) < 0);
            // Lanes the light does not reach (shadowed, facing away, no hit) add nothing.
            if (stdx::none_of(lit)) continue;
            const Floats3 n = Load3(columns.n, c);
            const Floats3 half = Normalized(Load3(wi, c) + Load3(columns.wo, c));
            Floats cos_h = Dot(n, half);
            where(cos_h < 0, cos_h) = 0;
            const Floats spec = Load(columns.specular_norm, c) * Pow(cos_h, Load(columns.exponent, c));
            const Floats e = Load(irradiance, c);
            const Floats3 reflected = (Load3(columns.diffuse, c) + Load3(columns.f0, c) * spec) * e;
            Floats3 radiance = Load3(columns.radiance, c);
            radiance.Where(lit, radiance + reflected);
            Store3(radiance, columns.radiance, c);
          }
        }
        for (int i = 0; i < kLanes; ++i) {
          valid[i] = 0;
          if (!active[i] || !lanes[i].ambient_lit) continue;
          const std::array<float, 2> a = samplers[i].Get(s, dims - 1);
          draw[0][i] = a[0], draw[1][i] = a[1];
          valid[i] = -1;
        }
        const float range = scene.ambient_occlusion_m;
        for (int c = 0; c < kLanes; c += kWidth) {
          const FloatMask lit = IsSet(valid, c);
          if (stdx::none_of(lit)) {
            StoreMask(lit, traced, c);
            continue;
          }
          const Floats3 n = Load3(columns.n, c);
          const Floats a0 = Load(draw[0], c), a1 = Load(draw[1], c);
          const Floats3 wa = CosineDirection(n, a0, a1);
          // A direction under the geometric surface (smooth-shaded silhouettes) counts as open.
          StoreMask(lit && !(Dot(wa, Load3(columns.ng, c)) <= 0), traced, c);
          Store3(Load3(columns.origin, c), rays.ray.org_x, rays.ray.org_y, rays.ray.org_z, c);
          Store3(wa, rays.ray.dir_x, rays.ray.dir_y, rays.ray.dir_z, c);
          Store(Floats(0), rays.ray.tnear, c);
          Store(Floats(range), rays.ray.tfar, c);
        }
        for (int i = 0; i < kLanes; ++i) {
          if (!traced[i]) continue;
          rays.ray.time[i] = 0;
          rays.ray.mask[i] = UINT32_MAX;
          rays.ray.id[i] = 0;
          rays.ray.flags[i] = 0;
          rays.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
          rays.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
        }
        count(traced);
        if (AnyValid(traced)) Intersect16(traced, scene.scene, &secondary, &rays);
        for (int c = 0; c < kLanes; c += kWidth) {
          // Obscurance rather than binary occlusion: a blocker at distance t lets t / range
          // through (open = t / range), which is much less noisy at a few rays per pixel.
          Floats open = 1;
          const FloatMask blocked = IsSet(traced, c) && IsHit(rays.hit.geomID, c);
          where(blocked, open) = Load(rays.ray.tfar, c) / range;
          Floats3 radiance = Load3(columns.radiance, c);
          radiance.Where(IsSet(valid, c),
                         radiance + Load3(columns.diffuse, c) * (kPi * open) * Load3(columns.ambient, c));
          // A single sample brighter than kMaxSampleRadiance would whiten its pixel alone (a firefly).
          for (Floats* r : {&radiance.x, &radiance.y, &radiance.z}) {
            where(kMaxSampleRadiance < *r, *r) = kMaxSampleRadiance;
          }
          Floats3 sum = Load3(columns.sum, c);
          sum.Where(IsSet(active, c), sum + radiance);
          Store3(sum, columns.sum, c);
        }
      }
      for (int i = 0; i < kLanes; ++i) {
        if (!inside[i]) continue;
        const Lane& lane = lanes[i];
        const float inv = 1.0f / static_cast<float>(lane.samples);
        const size_t pixel = static_cast<size_t>(ty * kTile + i / kTile) * width + tx * kTile + i % kTile;
        film.rgb[3 * pixel] = columns.sum[0][i] * inv;
        film.rgb[3 * pixel + 1] = columns.sum[1][i] * inv;
        film.rgb[3 * pixel + 2] = columns.sum[2][i] * inv;
        film.covered[pixel] = lane.covered ? 1 : 0;
        if (!adaptive) continue;
        guides.surface[pixel] = !lane.edge && lane.covered ? lane.instance : kNoSurface;
        if (guides.surface[pixel] != kNoSurface) {
          guides.depth[pixel] = lane.depth;
          guides.normal[pixel] = {columns.n[0][i], columns.n[1][i], columns.n[2][i]};
          guides.albedo[pixel] = lane.base;
        }
      }
    }
  }
  return traced_rays;
}

void FilterKeys(const FilterJob& job, int y) {
  const FlatGuides& guides = *job.guides;
  const Film* film = job.film;
  const int width = film->width;
  for (size_t p = static_cast<size_t>(y) * width, end = p + width; p < end; ++p) {
    const Vec3f a = guides.albedo[p];
    const bool usable =
        guides.surface[p] != kNoSurface && a.x > kDarkAlbedo && a.y > kDarkAlbedo && a.z > kDarkAlbedo;
    job.key[p] = usable ? static_cast<int32_t>(guides.surface[p]) : -1;
    const Vec3f n = usable ? guides.normal[p] : Vec3f{};
    const Vec3f l = usable ? Vec3f{film->rgb[3 * p] / a.x, film->rgb[3 * p + 1] / a.y, film->rgb[3 * p + 2] / a.z}
                           : Vec3f{};
    job.normal[0][p] = n.x, job.normal[1][p] = n.y, job.normal[2][p] = n.z;
    job.lighting[0][p] = l.x, job.lighting[1][p] = l.y, job.lighting[2][p] = l.z;
  }
}

// Separable: a box of 2 kFlatFilterRadius + 1 pixels along rows, then along columns, each
// over the pixels on the same surface. On an open surface that is the square box; at
// its borders and around other objects it shrinks to what lies on the surface. Both
// passes go row by row, which keeps the column pass's reads in cache.
void FilterAcross(const FilterJob& job, int y) {
  constexpr int r = kFlatFilterRadius;
  const int width = job.film->width;
  const SurfacePlanes g{job.key, job.guides->depth.data(), {job.normal[0], job.normal[1], job.normal[2]}};
  const size_t row = static_cast<size_t>(y) * width;
  auto scalar = [&](int x) {
    const size_t p = row + x;
    if (job.key[p] == -1) return;
    const Vec3f mean = Average(g, job.lighting, p, 1, std::max(-r, -x), std::min(r, width - 1 - x));
    job.across[0][p] = mean.x, job.across[1][p] = mean.y, job.across[2][p] = mean.z;
  };
  int x = 0;
  for (; x < std::min(r, width); ++x) scalar(x);
  // Whole vectors of pixels whose boxes lie inside the row.
  for (; x + kWidth - 1 + r < width; x += kWidth) {
    Floats3 mean;
    AverageLanes(g, job.lighting, row + x, 1, -r, r, &mean);
    mean.x.copy_to(job.across[0] + row + x, stdx::element_aligned);
    mean.y.copy_to(job.across[1] + row + x, stdx::element_aligned);
    mean.z.copy_to(job.across[2] + row + x, stdx::element_aligned);
  }
  for (; x < width; ++x) scalar(x);
}

void FilterDown(const FilterJob& job, int y) {
  constexpr int r = kFlatFilterRadius;
  const FlatGuides& guides = *job.guides;
  Film* film = job.film;
  const int width = film->width, height = film->height;
  const SurfacePlanes g{job.key, guides.depth.data(), {job.normal[0], job.normal[1], job.normal[2]}};
  const size_t row = static_cast<size_t>(y) * width;
  const int lo = std::max(-r, -y), hi = std::min(r, height - 1 - y);
  auto put = [&](size_t p, Vec3f mean) {
    if (job.key[p] == -1) return;
    const Vec3f radiance = mean * guides.albedo[p];
    film->rgb[3 * p] = radiance.x;
    film->rgb[3 * p + 1] = radiance.y;
    film->rgb[3 * p + 2] = radiance.z;
  };
  int x = 0;
  for (; x + kWidth <= width; x += kWidth) {
    Floats3 mean;
    AverageLanes(g, job.across, row + x, width, lo, hi, &mean);
    for (int k = 0; k < kWidth; ++k) put(row + x + k, {mean.x[k], mean.y[k], mean.z[k]});
  }
  for (; x < width; ++x) put(row + x, Average(g, job.across, row + x, width, lo, hi));
}

void Encode(const float* linear, size_t n, uint8_t* out) {
  const std::array<float, 255>& thresholds = SrgbThresholds();
  const std::array<uint8_t, kCodeBuckets + 1>& start = SrgbCodeBuckets();
  auto encode = [&](size_t i, float v) {  // v = ToneMap(linear[i]), in [0, 1]
    // The count of thresholds at or below v, from its bucket's first code on.
    int code = start[static_cast<size_t>(v * kCodeBuckets)];
    while (code < 255 && thresholds[code] <= v) ++code;
    out[i] = static_cast<uint8_t>(code);
  };
  size_t i = 0;
  for (; i + kWidth <= n; i += kWidth) {
    const Floats v = ToneMapLanes(Floats(&linear[i], stdx::element_aligned));
    for (int k = 0; k < kWidth; ++k) encode(i + k, v[k]);
  }
  for (; i < n; ++i) encode(i, ToneMapLanes(Floats(linear[i]))[0]);
}

float ToneMapOne(float v) { return ToneMapLanes(Floats(v))[0]; }

}  // namespace

extern const FilmKernels kFilmKernels{SOLID_FILM_ISA_NAME, ShadeTiles, FilterKeys, FilterAcross, FilterDown,
                                      Encode, ToneMapOne, BaseColorOf, MeanBaseColorOf};

}  // namespace solid::render::SOLID_FILM_ISA
