#include "shading.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <numbers>

#include <fmt/format.h>

#include "solid/formats/random.h"
#include "instance_scene.h"
#include "lanes.h"
#include "streams.h"
#include "solid/formats/workers.h"

namespace solid::render {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr float kInfinity = std::numeric_limits<float>::infinity();
constexpr float kMaxSampleRadiance = 4.0f;
constexpr float kMaxSpecularExponent = 1024.0f;
// A relative depth step between neighbouring pixel centres that makes both edge pixels.
constexpr float kDepthStep = 0.02f;
// FilterFlatLighting: the least cosine between the normals of two pixels it averages, and
// the base colour below which a pixel's lighting is not used.
constexpr float kFilterNormalCos = 0.906f;  // 25 degrees
constexpr float kDarkAlbedo = 1e-3f;
// FootprintBaseColor: the farthest of its taps from the centre, in texels, that one lookup
// at the centre stands in for.
constexpr float kFootprintTexels = 0.25f;

const std::array<float, 256>& SrgbTable() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
      const double c = i / 255.0;
      t[i] = static_cast<float>(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
    }
    return t;
  }();
  return table;
}

Vec3f Normalized(Vec3f v) {
  const float len2 = Dot(v, v);
  return len2 > 0 ? v * (1.0f / std::sqrt(len2)) : v;
}

struct Frame3f {
  float m[9];
  Vec3f operator*(Vec3f v) const {
    return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
            m[6] * v.x + m[7] * v.y + m[8] * v.z};
  }
};

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
  const Floats sign = stdx::copysign(Floats(1), n.z);
  const Floats a = -1 / (sign + n.z);
  const Floats c = n.x * n.y * a;
  const Floats3 t{1 + sign * n.x * n.x * a, sign * c, -sign * n.x};
  const Floats3 b{c, sign + n.y * n.y * a, -n.y};
  Floats cos_phi, sin_phi;
  CosSinTurn(a1, &cos_phi, &sin_phi);
  return t * (r * cos_phi) + b * (r * sin_phi) + n * stdx::sqrt(1 - a0);
}

struct SurfaceFrames {
  Frame3f rotation;
  float scale;
  Vec3f translation;
};

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

WorldTriangle MakeWorldTriangle(const ShadingScene& scene, const std::vector<SurfaceFrames>& frames,
                                uint32_t instance, uint32_t prim) {
  const ShadingSurface& s = scene.surfaces[instance];
  const SurfaceFrames& f = frames[instance];
  const MeshGeometry& m = *s.mesh;
  WorldTriangle t;
  t.instance = instance;
  t.prim = prim;
  const uint32_t corners[3] = {m.indices[3 * prim], m.indices[3 * prim + 1], m.indices[3 * prim + 2]};
  Vec3f object[3];
  for (int k = 0; k < 3; ++k) {
    const uint32_t i = corners[k];
    object[k] = {m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]};
    t.corners[k] = f.rotation * (object[k] * f.scale) + f.translation;
    // Instances scale uniformly, so the normals' inverse transpose is the rotation itself.
    t.normals[k] = f.rotation * Vec3f{m.normals[3 * i], m.normals[3 * i + 1], m.normals[3 * i + 2]};
    t.corner_uv[2 * k] = m.uvs[2 * i];
    t.corner_uv[2 * k + 1] = m.uvs[2 * i + 1];
  }
  t.geometric_normal = Normalized(f.rotation * Cross(object[1] - object[0], object[2] - object[0]));
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
  const WorldTriangle& Get(const ShadingScene& scene, const std::vector<SurfaceFrames>& frames, uint32_t instance,
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
      uint16_t* p = &perm_[static_cast<size_t>(d) * n];
      for (int i = 0; i < n; ++i) p[i] = static_cast<uint16_t>(i);
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
    const int stratum = d < 0 ? s : perm_[static_cast<size_t>(d) * nx_ * ny_ + s];
    const double a = (stratum % nx_ + u) / nx_;
    const double b = (stratum / nx_ + v) / ny_;
    return {static_cast<float>(a), static_cast<float>(b)};
  }

 private:
  int nx_ = 1, ny_ = 1, dims_;
  std::vector<uint16_t> perm_;
  Rng* rng_ = nullptr;
};

}  // namespace

float SrgbToLinear(uint8_t v) { return SrgbTable()[v]; }

namespace {

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

}  // namespace

float ToneMap(float v) { return ToneMapLanes(Floats(v))[0]; }

uint8_t LinearToSrgb8(float v) {
  if (!(v > 0)) return 0;
  if (v >= 1) return 255;
  const float c = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
  return static_cast<uint8_t>(std::lround(c * 255.0f));
}

Result<DecodedTextures> DecodeTextures(const std::vector<gltf::Texture>& textures, std::string_view where) {
  DecodedTextures out;
  for (size_t t = 0; t < textures.size(); ++t) {
    const gltf::Texture& in = textures[t];
    ImageFormat format;
    if (in.mime_type == "image/png") {
      format = ImageFormat::kPng;
    } else if (in.mime_type == "image/jpeg") {
      format = ImageFormat::kJpeg;
    } else {
      return ParseError(fmt::format("{}: texture {} ({}): unsupported type '{}'", where, t, in.name, in.mime_type));
    }
    Result<Image8> decoded = DecodeImage(in.bytes, format, kTextureLimits);
    if (!decoded.ok()) return decoded.status().WithContext(fmt::format("{}: texture {} ({})", where, t, in.name));
    const Image8& img = *decoded;
    if (img.channels < 1 || img.channels > 4 || img.width == 0 || img.height == 0) {
      return ParseError(fmt::format("{}: texture {} ({}): {} channels, {}x{}", where, t, in.name, img.channels,
                                    img.width, img.height));
    }
    DecodedTextures::Texture tex;
    tex.width = static_cast<int>(img.width);
    tex.height = static_cast<int>(img.height);
    const size_t texels = static_cast<size_t>(img.width) * img.height;
    tex.rgb.resize(3 * texels);
    double sum[3] = {0, 0, 0};
    for (size_t i = 0; i < texels; ++i) {
      const uint8_t* p = &img.pixels[i * img.channels];
      // Grey (+ alpha) images replicate their one colour channel; alpha is dropped.
      const bool grey = img.channels < 3;
      for (int c = 0; c < 3; ++c) {
        const uint8_t v = grey ? p[0] : p[c];
        tex.rgb[3 * i + c] = v;
        sum[c] += SrgbToLinear(v);
      }
    }
    tex.mean_linear = {static_cast<float>(sum[0] / texels), static_cast<float>(sum[1] / texels),
                       static_cast<float>(sum[2] / texels)};
    out.bytes += tex.rgb.size();
    out.textures.push_back(std::move(tex));
  }
  return out;
}

namespace {

const DecodedTextures::Texture* TextureOf(const gltf::Material* material, const DecodedTextures* textures) {
  if (material == nullptr || textures == nullptr || !material->base_color_texture.has_value()) return nullptr;
  const uint32_t t = *material->base_color_texture;
  return t < textures->textures.size() ? &textures->textures[t] : nullptr;
}

Vec3f Factor(const gltf::Material* material) {
  if (material == nullptr) return {1, 1, 1};
  return {material->base_color[0], material->base_color[1], material->base_color[2]};
}

}  // namespace

namespace {

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
  const std::array<float, 256>& lut = SrgbTable();
  auto texel = [&](int tx, int ty) {
    const uint8_t* p = &tex.rgb[3 * (static_cast<size_t>(ty) * tex.width + tx)];
    return Vec3f{lut[p[0]], lut[p[1]], lut[p[2]]};
  };
  const Vec3f top = texel(x0, y0) * (1 - ax) + texel(x1, y0) * ax;
  const Vec3f bottom = texel(x0, y1) * (1 - ax) + texel(x1, y1) * ax;
  return top * (1 - ay) + bottom * ay;
}

}  // namespace

Vec3f BaseColor(const gltf::Material* material, const DecodedTextures* textures, float u, float v) {
  const DecodedTextures::Texture* tex = TextureOf(material, textures);
  return tex == nullptr ? Factor(material) : Factor(material) * SampleTexture(*tex, u, v);
}

Vec3f MeanBaseColor(const gltf::Material* material, const DecodedTextures* textures) {
  const DecodedTextures::Texture* tex = TextureOf(material, textures);
  return tex == nullptr ? Factor(material) : Factor(material) * tex->mean_linear;
}

namespace {

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
  if (!(t.inverse > 0)) return BaseColor(t.material, t.textures, h.u, h.v);
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
  if (!uv_along(dir_dx, &ux, &vx) || !uv_along(dir_dy, &uy, &vy)) return BaseColor(t.material, t.textures, h.u, h.v);
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

}  // namespace

std::vector<uint8_t> EdgePixels(const MaskPassResult& masks) {
  const int w = masks.width, h = masks.height;
  std::vector<uint8_t> edges(static_cast<size_t>(w) * h, 0);
  // Whether two pixels differ is symmetric, so each neighbouring pair is compared once (a
  // pixel with its right and lower neighbours) and marks both. Diagonal neighbours are not
  // compared: a boundary that only touches a pixel's corner covers little of its area. On
  // 8 more-objects layouts at 640x480 (bench/render_quality_bench) leaving them flat took
  // 0.15 rays per pixel fewer, shading 5% faster over three interleaved runs, and cost
  // 0.04 dB (36.13 against 36.17; SSIM 0.9787 against 0.9785).
  auto differ = [&](size_t p, size_t q) {
    const float d = masks.depth[p], e = masks.depth[q];
    // Infinite depths (rays that leave the scene) differ from any finite one: inf - inf is NaN.
    return masks.ids[q] != masks.ids[p] || (d != e && !(std::fabs(d - e) <= kDepthStep * std::min(d, e)));
  };
  auto mark = [&](size_t p, size_t q) {
    if (differ(p, q)) edges[p] = edges[q] = 1;
  };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = static_cast<size_t>(y) * w + x;
      if (x + 1 < w) mark(p, p + 1);
      if (y + 1 < h) mark(p, p + w);
    }
  }
  return edges;
}

namespace {

// Buffers a thread reuses from film to film. Allocated afresh for each image, 14 MB of
// them at 640x480 cost 4,000 page faults per image: 2.2 s of system time in a 64-image
// render at --jobs 2, and the other worker's mask pass took half as long again.
struct FilterScratch {
  FlatGuides guides;
  // FilterFlatLighting's planes, one value per pixel, so that its loops load kWidth
  // neighbouring pixels at once: a pixel's surface where it is usable (else -1), its
  // normal, its lighting, and the lighting's mean along its row.
  std::vector<int32_t> key;
  std::array<std::vector<float>, 3> normal, lighting, across;
};

FilterScratch& ThreadScratch() {
  thread_local FilterScratch scratch;
  return scratch;
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
Vec3f Average(const SurfacePlanes& g, const std::array<std::vector<float>, 3>& in, size_t p, ptrdiff_t step, int lo,
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
void AverageLanes(const SurfacePlanes& g, const std::array<std::vector<float>, 3>& in, size_t p, ptrdiff_t step, int lo,
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
    const Floats3 value{load(in[0].data(), q), load(in[1].data(), q), load(in[2].data(), q)};
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

}  // namespace

void FilterFlatLighting(const FlatGuides& guides, int threads, Film* film) {
  const int width = film->width, height = film->height;
  const size_t pixels = film->rgb.size() / 3;
  FilterScratch& scratch = ThreadScratch();
  scratch.key.resize(pixels);
  for (int k = 0; k < 3; ++k) {
    scratch.normal[k].resize(pixels);
    scratch.lighting[k].resize(pixels);
    scratch.across[k].resize(pixels);
  }
  const SurfacePlanes g{scratch.key.data(),
                        guides.depth.data(),
                        {scratch.normal[0].data(), scratch.normal[1].data(), scratch.normal[2].data()}};
  auto rows = [&](const auto& row) {
    std::atomic<int> next{0};
    RunOnThreads(std::clamp(threads, 1, height), [&] {
      for (int y; (y = next.fetch_add(1, std::memory_order_relaxed)) < height;) row(y);
    });
  };
  // Pixels without a surface, and dark base colours (whose lighting would be noise over
  // a near-zero divisor), neither take nor give: their key is -1, which no usable pixel's is.
  rows([&](int y) {
    for (size_t p = static_cast<size_t>(y) * width, end = p + width; p < end; ++p) {
      const Vec3f a = guides.albedo[p];
      const bool usable =
          guides.surface[p] != kNoSurface && a.x > kDarkAlbedo && a.y > kDarkAlbedo && a.z > kDarkAlbedo;
      scratch.key[p] = usable ? static_cast<int32_t>(guides.surface[p]) : -1;
      const Vec3f n = usable ? guides.normal[p] : Vec3f{};
      const Vec3f l = usable ? Vec3f{film->rgb[3 * p] / a.x, film->rgb[3 * p + 1] / a.y, film->rgb[3 * p + 2] / a.z}
                             : Vec3f{};
      scratch.normal[0][p] = n.x, scratch.normal[1][p] = n.y, scratch.normal[2][p] = n.z;
      scratch.lighting[0][p] = l.x, scratch.lighting[1][p] = l.y, scratch.lighting[2][p] = l.z;
    }
  });
  // Separable: a box of 2 kFlatFilterRadius + 1 pixels along rows, then along columns, each
  // over the pixels on the same surface. On an open surface that is the square box; at
  // its borders and around other objects it shrinks to what lies on the surface. Both
  // passes go row by row, which keeps the column pass's reads in cache.
  constexpr int r = kFlatFilterRadius;
  rows([&](int y) {
    const size_t row = static_cast<size_t>(y) * width;
    auto scalar = [&](int x) {
      const size_t p = row + x;
      if (scratch.key[p] == -1) return;
      const Vec3f mean = Average(g, scratch.lighting, p, 1, std::max(-r, -x), std::min(r, width - 1 - x));
      scratch.across[0][p] = mean.x, scratch.across[1][p] = mean.y, scratch.across[2][p] = mean.z;
    };
    int x = 0;
    for (; x < std::min(r, width); ++x) scalar(x);
    // Whole vectors of pixels whose boxes lie inside the row.
    for (; x + kWidth - 1 + r < width; x += kWidth) {
      Floats3 mean;
      AverageLanes(g, scratch.lighting, row + x, 1, -r, r, &mean);
      mean.x.copy_to(&scratch.across[0][row + x], stdx::element_aligned);
      mean.y.copy_to(&scratch.across[1][row + x], stdx::element_aligned);
      mean.z.copy_to(&scratch.across[2][row + x], stdx::element_aligned);
    }
    for (; x < width; ++x) scalar(x);
  });
  rows([&](int y) {
    const size_t row = static_cast<size_t>(y) * width;
    const int lo = std::max(-r, -y), hi = std::min(r, height - 1 - y);
    auto put = [&](size_t p, Vec3f mean) {
      if (scratch.key[p] == -1) return;
      const Vec3f radiance = mean * guides.albedo[p];
      film->rgb[3 * p] = radiance.x;
      film->rgb[3 * p + 1] = radiance.y;
      film->rgb[3 * p + 2] = radiance.z;
    };
    int x = 0;
    for (; x + kWidth <= width; x += kWidth) {
      Floats3 mean;
      AverageLanes(g, scratch.across, row + x, width, lo, hi, &mean);
      for (int k = 0; k < kWidth; ++k) put(row + x + k, {mean.x[k], mean.y[k], mean.z[k]});
    }
    for (; x < width; ++x) put(row + x, Average(g, scratch.across, row + x, width, lo, hi));
  });
}

Film RenderFilm(const ShadingScene& scene, const Camera& camera, int width, int height, double near,
                const FilmSampling& sampling, int threads, uint64_t seed) {
  const int spp = sampling.spp;
  const bool adaptive = !sampling.edges.empty();
  const std::vector<MaskPassResult::CentreHit>* centre_hits = adaptive ? sampling.centre_hits : nullptr;
  const int flat_spp = FlatSamples(spp);
  Film film;
  film.width = width;
  film.height = height;
  const size_t pixels = static_cast<size_t>(width) * height;
  film.rgb.assign(pixels * 3, 0.0f);
  film.covered.assign(pixels, 0);
  // A reference, not the thread_local itself, so that the worker threads write this thread's guides.
  FlatGuides& guides = ThreadScratch().guides;
  if (adaptive) {
    // Every pixel's surface is written below, and the rest only where it has one.
    guides.surface.resize(pixels);
    guides.depth.resize(pixels);
    guides.normal.resize(pixels);
    guides.albedo.resize(pixels);
  }
  std::vector<SurfaceFrames> frames;
  for (const ShadingSurface& s : scene.surfaces) {
    SurfaceFrames f{};
    for (int i = 0; i < 9; ++i) f.rotation.m[i] = static_cast<float>(s.rotation.m[i]);
    f.scale = static_cast<float>(s.scale);
    f.translation = ToFloat(s.translation);
    frames.push_back(f);
  }
  int nx = 1, ny = 1, flat_nx = 1, flat_ny = 1;
  Strata(spp, &nx, &ny);
  Strata(flat_spp, &flat_nx, &flat_ny);
  const Vec3f eye = ToFloat(CameraPosition(camera));
  // RayDirection is affine in the image point: a flat pixel's centre direction and its
  // neighbours' (for its footprint) are sums of these instead of three double evaluations.
  const Vec3 corner_direction = RayDirection(camera, 0, 0);
  const Vec3f direction_at_origin = ToFloat(corner_direction);
  const Vec3f direction_per_x = ToFloat(RayDirection(camera, 1, 0) - corner_direction);
  const Vec3f direction_per_y = ToFloat(RayDirection(camera, 0, 1) - corner_direction);
  const int dims = static_cast<int>(scene.lights.size()) + 1;  // + ambient occlusion
  const int tiles_x = (width + kTile - 1) / kTile, tile_rows = (height + kTile - 1) / kTile;
  std::atomic<int> next_row{0};
  std::atomic<uint64_t> total_rays{0};

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

  auto work = [&] {
    RTCIntersectContext primary;
    rtcInitIntersectContext(&primary);
    primary.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTCIntersectContext secondary;
    rtcInitIntersectContext(&secondary);
    // Each pixel keeps its own generator and strata, so a pixel's draws do not depend on
    // its tile, its thread or the other pixels' hits.
    std::vector<PixelSampler> samplers(kLanes, PixelSampler(std::max(spp, flat_spp), dims));
    std::vector<Rng> rngs(kLanes, Rng(0, kShadingStream));
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
    for (int ty; (ty = next_row.fetch_add(1, std::memory_order_relaxed)) < tile_rows;) {
      for (int tx = 0; tx < tiles_x; ++tx) {
        int tile_spp = 0;
        for (int i = 0; i < kLanes; ++i) {
          const int x = tx * kTile + i % kTile, y = ty * kTile + i / kTile;
          inside[i] = x < width && y < height ? -1 : 0;
          hit[i] = 0;
          if (!inside[i]) continue;
          rngs[i] = Rng(MixSeed(seed, static_cast<size_t>(y) * width + x), kShadingStream);
          // The rest of a lane is written by its hit before anything reads it.
          for (int k = 0; k < 3; ++k) columns.sum[k][i] = 0;
          lanes[i].covered = false;
          lanes[i].edge = !adaptive || sampling.edges[static_cast<size_t>(y) * width + x] != 0;
          lanes[i].samples = lanes[i].edge ? spp : flat_spp;
          if (lanes[i].edge) {
            samplers[i].Start(&rngs[i], nx, ny);
          } else {
            samplers[i].Start(&rngs[i], flat_nx, flat_ny);
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
            SetRayHit(&rays, i, eye, dir, static_cast<float>(near), kInfinity);
          }
          count(traced);
          if (AnyValid(traced)) Intersect16(traced, scene.scene, &primary, &rays);
          for (int i = 0; i < kLanes; ++i) {
            active[i] = 0;
            if (!inside[i] || s >= lanes[i].samples) continue;
            Lane& lane = lanes[i];
            const int x = tx * kTile + i % kTile, y = ty * kTile + i / kTile;
            const MaskPassResult::CentreHit* centre =
                known[i] ? &(*centre_hits)[static_cast<size_t>(y) * width + x] : nullptr;
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
              lane.base = BaseColor(triangle.material, triangle.textures, h.u, h.v);
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
    total_rays += traced_rays;
  };
  RunOnThreads(std::clamp(threads, 1, std::max(1, tile_rows)), work);
  film.rays = total_rays;
  if (adaptive) FilterFlatLighting(guides, threads, &film);
  return film;
}

namespace {

// thresholds[k - 1]: the least display-linear value that LinearToSrgb8 maps to k or more
// (it is monotonic), so that encoding a film costs a short search per channel instead
// of a pow, with the same bytes.
const std::array<float, 255>& SrgbThresholds() {
  static const std::array<float, 255> table = [] {
    std::array<float, 255> t{};
    for (int k = 1; k < 256; ++k) {
      // Bisection over the bit patterns of the floats in [0, 1], which order as the values.
      uint32_t lo = 0, hi = std::bit_cast<uint32_t>(1.0f);
      while (lo < hi) {
        const uint32_t mid = lo + (hi - lo) / 2;
        if (LinearToSrgb8(std::bit_cast<float>(mid)) >= k) {
          hi = mid;
        } else {
          lo = mid + 1;
        }
      }
      t[k - 1] = std::bit_cast<float>(lo);
    }
    return t;
  }();
  return table;
}

// Per bucket b of [0, 1] in kCodeBuckets, the count of thresholds at or below b /
// kCodeBuckets: where EncodeFilm starts its search for a value in that bucket, a step or
// two short of its code instead of a binary search's eight.
constexpr int kCodeBuckets = 4096;
const std::array<uint8_t, kCodeBuckets + 1>& SrgbCodeBuckets() {
  static const std::array<uint8_t, kCodeBuckets + 1> table = [] {
    const std::array<float, 255>& thresholds = SrgbThresholds();
    std::array<uint8_t, kCodeBuckets + 1> t{};
    for (int b = 0; b <= kCodeBuckets; ++b) {
      const float low = static_cast<float>(b) / kCodeBuckets;
      t[b] = static_cast<uint8_t>(std::upper_bound(thresholds.begin(), thresholds.end(), low) - thresholds.begin());
    }
    return t;
  }();
  return table;
}

}  // namespace

Image8 EncodeFilm(const Film& film) {
  Image8 out;
  out.width = static_cast<uint32_t>(film.width);
  out.height = static_cast<uint32_t>(film.height);
  out.channels = 3;
  out.pixels.resize(film.rgb.size());
  const std::array<float, 255>& thresholds = SrgbThresholds();
  const std::array<uint8_t, kCodeBuckets + 1>& start = SrgbCodeBuckets();
  auto encode = [&](size_t i, float v) {  // v = ToneMap(film.rgb[i]), in [0, 1]
    // The count of thresholds at or below v, from its bucket's first code on.
    int code = start[static_cast<size_t>(v * kCodeBuckets)];
    while (code < 255 && thresholds[code] <= v) ++code;
    out.pixels[i] = static_cast<uint8_t>(code);
  };
  size_t i = 0;
  for (; i + kWidth <= film.rgb.size(); i += kWidth) {
    const Floats v = ToneMapLanes(Floats(&film.rgb[i], stdx::element_aligned));
    for (int k = 0; k < kWidth; ++k) encode(i + k, v[k]);
  }
  for (; i < film.rgb.size(); ++i) encode(i, ToneMap(film.rgb[i]));
  return out;
}

}  // namespace solid::render
