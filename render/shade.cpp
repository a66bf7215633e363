#include "solid/render/shade.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <numbers>
#include <unordered_map>

#include <fmt/format.h>

#include "film_kernels.h"
#include "instance_scene.h"
#include "room.h"
#include "shading.h"
#include "solid/formats/random.h"
#include "streams.h"

namespace solid::render {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kMaxLightDraws = 1000;
constexpr double kLightMargin = 0.05;  // D8: lights stay this far from the floor and the ceiling
constexpr float kWorldGrey = 0.05f;    // the reference's world colour, strength 1

struct LightRule {
  const char* name;
  double azimuth = 0, half_width = kPi;  // allowed horizontal azimuths: azimuth +- half_width
  Interval z, power_w, size_m;
};

double AngleBetween(double a, double b) { return std::fabs(std::remainder(a - b, 2 * kPi)); }

bool Inside(const Obb& box, Vec3 p) {
  const Vec3 d = p - box.center;
  for (int k = 0; k < 3; ++k) {
    if (std::fabs(Dot(d, box.axes.Column(k))) > box.half[k]) return false;
  }
  return true;
}

nlohmann::json LightJson(const AreaLight& l) {
  return {{"position", {l.position.x, l.position.y, l.position.z}},
          {"direction", {l.direction.x, l.direction.y, l.direction.z}},
          {"size_m", l.size_m},
          {"power_w", l.power_w}};
}

// The view factor from a point to a parallel rectangle h above it that spans
// [x0, x1] x [y0, y1] relative to the point (sum of four corner rectangles).
double ViewFactor(double x0, double x1, double y0, double y1, double h) {
  auto corner = [h](double a, double b) {
    const double x = std::fabs(a) / h, y = std::fabs(b) / h;
    const double sx = std::sqrt(1 + x * x), sy = std::sqrt(1 + y * y);
    const double f = (x / sx * std::atan(y / sx) + y / sy * std::atan(x / sy)) / (2 * kPi);
    return (a < 0 ? -1 : 1) * (b < 0 ? -1 : 1) * f;
  };
  return corner(x1, y1) - corner(x0, y1) - corner(x1, y0) + corner(x0, y0);
}

}  // namespace

nlohmann::json LightRig::ToJson() const {
  return {{"target", target},
          {"key", LightJson(key)},
          {"fill", LightJson(fill)},
          {"back", LightJson(back)},
          {"ceiling_strength", ceiling_strength}};
}

Result<LightRig> SampleLights(const Layout& layout) {
  if (layout.room == nullptr) return InvalidArgumentError(fmt::format("layout {}: no room", layout.index));
  if (layout.objects.empty()) {
    return InvalidArgumentError(fmt::format("layout {}: no placed object to aim the lights at", layout.index));
  }
  const RoomShell& room = *layout.room;
  Rng rng(MixSeed(layout.seed, static_cast<uint64_t>(layout.restart)), kLightStream);
  LightRig rig;
  rig.target = static_cast<size_t>(rng.Index(layout.objects.size()));
  const Vec3 target = layout.objects[rig.target].position;
  const Vec3 eye = CameraPosition(layout.camera);
  const double ring = std::hypot(eye.x, eye.y);
  struct Column {
    int i, j;
    double azimuth;
  };
  std::vector<Column> columns;
  for (int j = 0; j < room.points(); ++j) {
    for (int i = 0; i < room.points(); ++i) {
      const double r = std::hypot(room.X(i), room.Y(j));
      if (r >= 0.8 * ring && r <= ring && room.Covered(i, j)) columns.push_back({i, j, std::atan2(room.Y(j), room.X(i))});
    }
  }
  auto draw = [&](const LightRule& rule) -> Result<AreaLight> {
    std::vector<const Column*> allowed;
    for (const Column& c : columns) {
      if (AngleBetween(c.azimuth, rule.azimuth) <= rule.half_width) allowed.push_back(&c);
    }
    if (allowed.empty()) {
      return LimitExceededError(fmt::format("layout {} restart {}: no floor column for the {} light on the ring "
                                            "[{:.3f}, {:.3f}] m",
                                            layout.index, layout.restart, rule.name, 0.8 * ring, ring));
    }
    for (int d = 0; d < kMaxLightDraws; ++d) {
      const Column& c = *allowed[rng.Index(allowed.size())];
      const double floor = room.FloorZ(c.i, c.j), ceiling = room.CeilingZ(c.i, c.j);
      double z = rng.Uniform(rule.z.lo, rule.z.hi);
      const double lo = floor + kLightMargin, hi = ceiling - kLightMargin;
      z = lo > hi ? ceiling : std::clamp(z, lo, hi);
      const Vec3 p{room.X(c.i), room.Y(c.j), z};
      if (std::any_of(layout.objects.begin(), layout.objects.end(),
                      [&](const PlacedObject& o) { return Inside(o.box, p); })) {
        continue;
      }
      AreaLight light;
      light.position = p;
      const Vec3 to_target = target - p;
      light.direction = Length(to_target) > 0 ? Normalize(to_target) : Vec3{0, 0, -1};
      light.power_w = rng.Uniform(rule.power_w.lo, rule.power_w.hi);
      light.size_m = rng.Uniform(rule.size_m.lo, rule.size_m.hi);
      return light;
    }
    return LimitExceededError(fmt::format("layout {} restart {}: the {} light found no position outside the "
                                          "objects in {} draws",
                                          layout.index, layout.restart, rule.name, kMaxLightDraws));
  };
  SOLID_ASSIGN_OR_RETURN(rig.key, draw({"key", 0, kPi, {2, 5}, {150, 300}, {0.01, 0.25}}));
  const double key_azimuth = std::atan2(rig.key.position.y, rig.key.position.x);
  SOLID_ASSIGN_OR_RETURN(rig.fill, draw({"fill", key_azimuth, kPi / 3, {0.1, 1.0}, {10, 30}, {0.25, 0.25}}));
  const double back_azimuth = std::atan2(eye.y, eye.x) + kPi;
  SOLID_ASSIGN_OR_RETURN(rig.back, draw({"back", back_azimuth, kPi / 6, {6, 10}, {20, 60}, {0.25, 0.25}}));
  rig.ceiling_strength = room.key() == "white_cube" ? rng.Uniform(0, 1) : rng.Uniform(0.5, 1.0);
  return rig;
}

struct TextureCache::Impl {
  struct Entry {
    std::weak_ptr<const void> owner;
    std::shared_ptr<const DecodedTextures> textures;
    uint64_t last_use = 0;
  };
  uint64_t cap = 0;
  mutable std::mutex mutex;
  std::unordered_map<const void*, Entry> entries;  // by the address of the texture list
  uint64_t bytes = 0, clock = 0;

  // Drops entries whose owner is gone, then the least recently used ones over the cap.
  void Trim() {
    for (auto it = entries.begin(); it != entries.end();) {
      if (it->second.owner.expired()) {
        bytes -= it->second.textures->bytes;
        it = entries.erase(it);
      } else {
        ++it;
      }
    }
    while (bytes > cap && entries.size() > 1) {
      auto oldest = std::min_element(entries.begin(), entries.end(), [](const auto& a, const auto& b) {
        return a.second.last_use < b.second.last_use;
      });
      bytes -= oldest->second.textures->bytes;
      entries.erase(oldest);
    }
  }
};

TextureCache::TextureCache(uint64_t cap_bytes) : impl_(std::make_unique<Impl>()) { impl_->cap = cap_bytes; }
TextureCache::~TextureCache() = default;

uint64_t TextureCache::bytes() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->bytes;
}

Result<std::shared_ptr<const DecodedTextures>> TextureCache::Get(const std::vector<gltf::Texture>& textures,
                                                                 const std::shared_ptr<const void>& owner,
                                                                 std::string_view where) {
  if (textures.empty()) return std::shared_ptr<const DecodedTextures>();
  {
    std::lock_guard lock(impl_->mutex);
    const auto it = impl_->entries.find(&textures);
    // The owner check catches a new asset allocated where a freed one was.
    if (it != impl_->entries.end() && it->second.owner.lock() == owner) {
      it->second.last_use = ++impl_->clock;
      return it->second.textures;
    }
  }
  // Decoded outside the lock; a concurrent duplicate decode is harmless.
  SOLID_ASSIGN_OR_RETURN(DecodedTextures decoded, DecodeTextures(textures, where));
  auto shared = std::make_shared<const DecodedTextures>(std::move(decoded));
  std::lock_guard lock(impl_->mutex);
  Impl::Entry& e = impl_->entries[&textures];
  if (e.textures != nullptr) impl_->bytes -= e.textures->bytes;
  e = {owner, shared, ++impl_->clock};
  impl_->bytes += shared->bytes;
  impl_->Trim();
  return shared;
}

Result<ShadeResult> Shade(const Layout& layout, const LightRig& lights, const ShadeOptions& options,
                          TextureCache& textures, const MaskPassResult* masks) {
  return ShadeWith(layout, lights, options, textures, masks, BestFilmKernels());
}

Result<ShadeResult> ShadeWith(const Layout& layout, const LightRig& lights, const ShadeOptions& options,
                              TextureCache& textures, const MaskPassResult* masks, const FilmKernels& kernels) {
  const auto start = std::chrono::steady_clock::now();
  if (options.samples_per_pixel < 1 || options.samples_per_pixel > 1024) {
    return InvalidArgumentError(fmt::format("shade: samples_per_pixel {} outside [1, 1024]", options.samples_per_pixel));
  }
  if (layout.room == nullptr) return InvalidArgumentError(fmt::format("shade: layout {} has no room", layout.index));
  if (lights.target >= layout.objects.size()) {
    return InvalidArgumentError(fmt::format("shade: layout {}: light target {} of {} objects", layout.index,
                                            lights.target, layout.objects.size()));
  }
  if (layout.width <= 0 || layout.height <= 0) {
    return InvalidArgumentError(fmt::format("shade: layout {}: image {}x{}", layout.index, layout.width, layout.height));
  }
  FilmSampling sampling{options.samples_per_pixel, {}};
  if (options.sampling == Sampling::kAdaptive) {
    const size_t pixels = static_cast<size_t>(layout.width) * layout.height;
    if (masks == nullptr || masks->width != layout.width || masks->height != layout.height ||
        masks->ids.size() != pixels || masks->depth.size() != pixels ||
        (!masks->centre_hits.empty() &&
         (masks->centre_hits.size() != pixels || masks->instances.size() != layout.objects.size()))) {
      return InvalidArgumentError(fmt::format("shade: layout {}: adaptive sampling needs the layout's {}x{} mask pass",
                                              layout.index, layout.width, layout.height));
    }
    // Flat pixels shade these hits without tracing them: a hit that names no triangle of
    // this layout (another layout's mask pass) is refused here rather than read out of range.
    const size_t objects = layout.objects.size();
    for (size_t p = 0; p < masks->centre_hits.size(); ++p) {
      const MaskPassResult::CentreHit& hit = masks->centre_hits[p];
      if (hit.surface == MaskPassResult::CentreHit::kNothing) continue;
      const size_t triangles = hit.surface < objects ? layout.objects[hit.surface].asset->mesh().TriangleCount()
                               : hit.surface == objects ? layout.room->mesh().TriangleCount()
                                                        : 0;
      if (hit.triangle >= triangles) {
        return InvalidArgumentError(fmt::format("shade: layout {}: mask pass pixel ({}, {}) hit surface {} triangle {}, "
                                                "which the layout does not have",
                                                layout.index, p % layout.width, p / layout.width, hit.surface,
                                                hit.triangle));
      }
    }
    sampling.edges = EdgePixels(*masks);
    if (!masks->centre_hits.empty()) sampling.centre_hits = &masks->centre_hits;
  }
  const RoomShell& room = *layout.room;
  ShadingScene scene;
  std::vector<SceneInstance> instances;
  std::vector<std::shared_ptr<const DecodedTextures>> keep;  // alive while shading
  for (const PlacedObject& o : layout.objects) {
    SOLID_ASSIGN_OR_RETURN(auto tex, textures.Get(o.asset->textures(), o.asset, o.model_key));
    ShadingSurface s;
    s.mesh = &o.asset->mesh();
    s.materials = &o.asset->materials();
    s.textures = tex.get();
    s.rotation = o.rotation;
    s.scale = o.scale;
    s.translation = o.position;
    scene.surfaces.push_back(s);
    keep.push_back(std::move(tex));
    instances.push_back({reinterpret_cast<RTCScene>(o.asset->scene()), o.WorldFromObject()});
  }
  SOLID_ASSIGN_OR_RETURN(auto room_tex, textures.Get(room.textures(), layout.room, "room " + room.key()));
  scene.surfaces.push_back({&room.mesh(), &room.materials(), room_tex.get(), Mat3{}, 1.0, Vec3{}});
  instances.push_back({reinterpret_cast<RTCScene>(room.scene()), kIdentityAffine});
  const ObjectScene top(room.device()->handle(), instances);
  scene.scene = top.get();

  for (const AreaLight* l : {&lights.key, &lights.fill, &lights.back}) {
    ShadingLight s;
    s.area = true;
    s.position = ToFloat(l->position);
    s.normal = ToFloat(l->direction);
    Vec3f t, b;
    const Vec3 d = Normalize(l->direction);
    // Any in-plane orientation: the square's rotation about its axis is not specified.
    const Vec3 helper = std::fabs(d.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
    const Vec3 u = Normalize(Cross(helper, d)), v = Cross(d, u);
    t = ToFloat(u * (l->size_m / 2));
    b = ToFloat(v * (l->size_m / 2));
    s.u_axis = t;
    s.v_axis = b;
    s.power_w = static_cast<float>(l->power_w);
    scene.lights.push_back(s);
  }

  // The ceiling's mean colour, and the shell's mean albedo for one bounce of it.
  const MeshGeometry& m = room.mesh();
  Vec3f ceiling_sum, shell_sum;
  double ceiling_area = 0, shell_area = 0, ceiling_z = 0;
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (size_t t = 0; t < m.TriangleCount(); ++t) {
    Vec3 p[3];
    for (int k = 0; k < 3; ++k) {
      const uint32_t i = m.indices[3 * t + k];
      p[k] = {m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]};
      x0 = std::min(x0, p[k].x), x1 = std::max(x1, p[k].x), y0 = std::min(y0, p[k].y), y1 = std::max(y1, p[k].y);
    }
    const double area = Length(Cross(p[1] - p[0], p[2] - p[0])) / 2;
    const uint32_t mat = m.triangle_material[t];
    const gltf::Material* material = mat < room.materials().size() ? &room.materials()[mat] : nullptr;
    const Vec3f colour = MeanBaseColor(material, room_tex.get());
    shell_sum = shell_sum + colour * static_cast<float>(area);
    shell_area += area;
    if (m.triangle_structure[t] == Structure::kCeiling) {
      ceiling_sum = ceiling_sum + colour * static_cast<float>(area);
      ceiling_area += area;
      ceiling_z = std::max(ceiling_z, (p[0].z + p[1].z + p[2].z) / 3);
    }
  }
  if (ceiling_area > 0) {
    const Vec3f ceiling = ceiling_sum * static_cast<float>(lights.ceiling_strength / ceiling_area);
    const Vec3f albedo = shell_sum * static_cast<float>(1 / shell_area);
    const Vec3 at = layout.objects[lights.target].position;
    const double h_target = std::max(ceiling_z - at.z, 0.05);
    const double h_floor = std::max(ceiling_z, 0.05);
    const double f_target = ViewFactor(x0 - at.x, x1 - at.x, y0 - at.y, y1 - at.y, h_target);
    const double f_floor = ViewFactor(x0, x1, y0, y1, h_floor);
    scene.sky = ceiling * static_cast<float>(f_target);
    scene.ambient = albedo * ceiling * static_cast<float>(f_floor);
  }
  scene.ambient = scene.ambient + Vec3f{kWorldGrey, kWorldGrey, kWorldGrey};
  scene.background = {kWorldGrey, kWorldGrey, kWorldGrey};

  const Film film = RenderFilm(scene, layout.camera, layout.width, layout.height, layout.near, sampling,
                               options.threads,
                               MixSeed(layout.seed, static_cast<uint64_t>(layout.restart)), kernels);
  ShadeResult out;
  out.image = EncodeFilm(film, kernels);
  out.rays = film.rays;
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace solid::render
