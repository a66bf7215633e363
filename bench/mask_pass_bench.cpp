// Time per layout of the mask pass (visible ids, every full mask, depth, boxes,
// truncation) and of its metrics-only form (areas alone: the optimizer's evaluations)
// next to the floor of any ray-cast mask pass: one plain Embree primary
// ray per pixel, nearest hit, over the same scene (room and instances in one
// top-level scene), on the same layouts, threads and resolution, in the same run. Wall
// time, and CPU time of the process for the mask pass and the packet floor (on a loaded
// host, what each costs whatever else runs).
//
//   mask_pass_bench [--assets DIR] [--preset more-objects] [--layouts 50] [--repeat 3]
//                   [--resolution 320x240] [--threads 1,2]
//
// Without --assets it converts 16 procedural shapes of 10k-20k triangles and 3 rooms
// into a temporary directory (the "about 14 objects of 10k-20k triangles").
#include <embree3/rtcore.h>
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "solid/convert/convert.h"
#include "solid/render/assets.h"
#include "solid/render/layout.h"
#include "solid/render/mask_pass.h"
#include "solid/render/params.h"
#include "solid/render/sample.h"

#include "room.h"

namespace {

namespace fs = std::filesystem;
using namespace solid;
using namespace solid::render;
using Clock = std::chrono::steady_clock;

double MillisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// CPU time of the whole process (every thread), ms: on a loaded host the work a pass
// costs, where its wall time also holds the time other processes took.
double CpuMilliseconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  auto ms = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_usec) * 1e-3;
  };
  return ms(usage.ru_utime) + ms(usage.ru_stime);
}

// The floor: the room and every object as instances of one top-level scene, one ray per
// pixel centre, and only the nearest hit's instance and distance kept. Measured with
// single rays and with 4x4 packets (what the mask pass uses); the ratio is against the
// faster of the two.
struct FloorResult {
  std::vector<uint32_t> ids;
  std::vector<float> t;
};

enum class FloorKind { kSingle, kPacket };  // rtcIntersect1 per ray, or rtcIntersect16 per 4x4 tile

void TraceFloor(const Layout& layout, int threads, FloorKind kind, FloorResult* out) {
  RTCDevice device = layout.room->device()->handle();
  RTCScene scene = rtcNewScene(device);
  auto attach = [&](RTCScene child, const float* row_major_3x4, unsigned id) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(g, child);
    rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, row_major_3x4);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(scene, g, id);
    rtcReleaseGeometry(g);
  };
  const float identity[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  attach(reinterpret_cast<RTCScene>(layout.room->scene()), identity, 0);
  for (size_t k = 0; k < layout.objects.size(); ++k) {
    const Affine3x4 a = layout.objects[k].WorldFromObject();
    float m[12];
    for (int i = 0; i < 12; ++i) m[i] = static_cast<float>(a[i]);
    attach(reinterpret_cast<RTCScene>(layout.objects[k].asset->scene()), m, static_cast<unsigned>(k + 1));
  }
  rtcCommitScene(scene);

  const int w = layout.width, h = layout.height;
  out->ids.assign(static_cast<size_t>(w) * h, 0);
  out->t.assign(static_cast<size_t>(w) * h, 0);
  const Vec3 eye = CameraPosition(layout.camera);
  const float tnear = static_cast<float>(layout.near);
  // The same work split as the mask pass: rows of 4x4 tiles from a shared counter.
  const int tile_rows = (h + 3) / 4;
  std::atomic<int> next_tile_row{0};
  auto trace = [&] {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (int tile_y; (tile_y = next_tile_row.fetch_add(1)) < tile_rows;) {
      for (int x0 = 0; x0 < w; x0 += 4) {
        alignas(64) int valid[16];
        RTCRayHit16 packet;
        RTCRayHit single[16];
        for (int i = 0; i < 16; ++i) {
          const int x = x0 + i % 4, y = tile_y * 4 + i / 4;
          valid[i] = x < w && y < h ? -1 : 0;
          const Vec3 d = Normalize(RayDirection(layout.camera, x + 0.5, y + 0.5));
          RTCRayHit& r = single[i];
          r = RTCRayHit{};
          r.ray.org_x = static_cast<float>(eye.x), r.ray.org_y = static_cast<float>(eye.y);
          r.ray.org_z = static_cast<float>(eye.z);
          r.ray.dir_x = static_cast<float>(d.x), r.ray.dir_y = static_cast<float>(d.y);
          r.ray.dir_z = static_cast<float>(d.z);
          r.ray.tnear = tnear;
          r.ray.tfar = std::numeric_limits<float>::infinity();
          r.ray.mask = UINT32_MAX;
          r.hit.geomID = RTC_INVALID_GEOMETRY_ID;
          r.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
          if (kind == FloorKind::kPacket) {
            packet.ray.org_x[i] = r.ray.org_x, packet.ray.org_y[i] = r.ray.org_y, packet.ray.org_z[i] = r.ray.org_z;
            packet.ray.dir_x[i] = r.ray.dir_x, packet.ray.dir_y[i] = r.ray.dir_y, packet.ray.dir_z[i] = r.ray.dir_z;
            packet.ray.tnear[i] = tnear, packet.ray.tfar[i] = r.ray.tfar, packet.ray.time[i] = 0;
            packet.ray.mask[i] = UINT32_MAX, packet.ray.id[i] = 0, packet.ray.flags[i] = 0;
            packet.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID, packet.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
          } else if (valid[i]) {
            rtcIntersect1(scene, &context, &r);
          }
        }
        if (kind == FloorKind::kPacket) rtcIntersect16(valid, scene, &context, &packet);
        for (int i = 0; i < 16; ++i) {
          if (!valid[i]) continue;
          const size_t pixel = static_cast<size_t>(tile_y * 4 + i / 4) * w + x0 + i % 4;
          const bool packed = kind == FloorKind::kPacket;
          out->ids[pixel] = packed ? packet.hit.instID[0][i] : single[i].hit.instID[0];
          out->t[pixel] = packed ? packet.ray.tfar[i] : single[i].ray.tfar;
        }
      }
    }
  };
  if (threads == 1) {
    trace();
  } else {
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) pool.emplace_back(trace);
    for (std::thread& t : pool) t.join();
  }
  rtcReleaseScene(scene);
}

int Run(int argc, char** argv) {
  CLI::App app{"Mask pass time per layout against one primary ray per pixel"};
  std::string assets, preset = "more-objects", resolution = "320x240";
  int layouts = 50, repeat = 3, max_objects = 14;
  std::vector<int> thread_counts = {1, 2};
  uint64_t seed = 1;
  app.add_option("--assets", assets, "Assets directory (default: procedural, 10k-20k triangles per shape)");
  app.add_option("--preset", preset, "Layout preset")->capture_default_str();
  app.add_option("--layouts", layouts, "Layouts")->capture_default_str();
  app.add_option("--repeat", repeat, "Passes over the layouts per measurement (the fastest counts)")
      ->capture_default_str();
  app.add_option("--resolution", resolution, "WxH")->capture_default_str();
  app.add_option("--threads", thread_counts, "Thread counts to measure")->delimiter(',');
  app.add_option("--seed", seed, "Dataset seed")->capture_default_str();
  app.add_option("--max-objects", max_objects, "Keep the first N placed objects of each layout (0: all)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  int width = 0, height = 0;
  if (std::sscanf(resolution.c_str(), "%dx%d", &width, &height) != 2 || width <= 0 || height <= 0) {
    fmt::print(stderr, "--resolution: expected WxH, got {}\n", resolution);
    return 2;
  }
  fs::path dir = assets;
  const bool temporary = assets.empty();
  if (temporary) {
    dir = fs::temp_directory_path() / fmt::format("solid-mask-bench-{}", ::getpid());
    convert::ProceduralSet set{16, 3, 7};
    set.shapes.min_triangles = 10000;
    set.shapes.max_triangles = 20000;
    const auto converted = convert::Convert({.out = dir, .procedural = set});
    if (!converted.ok() || converted->failed != 0) {
      fmt::print(stderr, "procedural assets: {}\n", converted.ok() ? "failures" : converted.status().ToString());
      return 1;
    }
  }
  auto library = AssetLibrary::Open(dir, dir);
  auto params = LoadPreset(preset);
  if (!library.ok() || !params.ok()) {
    fmt::print(stderr, "{}\n", library.ok() ? params.status().ToString() : library.status().ToString());
    return 1;
  }
  params->width = width;
  params->height = height;
  auto sampler = LayoutSampler::Create(*params, *library);
  if (!sampler.ok()) {
    fmt::print(stderr, "{}\n", sampler.status().ToString());
    return 1;
  }

  std::vector<Layout> drawn;
  double objects = 0, triangles = 0;
  for (int i = 0; i < layouts; ++i) {
    auto generated = GenerateLayout(**sampler, seed, i);
    if (!generated.ok()) continue;
    std::vector<PlacedObject>& placed = generated->layout.objects;
    if (max_objects > 0 && placed.size() > static_cast<size_t>(max_objects)) placed.resize(max_objects);
    for (const PlacedObject& o : generated->layout.objects) triangles += o.asset->mesh().TriangleCount();
    objects += generated->layout.objects.size();
    drawn.push_back(std::move(generated->layout));
  }
  if (drawn.empty()) {
    fmt::print(stderr, "no usable layout\n");
    return 1;
  }
  fmt::print("{} layouts of preset {} at {}x{}: {:.1f} objects per layout, {:.0f} triangles per object\n",
             drawn.size(), preset, width, height, objects / drawn.size(), triangles / std::max(1.0, objects));

  fmt::print("{:>8} {:>14} {:>16} {:>18} {:>18} {:>8} {:>18} {:>18} {:>10}\n", "threads", "mask pass ms",
             "metrics-only ms", "floor ms (rays)", "floor ms (packets)", "ratio", "mask pass cpu ms",
             "floor cpu ms (pk)", "cpu ratio");
  for (int threads : thread_counts) {
    const double infinity = std::numeric_limits<double>::infinity();
    double best_mask = infinity, best_metrics = infinity, best_single = infinity, best_packet = infinity;
    double cpu_mask = infinity, cpu_packet = infinity;
    FloorResult floor;
    for (int r = 0; r < repeat; ++r) {
      auto start = Clock::now();
      double cpu = CpuMilliseconds();
      for (const Layout& layout : drawn) {
        auto masks = RunMaskPass(layout, params->min_visible_pixels, {.threads = threads});
        if (!masks.ok()) {
          fmt::print(stderr, "{}\n", masks.status().ToString());
          return 1;
        }
      }
      best_mask = std::min(best_mask, MillisecondsSince(start) / drawn.size());
      cpu_mask = std::min(cpu_mask, (CpuMilliseconds() - cpu) / drawn.size());
      start = Clock::now();
      for (const Layout& layout : drawn) {
        auto counted = RunMaskPass(layout, params->min_visible_pixels, {.threads = threads, .metrics_only = true});
        if (!counted.ok()) {
          fmt::print(stderr, "{}\n", counted.status().ToString());
          return 1;
        }
      }
      best_metrics = std::min(best_metrics, MillisecondsSince(start) / drawn.size());
      start = Clock::now();
      for (const Layout& layout : drawn) TraceFloor(layout, threads, FloorKind::kSingle, &floor);
      best_single = std::min(best_single, MillisecondsSince(start) / drawn.size());
      start = Clock::now();
      cpu = CpuMilliseconds();
      for (const Layout& layout : drawn) TraceFloor(layout, threads, FloorKind::kPacket, &floor);
      best_packet = std::min(best_packet, MillisecondsSince(start) / drawn.size());
      cpu_packet = std::min(cpu_packet, (CpuMilliseconds() - cpu) / drawn.size());
    }
    fmt::print("{:>8} {:>14.2f} {:>16.2f} {:>18.2f} {:>18.2f} {:>7.2f}x {:>18.2f} {:>18.2f} {:>9.2f}x\n",
               threads, best_mask, best_metrics, best_single, best_packet,
               best_mask / std::min(best_single, best_packet), cpu_mask, cpu_packet, cpu_mask / cpu_packet);
  }
  if (temporary) fs::remove_all(dir);
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return Run(argc, argv); }
