// Canonical scenes with exact expected masks: pixel (x, y) belongs to a camera-facing
// rectangle exactly when the ray through its centre crosses it, which the tests
// compute analytically. Scenes are chosen so that no pixel centre lies on an edge.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "render/test_assets.h"
#include "room.h"
#include "solid/formats/rle.h"
#include "solid/render/mask_pass.h"
#include "solid/render/sample.h"

namespace solid::render {
namespace {

constexpr int kWidth = 64, kHeight = 48;
// fx = fy = 64 px: a point (X, Z) at depth D lands at u = 32 + 64 X / D, v = 24 - 64 Z / D.
const double kHfovDeg = 2 * std::atan(0.5) * 180 / std::numbers::pi;

std::shared_ptr<Device> TestDevice() {
  static std::shared_ptr<Device> device = Device::Create().value();
  return device;
}

// An axis-aligned box of the given size (world x, y, z), as a glTF asset (Y up).
gltf::Asset BoxAsset(double sx, double sy, double sz) {
  gltf::Primitive p;
  for (int i = 0; i < 8; ++i) {
    const double x = (i & 1 ? 0.5 : -0.5) * sx, y = (i & 2 ? 0.5 : -0.5) * sy, z = (i & 4 ? 0.5 : -0.5) * sz;
    // world (x, y, z) is glTF (x, z, -y)
    p.positions.insert(p.positions.end(), {float(x), float(z), float(-y)});
  }
  p.indices = {0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3};
  gltf::Asset a;
  a.nodes.push_back({"box", {p}, nlohmann::json::object()});
  return a;
}

// A rectangle of width sx (world x) and height sz (world z) in the plane y = 0.
gltf::Asset QuadAsset(double sx, double sz) {
  gltf::Primitive p;
  for (int i = 0; i < 4; ++i) {
    const double x = (i & 1 ? 0.5 : -0.5) * sx, z = (i & 2 ? 0.5 : -0.5) * sz;
    p.positions.insert(p.positions.end(), {float(x), float(z), 0.0f});
  }
  p.indices = {0, 1, 3, 0, 3, 2};
  gltf::Asset a;
  a.nodes.push_back({"quad", {p}, nlohmann::json::object()});
  return a;
}

// A rectangle of sx by sy (world x, y) in the plane z = 0.
gltf::Asset FloorQuadAsset(double sx, double sy) {
  gltf::Primitive p;
  for (int i = 0; i < 4; ++i) {
    const double x = (i & 1 ? 0.5 : -0.5) * sx, y = (i & 2 ? 0.5 : -0.5) * sy;
    p.positions.insert(p.positions.end(), {float(x), 0.0f, float(-y)});
  }
  p.indices = {0, 1, 3, 0, 3, 2};
  gltf::Asset a;
  a.nodes.push_back({"floor_quad", {p}, nlohmann::json::object()});
  return a;
}

class Scene {
 public:
  Scene() {
    LayoutParams params;
    params.scene = SceneKind::kWhiteCube;
    layout_.room = RoomShell::WhiteCube(TestDevice(), params).value();
    layout_.width = kWidth;
    layout_.height = kHeight;
    layout_.near = 0.1;
    EXPECT_TRUE(LookAt({0, -5, 1}, {0, 0, 1}, kHfovDeg, kWidth, kHeight, &layout_.camera));
  }
  void Add(const gltf::Asset& asset, Vec3 position) {
    PlacedObject o;
    o.asset = LoadedAsset::Build(TestDevice(), "object", asset, true).value();
    o.model_key = "test/" + std::to_string(layout_.objects.size());
    o.scale = 1;
    o.size_m = o.asset->largest_extent();
    o.position = position;
    o.box = Obb{position, Mat3{}, o.asset->half_extents()};
    layout_.objects.push_back(o);
  }
  MaskPassResult Run(int threads = 1) { return RunMaskPass(layout_, 1, MaskPassOptions{threads}).value(); }
  Layout& layout() { return layout_; }

 private:
  Layout layout_;
};

// The expected mask of a camera-facing rectangle x in [x0, x1], z in [z0, z1] at
// distance `depth` in front of the camera at (0, -5, 1).
std::vector<uint8_t> RectMask(double x0, double x1, double z0, double z1, double depth) {
  std::vector<uint8_t> mask(kWidth * kHeight, 0);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const double wx = (x + 0.5 - 32) * depth / 64, wz = 1 + (24 - (y + 0.5)) * depth / 64;
      mask[y * kWidth + x] = wx >= x0 && wx <= x1 && wz >= z0 && wz <= z1;
    }
  }
  return mask;
}

std::vector<uint8_t> AndNot(std::vector<uint8_t> a, const std::vector<uint8_t>& b) {
  for (size_t i = 0; i < a.size(); ++i) a[i] = a[i] && !b[i];
  return a;
}

std::string Rle(const std::vector<uint8_t>& mask) { return rle::ToString(rle::EncodeRowMajor(mask, kHeight, kWidth)); }

TEST(MaskPass, OneCubeVisibleEqualsFullAndDepthIsExact) {
  Scene scene;
  scene.Add(BoxAsset(1, 1, 1), {0, 0, 1});
  const MaskPassResult r = scene.Run();
  ASSERT_EQ(r.instances.size(), 1u);
  const InstanceRecord& cube = r.instances[0];
  // The silhouette is the front face, 4.5 m away.
  const auto expected = RectMask(-0.5, 0.5, 0.5, 1.5, 4.5);
  EXPECT_EQ(cube.visible_rle, Rle(expected));
  EXPECT_EQ(cube.full_rle, Rle(expected));
  EXPECT_EQ(cube.visible_area, 196u);
  EXPECT_EQ(cube.visible_box, (rle::Box{25, 17, 14, 14}));
  ASSERT_TRUE(cube.occlusion.has_value());
  EXPECT_EQ(*cube.occlusion, 0.0);
  EXPECT_EQ(cube.truncation, 0.0);
  EXPECT_EQ(r.visible_objects, 1);
  EXPECT_NEAR(r.depth[24 * kWidth + 32], 4.5, 1e-4);
  EXPECT_EQ(r.ids[24 * kWidth + 32], 1u);
  // The background is the white cube's far wall at y = 6, 11 m away.
  EXPECT_EQ(r.ids[2 * kWidth + 2], 0u);
  EXPECT_NEAR(r.depth[24 * kWidth + 2], 11.0, 1e-3);
  EXPECT_NEAR(cube.camera_distance, 5.0, 1e-12);
  // Seen from -Y in the object's frame: azimuth -90 degrees, elevation 0.
  EXPECT_NEAR(cube.view_azimuth, -std::numbers::pi / 2, 1e-12);
  EXPECT_NEAR(cube.view_elevation, 0.0, 1e-12);
}

TEST(MaskPass, RearQuadKeepsItsWholeFullMaskAndLosesTheOverlap) {
  Scene scene;
  scene.Add(QuadAsset(1, 1), {-0.25, -1, 1});  // 4 m away
  scene.Add(QuadAsset(1, 1), {0.25, 0, 1});    // 5 m away
  const MaskPassResult r = scene.Run();
  const auto front = RectMask(-0.75, 0.25, 0.5, 1.5, 4);
  const auto rear = RectMask(-0.25, 0.75, 0.5, 1.5, 5);
  EXPECT_EQ(r.instances[0].visible_rle, Rle(front));
  EXPECT_EQ(r.instances[0].full_rle, Rle(front));
  EXPECT_EQ(r.instances[1].full_rle, Rle(rear));
  EXPECT_EQ(r.instances[1].visible_rle, Rle(AndNot(rear, front)));
  const double n_f = r.instances[1].full_area, n_p = r.instances[1].visible_area;
  EXPECT_GT(n_f, n_p);
  EXPECT_EQ(*r.instances[1].occlusion, (n_f - n_p) / n_f);
  EXPECT_EQ(*r.instances[0].occlusion, 0.0);
}

TEST(MaskPass, FullyOccludedObjectHasNoVisiblePixels) {
  Scene scene;
  scene.Add(QuadAsset(1, 1), {0, -1, 1});
  scene.Add(QuadAsset(0.4, 0.4), {0, 1, 1});  // behind the first, inside its shadow
  const MaskPassResult r = scene.Run();
  const InstanceRecord& hidden = r.instances[1];
  EXPECT_EQ(hidden.visible_area, 0u);
  EXPECT_EQ(hidden.full_rle, Rle(RectMask(-0.2, 0.2, 0.8, 1.2, 6)));
  EXPECT_GT(hidden.full_area, 0u);
  EXPECT_EQ(*hidden.occlusion, 1.0);
  EXPECT_FALSE(hidden.scale_class.has_value());
  EXPECT_EQ(r.visible_objects, 1);
}

TEST(MaskPass, ObjectCrossingTheBorderIsTruncatedNotOccluded) {
  Scene scene;
  // Centred on the right image edge (u = 64 at x = 2.5, 5 m away): half of it is outside.
  scene.Add(QuadAsset(1, 1), {2.5, 0, 1});
  const MaskPassResult r = scene.Run();
  const InstanceRecord& q = r.instances[0];
  EXPECT_EQ(q.full_rle, Rle(RectMask(2.0, 3.0, 0.5, 1.5, 5)));
  EXPECT_EQ(q.visible_rle, q.full_rle);
  EXPECT_EQ(*q.occlusion, 0.0);  // clipping at the border is not occlusion
  EXPECT_NEAR(q.truncation, 0.5, 0.05);
}

// The full masks are traced over the pixels an object's box projects to; a box that
// reaches behind the camera projects nowhere, and its object is traced over the whole image.
TEST(MaskPass, ObjectReachingBehindTheCameraKeepsItsWholeFullMask) {
  Scene scene;
  // 0.7 m below the camera, from 1.2 m behind it to 3.8 m in front (y in [-6.2, -1.2]),
  // x in [-1.27, 1.27]: no pixel centre falls exactly on an edge.
  scene.Add(FloorQuadAsset(2.54, 5), {0, -3.7, 0.3});
  // A square 2 m in front of the camera, above the quad's plane, hides part of it: what the
  // full mask holds there, only the full pass can have found.
  scene.Add(QuadAsset(1, 1), {0, -3, 0.85});
  const MaskPassResult r = scene.Run();
  const InstanceRecord& q = r.instances[0];
  std::vector<uint8_t> expected(kWidth * kHeight, 0);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      // The pixel's ray from (0, -5, 1) along ((x + 0.5 - 32) / 64, 1, (24 - (y + 0.5)) / 64).
      const double dx = (x + 0.5 - 32) / 64, dz = (24 - (y + 0.5)) / 64;
      if (dz >= 0) continue;
      const double t = -0.7 / dz, wx = t * dx, wy = -5 + t;
      expected[y * kWidth + x] = std::fabs(wx) <= 1.27 && wy >= -6.2 && wy <= -1.2;
    }
  }
  EXPECT_EQ(q.full_rle, Rle(expected));
  EXPECT_EQ(q.visible_rle, Rle(AndNot(expected, RectMask(-0.5, 0.5, 0.35, 1.35, 2))));
  EXPECT_GT(q.full_area, q.visible_area + 100);
}

TEST(MaskPass, ObjectBehindAWallIsInvisibleButKeepsItsFullMask) {
  Scene scene;
  scene.Add(QuadAsset(1, 1), {0, 8, 1});  // beyond the white cube's wall at y = 6
  const MaskPassResult r = scene.Run();
  const InstanceRecord& q = r.instances[0];
  EXPECT_EQ(q.visible_area, 0u);
  EXPECT_EQ(q.full_rle, Rle(RectMask(-0.5, 0.5, 0.5, 1.5, 13)));
  EXPECT_EQ(*q.occlusion, 1.0);
  EXPECT_EQ(r.visible_objects, 0);
}

TEST(MaskPass, ThreadCountDoesNotChangeAnything) {
  Scene scene;
  scene.Add(QuadAsset(1, 1), {-0.25, -1, 1});
  scene.Add(BoxAsset(0.7, 0.5, 1.2), {0.4, 0.5, 0.9});
  const MaskPassResult one = scene.Run(1), three = scene.Run(3);
  EXPECT_EQ(one.ids, three.ids);
  EXPECT_EQ(one.depth, three.depth);
  EXPECT_EQ(one.centre_hits, three.centre_hits);
  for (size_t k = 0; k < one.instances.size(); ++k) {
    EXPECT_EQ(one.instances[k].visible_rle, three.instances[k].visible_rle);
    EXPECT_EQ(one.instances[k].full_rle, three.instances[k].full_rle);
  }
}

// Each pixel's centre hit names what `ids` and `depth` say is nearest: the object, the
// room (object count) or nothing, at the depth's distance along the unit ray.
TEST(MaskPass, CentreHitsAgreeWithIdsAndDepth) {
  const testing::SmallLayout drawn = testing::DrawSmallLayout("more-objects", 3);
  const GeneratedLayout& g = drawn.g;
  const MaskPassResult& m = g.masks;
  ASSERT_EQ(m.centre_hits.size(), m.ids.size());
  const auto objects = static_cast<uint32_t>(g.layout.objects.size());
  int room = 0;
  for (int y = 0; y < m.height; ++y) {
    for (int x = 0; x < m.width; ++x) {
      const size_t p = static_cast<size_t>(y) * m.width + x;
      const MaskPassResult::CentreHit& hit = m.centre_hits[p];
      SCOPED_TRACE(::testing::Message() << x << "," << y);
      if (m.ids[p] != 0) {
        EXPECT_EQ(hit.surface, m.ids[p] - 1);
      } else if (std::isinf(m.depth[p])) {
        EXPECT_EQ(hit.surface, MaskPassResult::CentreHit::kNothing);
        continue;
      } else {
        EXPECT_EQ(hit.surface, objects);
        ++room;
      }
      const double length = Length(RayDirection(g.layout.camera, x + 0.5, y + 0.5));
      EXPECT_NEAR(hit.distance, m.depth[p] * length, 1e-5 * hit.distance);
      EXPECT_GE(hit.u, 0.0f);
      EXPECT_GE(hit.v, 0.0f);
      EXPECT_LE(hit.u + hit.v, 1.0f + 1e-6f);
    }
  }
  EXPECT_GT(room, 0);
  // Metrics-only passes keep none.
  EXPECT_TRUE(RunMaskPass(g.layout, 1, {.metrics_only = true}).value().centre_hits.empty());
}

// The optimizer's metrics-only pass counts what the full pass paints: every visible
// object's areas (and so occlusion and scale class) equal, on layouts with many
// overlapping objects, for any thread count. Hidden objects count for no metric, and
// their full masks are not traced: their full area is their visible area, 0.
TEST(MaskPass, MetricsOnlyCountsExactlyTheAreasOfTheFullPass) {
  LayoutParams params = LoadPreset("more-objects").value();
  params.width = 160;
  params.height = 120;
  params.scale_width = 640;
  params.scale_height = 480;
  const auto sampler = LayoutSampler::Create(params, testing::ProceduralLibrary()).value();
  int64_t compared = 0, hidden = 0;
  for (int64_t index = 0; index < 6; ++index) {
    SCOPED_TRACE(index);
    const GeneratedLayout full = GenerateLayout(*sampler, 3, index, {}).value();
    for (int threads : {1, 2}) {
      MaskPassOptions options;
      options.threads = threads;
      options.metrics_only = true;
      const GeneratedLayout counted = GenerateLayout(*sampler, 3, index, options).value();
      EXPECT_TRUE(counted.masks.ids.empty());
      EXPECT_TRUE(counted.masks.depth.empty());
      EXPECT_EQ(counted.masks.visible_objects, full.masks.visible_objects);
      ASSERT_EQ(counted.masks.instances.size(), full.masks.instances.size());
      for (size_t k = 0; k < full.masks.instances.size(); ++k) {
        const InstanceRecord &a = full.masks.instances[k], &b = counted.masks.instances[k];
        EXPECT_EQ(b.visible_area, a.visible_area) << k;
        EXPECT_EQ(b.scale_class, a.scale_class) << k;
        EXPECT_TRUE(b.visible_rle.empty() && b.full_rle.empty());
        if (a.visible_area == 0) {
          EXPECT_EQ(b.full_area, 0u) << k;
          hidden += a.full_area > 0;
          continue;
        }
        EXPECT_EQ(b.full_area, a.full_area) << k;
        EXPECT_EQ(b.occlusion, a.occlusion) << k;
        compared += 1;
      }
    }
  }
  EXPECT_GT(compared, 50) << "the layouts should hold many objects in view";
  EXPECT_GT(hidden, 0) << "and objects hidden behind them";
}

}  // namespace
}  // namespace solid::render
