#include "solid/render/mask_pass.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>

#include <fmt/format.h>

#include "instance_scene.h"
#include "room.h"
#include "solid/formats/workers.h"

namespace solid::render {
namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();
constexpr int kMaxTruncationSamples = 4096;

// Rays go in 4x4 pixel tiles as one Embree packet: coherent primary rays traverse the
// BVHs together, about three times faster than one by one here (bench/mask_pass_bench).
constexpr int kTile = 4;
constexpr int kLanes = kTile * kTile;

// The rays through the pixel centres, unit length, as every pass casts them: a pixel
// belongs to an object's full mask exactly when its ray hits the object. RayDirection's
// camera-space terms depend on the column alone and on the row alone, so they are computed
// once per column and row (the same doubles, without two divisions per pixel), and the
// visible pass keeps each pixel's direction for the full pass instead of computing it again
// (ray generation was half of both passes' own time at 640x480).
class PixelRays {
 public:
  // `directions`: where the directions are kept (reused from pass to pass: 3.7 MB at
  // 640x480, whose pages a fresh allocation would fault in every time).
  PixelRays(const Camera& cam, int width, int height, std::vector<float>& directions)
      : cam_(cam), width_(width), directions_(directions) {
    columns_.resize(static_cast<size_t>(width));
    rows_.resize(static_cast<size_t>(height));
    for (int x = 0; x < width; ++x) columns_[x] = (x + 0.5 - cam.cx) / cam.fx;
    for (int y = 0; y < height; ++y) rows_[y] = -(y + 0.5 - cam.cy) / cam.fy;
    directions_.resize(3 * static_cast<size_t>(width) * height);
  }
  // Computes and keeps the direction of pixel (x, y); `length`: of the unnormalised
  // direction, whose camera-space z is -1 (depth = t / length).
  Vec3 Compute(int x, int y, float* length) {
    const auto& a = cam_.world_from_camera;
    const Vec3 c{columns_[x], rows_[y], -1.0};
    const Vec3 raw{a[0] * c.x + a[1] * c.y + a[2] * c.z, a[4] * c.x + a[5] * c.y + a[6] * c.z,
                   a[8] * c.x + a[9] * c.y + a[10] * c.z};
    *length = static_cast<float>(Length(raw));
    const Vec3 unit = raw * (1.0 / Length(raw));
    float* kept = &directions_[3 * (static_cast<size_t>(y) * width_ + x)];
    kept[0] = static_cast<float>(unit.x), kept[1] = static_cast<float>(unit.y), kept[2] = static_cast<float>(unit.z);
    return unit;
  }
  // The direction Compute kept for pixel (x, y), as the rays carry it (floats).
  Vec3 Kept(int x, int y) const {
    const float* kept = &directions_[3 * (static_cast<size_t>(y) * width_ + x)];
    return {kept[0], kept[1], kept[2]};
  }

 private:
  const Camera& cam_;
  int width_;
  std::vector<double> columns_, rows_;
  std::vector<float>& directions_;
};

// The image-plane bounds of an object's box: nullopt when a corner is not in front of the
// near plane (or projects to no finite point).
struct ImageBounds {
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
};

std::optional<ImageBounds> ProjectedBox(const Layout& layout, const PlacedObject& o) {
  ImageBounds b;
  for (int c = 0; c < 8; ++c) {
    double u = 0, v = 0;
    if (!Project(layout.camera, o.box.Corner(c), layout.near, &u, &v)) return std::nullopt;
    b.u0 = std::min(b.u0, u);
    b.u1 = std::max(b.u1, u);
    b.v0 = std::min(b.v0, v);
    b.v1 = std::max(b.v1, v);
  }
  if (!(b.u0 <= b.u1 && b.v0 <= b.v1)) return std::nullopt;
  return b;
}

// Pixels [x0, x1) x [y0, y1) whose centre rays can hit an object: its box projected, a
// pixel wider for rounding, or the whole image when the box reaches behind the near plane.
struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  size_t Area() const { return static_cast<size_t>(x1 - x0) * static_cast<size_t>(y1 - y0); }
  // Grows to hold pixel (x, y).
  void Include(int x, int y) {
    if (Area() == 0) {
      *this = {x, y, x + 1, y + 1};
      return;
    }
    x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x + 1), y1 = std::max(y1, y + 1);
  }
  friend bool operator==(const PixelRect&, const PixelRect&) = default;
};

PixelRect CandidatePixels(const Layout& layout, const PlacedObject& o) {
  const int w = layout.width, h = layout.height;
  const std::optional<ImageBounds> b = ProjectedBox(layout, o);
  if (!b) return {0, 0, w, h};
  // Pixel x's centre x + 0.5 lies in [u0, u1] for x in [u0 - 0.5, u1 - 0.5].
  auto clamped = [](double x, int size) { return static_cast<int>(std::clamp(x, 0.0, 1.0 * size)); };
  return {clamped(std::floor(b->u0 - 0.5) - 1, w), clamped(std::floor(b->v0 - 0.5) - 1, h),
          clamped(std::floor(b->u1 - 0.5) + 2, w), clamped(std::floor(b->v1 - 0.5) + 2, h)};
}

// See the header: the share of the object's silhouette outside the image.
double Truncation(const Layout& layout, const PlacedObject& o) {
  const Camera& cam = layout.camera;
  const double w = layout.width, h = layout.height;
  const std::optional<ImageBounds> b = ProjectedBox(layout, o);
  if (b && b->u0 >= 0 && b->u1 <= w && b->v0 >= 0 && b->v1 <= h) return 0;
  // The box clipped to a 3x3-image window, or that whole window.
  const double u0 = b ? std::max(b->u0, -w) : -w, u1 = b ? std::min(b->u1, 2 * w) : 2 * w;
  const double v0 = b ? std::max(b->v0, -h) : -h, v1 = b ? std::min(b->v1, 2 * h) : 2 * h;
  const double area = (u1 - u0) * (v1 - v0);
  if (!(area > 0)) return 0;
  const double stride = std::max(1.0, std::sqrt(area / kMaxTruncationSamples));
  // Rays in the object's own frame against its scene alone.
  const Mat3 to_object = o.rotation.Transposed();
  const Vec3 eye = CameraPosition(cam);
  const Vec3 origin = to_object * (eye - o.position) * (1.0 / o.scale);
  RTCScene scene = reinterpret_cast<RTCScene>(o.asset->scene());
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  int64_t inside = 0, outside = 0;
  for (double v = v0 + stride / 2; v < v1; v += stride) {
    for (double u = u0 + stride / 2; u < u1; u += stride) {
      const Vec3 d = to_object * Normalize(RayDirection(cam, u, v)) * (1.0 / o.scale);
      RTCRayHit r = MakeRay(origin, d, static_cast<float>(layout.near));
      rtcOccluded1(scene, &context, &r.ray);
      if (r.ray.tfar >= 0) continue;  // no hit
      (u >= 0 && u < w && v >= 0 && v < h ? inside : outside) += 1;
    }
  }
  return inside + outside == 0 ? 0.0 : static_cast<double>(outside) / static_cast<double>(inside + outside);
}

}  // namespace

Result<MaskPassResult> RunMaskPass(const Layout& layout, int min_visible_pixels, const MaskPassOptions& options) {
  if (layout.room == nullptr) return InvalidArgumentError("mask pass: the layout has no room");
  const int w = layout.width, h = layout.height;
  const size_t pixels = static_cast<size_t>(w) * h;
  const size_t objects = layout.objects.size();
  const bool masks = !options.metrics_only;
  MaskPassResult out;
  out.width = w;
  out.height = h;
  // Each full mask is stored over the pixels its object can cover (CandidatePixels),
  // column by column as COCO's RLE runs, all in one zeroed block: a whole image per
  // object cost 7 MB of zeroing and a scan of it per object at 640x480 (mask pass 37 ms
  // against 32 with no full masks in a render at --jobs 2).
  std::vector<PixelRect> windows;
  std::vector<uint8_t> full;
  std::vector<uint8_t*> full_windows;
  // The visible-id image, also when only metrics are wanted: the full masks are made to
  // contain the visible pixels (see the full pass). That one is scratch memory reused by
  // the calling thread, so that evaluations of many layouts do not fault in fresh pages.
  static thread_local std::vector<uint32_t> scratch_ids;
  std::vector<uint32_t>& ids = masks ? out.ids : scratch_ids;
  ids.assign(pixels, 0);
  if (masks) {
    out.depth.assign(pixels, kInfinity);
    out.centre_hits.resize(pixels);
    size_t window_pixels = 0;
    for (const PlacedObject& o : layout.objects) {
      windows.push_back(CandidatePixels(layout, o));
      window_pixels += windows.back().Area();
    }
    full.assign(window_pixels, 0);
    uint8_t* next_window = full.data();
    for (const PixelRect& r : windows) {
      full_windows.push_back(next_window);
      next_window += r.Area();
    }
  }
  // Visible pixels per object, summed over the threads; full ones (metrics-only) per object
  // by the one thread that traces it.
  std::vector<uint64_t> visible_counts(objects, 0), full_counts(objects, 0);
  std::mutex counts_mutex;

  RTCDevice device = layout.room->device()->handle();
  // The objects and, as instance `objects`, the room (with the identity transform, which
  // moves no ray's bits): one packet finds the nearest of them all, as the floor of any
  // ray-cast pass does. Two packets, one against the room and one against the objects, took
  // a tenth more of the pass.
  std::vector<SceneInstance> instances;
  for (const PlacedObject& o : layout.objects) {
    instances.push_back({reinterpret_cast<RTCScene>(o.asset->scene()), o.WorldFromObject()});
  }
  instances.push_back({reinterpret_cast<RTCScene>(layout.room->scene()), kIdentityAffine});
  const ObjectScene visible_scene(device, instances);
  const Camera& cam = layout.camera;
  const Vec3 eye = CameraPosition(cam);
  const float tnear = static_cast<float>(layout.near);
  static thread_local std::vector<float> scratch_directions;
  PixelRays pixel_rays(cam, w, h, scratch_directions);

  // The visible pass. Threads take tile rows from a shared counter: objects crowd some
  // rows (near the floor) and leave others (walls, ceiling) nearly free, so fixed bands
  // balance badly. Each tile is one packet, nearest hit.
  const int tile_rows = (h + kTile - 1) / kTile;
  std::atomic<int> next_tile_row{0};
  auto trace_visible = [&] {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    std::vector<uint64_t> thread_visible(objects, 0);
    alignas(64) int valid[kLanes];
    float length[kLanes];
    uint32_t pixel[kLanes];
    RTCRayHit16 rays;
    for (int tile_y; (tile_y = next_tile_row.fetch_add(1, std::memory_order_relaxed)) < tile_rows;) {
      for (int x0 = 0; x0 < w; x0 += kTile) {
        for (int i = 0; i < kLanes; ++i) {
          const int x = x0 + i % kTile, y = tile_y * kTile + i / kTile;
          valid[i] = x < w && y < h ? -1 : 0;
          pixel[i] = valid[i] ? static_cast<uint32_t>(y) * static_cast<uint32_t>(w) + static_cast<uint32_t>(x) : 0;
          SetRayLane(&rays.ray, i, eye, valid[i] ? pixel_rays.Compute(x, y, &length[i]) : Vec3{}, tnear);
          rays.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
          rays.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
        }
        Intersect16(valid, visible_scene.get(), &context, &rays);
        for (int i = 0; i < kLanes; ++i) {
          if (!valid[i]) continue;
          const uint32_t nearest = rays.hit.instID[0][i];  // objects: the room
          if (nearest < objects) {
            ids[pixel[i]] = nearest + 1;
            ++thread_visible[nearest];
          }
          if (masks) {
            const float nearest_t = nearest != RTC_INVALID_GEOMETRY_ID ? rays.ray.tfar[i] : kInfinity;
            out.depth[pixel[i]] = nearest_t == kInfinity ? kInfinity : nearest_t / length[i];
            MaskPassResult::CentreHit& hit = out.centre_hits[pixel[i]];
            hit.surface = nearest != RTC_INVALID_GEOMETRY_ID ? nearest : MaskPassResult::CentreHit::kNothing;
            hit.triangle = rays.hit.primID[i];
            hit.u = rays.hit.u[i];
            hit.v = rays.hit.v[i];
            hit.distance = nearest_t;
          }
        }
      }
    }
    std::lock_guard lock(counts_mutex);
    for (size_t k = 0; k < objects; ++k) visible_counts[k] += thread_visible[k];
  };
  RunOnThreads(std::clamp(options.threads, 1, std::max(1, tile_rows)), trace_visible);

  // The full masks: object by object, the same pixel rays over the pixels its box covers,
  // against a scene of that object alone, any hit. Cheaper than finding every crossing of
  // every ray in one pass: each ray stops at its first hit, and only rays near the object
  // are cast. Embree's traversal of this scene can miss a grazing hit that the visible
  // pass found (in about one pixel in 40 layouts at 640x480), so each full mask also takes
  // its object's visible pixels: it always contains the visible mask.
  //
  // Metrics count only the objects with min_visible_pixels visible pixels or more, so a
  // metrics-only pass traces no full mask for the others: in fitted more-objects layouts
  // at 160x120, 10 of 23 placed objects show no pixel (the pass 6-7% faster at 160x120
  // and at 640x480, bench/mask_pass_bench).
  const uint64_t min_visible = static_cast<uint64_t>(std::max(1, min_visible_pixels));
  std::atomic<size_t> next_object{0};
  std::atomic<bool> visible_outside_a_box{false};
  auto trace_full = [&] {
    // Incoherent (the default): with the coherent flag, Embree 3.13.5's rtcOccluded16 never
    // returned on a one-instance scene (MaskPass tests, after another layout's pass).
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    alignas(64) int valid[kLanes];
    bool inside[kLanes], seen[kLanes];
    uint32_t pixel[kLanes];
    RTCRay16 rays;
    for (size_t k; (k = next_object.fetch_add(1, std::memory_order_relaxed)) < objects;) {
      if (!masks && visible_counts[k] < min_visible) {
        full_counts[k] = visible_counts[k];
        continue;
      }
      const PlacedObject& o = layout.objects[k];
      const SceneInstance alone{reinterpret_cast<RTCScene>(o.asset->scene()), o.WorldFromObject()};
      const ObjectScene scene(device, {&alone, 1});
      const PixelRect rect = masks ? windows[k] : CandidatePixels(layout, o);
      const int rect_height = rect.y1 - rect.y0;
      const uint32_t id = static_cast<uint32_t>(k) + 1;
      uint64_t count = 0, visible_inside = 0;
      for (int y0 = rect.y0; y0 < rect.y1; y0 += kTile) {
        for (int x0 = rect.x0; x0 < rect.x1; x0 += kTile) {
          // A pixel where the object is visible is in its full mask whatever its ray would
          // find, so only the others are traced; a tile inside the visible object traces none.
          bool any_traced = false;
          for (int i = 0; i < kLanes; ++i) {
            const int x = x0 + i % kTile, y = y0 + i / kTile;
            inside[i] = x < rect.x1 && y < rect.y1;
            pixel[i] = inside[i] ? static_cast<uint32_t>(y) * static_cast<uint32_t>(w) + static_cast<uint32_t>(x) : 0;
            seen[i] = inside[i] && ids[pixel[i]] == id;
            valid[i] = inside[i] && !seen[i] ? -1 : 0;
            if (!valid[i]) continue;
            any_traced = true;
            SetRayLane(&rays, i, eye, pixel_rays.Kept(x, y), tnear);
          }
          if (any_traced) Occluded16(valid, scene.get(), &context, &rays);
          for (int i = 0; i < kLanes; ++i) {
            if (!inside[i]) continue;
            visible_inside += seen[i];
            // An occluded ray's tfar is set to -inf.
            if (!(seen[i] || rays.tfar[i] < 0)) continue;
            ++count;
            if (masks) {
              const int x = x0 + i % kTile, y = y0 + i / kTile;
              full_windows[k][static_cast<size_t>(x - rect.x0) * rect_height + (y - rect.y0)] = 1;
            }
          }
        }
      }
      full_counts[k] = count + (visible_counts[k] - visible_inside);
      if (visible_counts[k] != visible_inside) visible_outside_a_box = true;
    }
  };
  RunOnThreads(std::clamp(options.threads, 1, std::max<int>(1, static_cast<int>(objects))), trace_full);
  // Visible pixels outside an object's window: none unless rounding put them there. The
  // window of such an object grows to hold them.
  std::vector<std::vector<uint8_t>> grown_windows;
  if (masks && visible_outside_a_box) {
    std::vector<PixelRect> reach = windows;
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const uint32_t id = ids[static_cast<size_t>(y) * w + x];
        if (id != 0) reach[id - 1].Include(x, y);
      }
    }
    for (size_t k = 0; k < objects; ++k) {
      if (reach[k] == windows[k]) continue;
      const PixelRect& old = windows[k];
      std::vector<uint8_t>& grown = grown_windows.emplace_back(reach[k].Area(), 0);
      const int old_height = old.y1 - old.y0, new_height = reach[k].y1 - reach[k].y0;
      for (int x = old.x0; x < old.x1; ++x) {
        std::copy_n(full_windows[k] + static_cast<size_t>(x - old.x0) * old_height, old_height,
                    grown.data() + static_cast<size_t>(x - reach[k].x0) * new_height + (old.y0 - reach[k].y0));
      }
      full_windows[k] = grown.data();
      windows[k] = reach[k];
    }
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const uint32_t id = ids[static_cast<size_t>(y) * w + x];
        if (id == 0) continue;
        const PixelRect& r = windows[id - 1];
        full_windows[id - 1][static_cast<size_t>(x - r.x0) * (r.y1 - r.y0) + (y - r.y0)] = 1;
      }
    }
  }

  std::vector<rle::IdRle> visible;
  rle::Rle empty;
  if (masks) {
    visible = rle::EncodeIdImageRowMajor(out.ids, h, w);
    empty = rle::EncodeRowMajor(std::vector<uint8_t>(pixels, 0), h, w);
  }
  out.instances.resize(objects);
  for (size_t k = 0; k < objects; ++k) {
    const PlacedObject& o = layout.objects[k];
    InstanceRecord& r = out.instances[k];
    r.image_id = layout.index;
    r.ordinal = static_cast<int32_t>(k);
    r.model_key = o.model_key;
    if (masks) {
      const auto it = std::lower_bound(visible.begin(), visible.end(), static_cast<uint32_t>(k + 1),
                                       [](const rle::IdRle& e, uint32_t id) { return e.id < id; });
      const rle::Rle& vis = it != visible.end() && it->id == k + 1 ? it->rle : empty;
      const PixelRect& window = windows[k];
      const rle::Rle full_rle = rle::EncodeColumnMajorWindow(
          {full_windows[k], window.Area()}, static_cast<uint32_t>(window.x0), static_cast<uint32_t>(window.y0),
          static_cast<uint32_t>(window.x1 - window.x0), static_cast<uint32_t>(window.y1 - window.y0), h, w);
      SOLID_RETURN_IF_ERROR(SetInstanceMasks(vis, full_rle, &r, options.area_scale).WithContext(
          fmt::format("layout {} object {} ({})", layout.index, k, o.model_key)));
      r.truncation = Truncation(layout, o);
    } else {
      SetInstanceAreas(visible_counts[k], full_counts[k], &r, options.area_scale);
    }
    r.world_from_object = o.WorldFromObject();
    r.object_scale = o.size_m;
    r.camera_distance = Length(eye - o.position);
    const Vec3 view = o.rotation.Transposed() * (eye - o.position);
    r.view_azimuth = std::atan2(view.y, view.x);
    r.view_elevation = std::atan2(view.z, std::hypot(view.x, view.y));
    if (r.visible_area >= static_cast<uint64_t>(std::max(1, min_visible_pixels))) ++out.visible_objects;
  }
  return out;
}

}  // namespace solid::render
