#include "solid/render/mask_pass.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>

#include <fmt/format.h>

#include "instance_scene.h"
#include "solid/formats/workers.h"

namespace solid::render {
namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();
constexpr int kMaxTruncationSamples = 4096;

// Rays go in 4x4 pixel tiles as one Embree packet: coherent primary rays traverse the
// BVHs together, about three times faster than one by one here (bench/mask_pass_bench).
constexpr int kTile = 4;
constexpr int kLanes = kTile * kTile;

// The intersect context of an object packet: Embree hands it back to the filter, which
// records what each ray crosses. Embree's context must be the first member.
struct CrossingContext {
  RTCIntersectContext base;
  uint32_t pixel[kLanes] = {};
  float nearest_t[kLanes] = {};
  uint32_t nearest[kLanes] = {};
  uint8_t* const* full = nullptr;  // full pass: per object, its full mask, row-major
  // Metrics-only pass: a ray crosses an object once per surface, so each (lane, object)
  // remembers the pixel it last counted (+ 1) and full_counts[object] counts pixels.
  uint32_t* counted = nullptr;  // kLanes x objects
  uint64_t* full_counts = nullptr;
  size_t objects = 0;
};

void RecordCrossings(const RTCFilterFunctionNArguments* args) {
  auto* ctx = reinterpret_cast<CrossingContext*>(const_cast<RTCIntersectContext*>(args->context));
  // Embree calls with N = the packet width; lane i is lane i of the packet, also when it
  // traverses one ray of the packet alone.
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    // During the filter call Embree has set the ray's tfar to the candidate hit's distance.
    const float t = RTCRayN_tfar(args->ray, args->N, i);
    const uint32_t object = RTCHitN_instID(args->hit, args->N, i, 0);
    if (t < ctx->nearest_t[i]) {
      ctx->nearest_t[i] = t;
      ctx->nearest[i] = object;
    }
    if (ctx->full != nullptr) {
      ctx->full[object][ctx->pixel[i]] = 1;
    } else if (uint32_t& last = ctx->counted[i * ctx->objects + object]; last != ctx->pixel[i] + 1) {
      last = ctx->pixel[i] + 1;
      ++ctx->full_counts[object];
    }
    args->valid[i] = 0;  // reject: traversal goes on to farther surfaces
  }
}

void SetLane(RTCRayHit16* packet, int i, Vec3 origin, Vec3 direction, float tnear) {
  packet->ray.org_x[i] = static_cast<float>(origin.x);
  packet->ray.org_y[i] = static_cast<float>(origin.y);
  packet->ray.org_z[i] = static_cast<float>(origin.z);
  packet->ray.dir_x[i] = static_cast<float>(direction.x);
  packet->ray.dir_y[i] = static_cast<float>(direction.y);
  packet->ray.dir_z[i] = static_cast<float>(direction.z);
  packet->ray.tnear[i] = tnear;
  packet->ray.tfar[i] = kInfinity;
  packet->ray.time[i] = 0;
  packet->ray.mask[i] = UINT32_MAX;
  packet->ray.id[i] = 0;
  packet->ray.flags[i] = 0;
  packet->hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
  packet->hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
}

// See the header: the share of the object's silhouette outside the image.
double Truncation(const Layout& layout, const PlacedObject& o) {
  const Camera& cam = layout.camera;
  const double w = layout.width, h = layout.height;
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
  bool in_front = true;
  for (int c = 0; c < 8; ++c) {
    double u = 0, v = 0;
    if (!Project(cam, o.box.Corner(c), layout.near, &u, &v)) {
      in_front = false;
      break;
    }
    u0 = std::min(u0, u);
    u1 = std::max(u1, u);
    v0 = std::min(v0, v);
    v1 = std::max(v1, v);
  }
  if (in_front && u0 >= 0 && u1 <= w && v0 >= 0 && v1 <= h) return 0;
  if (!in_front) {
    u0 = -w, u1 = 2 * w, v0 = -h, v1 = 2 * h;
  } else {
    u0 = std::max(u0, -w), u1 = std::min(u1, 2 * w), v0 = std::max(v0, -h), v1 = std::min(v1, 2 * h);
  }
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
  // Every full mask in one zeroed block: one allocation per layout, not one copy per object.
  std::vector<uint8_t> full;
  std::vector<uint8_t*> full_rows;
  if (masks) {
    out.ids.assign(pixels, 0);
    out.depth.assign(pixels, kInfinity);
    full.assign(objects * pixels, 0);
    full_rows.resize(objects);
    for (size_t k = 0; k < objects; ++k) full_rows[k] = full.data() + k * pixels;
  }
  // Metrics-only: pixel counts, summed over the threads.
  std::vector<uint64_t> visible_counts(masks ? 0 : objects, 0), full_counts(masks ? 0 : objects, 0);
  std::mutex counts_mutex;

  const ObjectScene object_scene(layout.room->device()->handle(), layout);
  RTCScene room = reinterpret_cast<RTCScene>(layout.room->scene());
  const Camera& cam = layout.camera;
  const Vec3 eye = CameraPosition(cam);
  const float tnear = static_cast<float>(layout.near);

  // Threads take tile rows from a shared counter: objects crowd some rows (near the
  // floor) and leave others (walls, ceiling) nearly free, so fixed bands balance badly.
  // Each tile is one packet against the room and one against the objects.
  const int tile_rows = (h + kTile - 1) / kTile;
  std::atomic<int> next_tile_row{0};
  auto trace_tile_rows = [&] {
    CrossingContext ctx;
    rtcInitIntersectContext(&ctx.base);
    ctx.base.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    ctx.base.filter = RecordCrossings;
    std::vector<uint32_t> counted;
    std::vector<uint64_t> thread_visible, thread_full;
    if (masks) {
      ctx.full = full_rows.data();
    } else {
      counted.assign(kLanes * objects, 0);
      thread_visible.assign(objects, 0);
      thread_full.assign(objects, 0);
      ctx.counted = counted.data();
      ctx.full_counts = thread_full.data();
      ctx.objects = objects;
    }
    RTCIntersectContext room_ctx;
    rtcInitIntersectContext(&room_ctx);
    room_ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    alignas(64) int valid[kLanes];
    float length[kLanes];
    RTCRayHit16 room_rays, object_rays;
    for (int tile_y; (tile_y = next_tile_row.fetch_add(1, std::memory_order_relaxed)) < tile_rows;) {
      for (int x0 = 0; x0 < w; x0 += kTile) {
        for (int i = 0; i < kLanes; ++i) {
          const int x = x0 + i % kTile, y = tile_y * kTile + i / kTile;
          valid[i] = x < w && y < h ? -1 : 0;
          ctx.pixel[i] = valid[i] ? static_cast<uint32_t>(y) * static_cast<uint32_t>(w) + static_cast<uint32_t>(x) : 0;
          ctx.nearest_t[i] = kInfinity;
          ctx.nearest[i] = RTC_INVALID_GEOMETRY_ID;
          const Vec3 raw = RayDirection(cam, x + 0.5, y + 0.5);
          length[i] = static_cast<float>(Length(raw));
          // Depth along -Z: raw has camera-space z = -1, so depth = t / length.
          SetLane(&room_rays, i, eye, raw * (1.0 / Length(raw)), tnear);
        }
        object_rays = room_rays;
        rtcIntersect16(valid, room, &room_ctx, &room_rays);
        if (objects > 0) rtcIntersect16(valid, object_scene.get(), &ctx.base, &object_rays);
        for (int i = 0; i < kLanes; ++i) {
          if (!valid[i]) continue;
          const uint32_t pixel = ctx.pixel[i];
          const float room_t =
              room_rays.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID ? room_rays.ray.tfar[i] : kInfinity;
          const bool object_nearest = ctx.nearest[i] != RTC_INVALID_GEOMETRY_ID && ctx.nearest_t[i] < room_t;
          if (!masks) {
            if (object_nearest) ++thread_visible[ctx.nearest[i]];
            continue;
          }
          float nearest_t = room_t;
          if (object_nearest) {
            out.ids[pixel] = ctx.nearest[i] + 1;
            nearest_t = ctx.nearest_t[i];
          }
          out.depth[pixel] = nearest_t == kInfinity ? kInfinity : nearest_t / length[i];
        }
      }
    }
    if (!masks) {
      std::lock_guard lock(counts_mutex);
      for (size_t k = 0; k < objects; ++k) {
        visible_counts[k] += thread_visible[k];
        full_counts[k] += thread_full[k];
      }
    }
  };
  RunOnThreads(std::clamp(options.threads, 1, std::max(1, tile_rows)), trace_tile_rows);

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
      const rle::Rle full_rle = rle::EncodeRowMajor({full_rows[k], pixels}, h, w);
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
