// Properties of sampled layouts and their mask passes over procedural assets.
#include <gtest/gtest.h>

#include <cmath>

#include "formats/test_util.h"
#include "render/test_assets.h"
#include "room.h"
#include "solid/formats/rle.h"
#include "solid/render/sample.h"

namespace solid::render {
namespace {

LayoutParams WhiteCubeOnFloor() {
  LayoutParams p;
  p.scene = SceneKind::kWhiteCube;
  p.support = Support::kFloor;
  p.rotation_axes = RotationAxes::kZ;
  p.attempts = {9, 9};
  return p;
}

void CheckLayoutProperties(const LayoutParams& params, int layouts) {
  auto sampler = LayoutSampler::Create(params, testing::ProceduralLibrary()).value();
  for (int i = 0; i < layouts; ++i) {
    SCOPED_TRACE("layout " + std::to_string(i));
    const GeneratedLayout g = GenerateLayout(*sampler, 11, i).value();
    const Layout& l = g.layout;
    ASSERT_EQ(g.masks.instances.size(), l.objects.size());
    EXPECT_GE(g.masks.visible_objects, 1);
    for (size_t a = 0; a < l.objects.size(); ++a) {
      const Obb& box = l.objects[a].box;
      EXPECT_TRUE(l.room->InsideValidVolume(box));
      EXPECT_FALSE(l.room->TouchesShell(box));
      for (size_t b = a + 1; b < l.objects.size(); ++b) EXPECT_FALSE(Intersects(box, l.objects[b].box));
      if (params.support == Support::kFloor) {
        double lowest = 1e300;
        for (int c = 0; c < 8; ++c) lowest = std::min(lowest, box.Corner(c).z);
        EXPECT_NEAR(lowest, 0.001, 1e-9);  // resting on the floor at z = 0, 1 mm above it
      }
      const InstanceRecord& r = g.masks.instances[a];
      const rle::Rle visible = rle::FromString(r.visible_rle, l.height, l.width).value();
      const rle::Rle full = rle::FromString(r.full_rle, l.height, l.width).value();
      EXPECT_TRUE(rle::Contains(full, visible));
      EXPECT_EQ(rle::Area(visible), r.visible_area);
      EXPECT_EQ(rle::Area(full), r.full_area);
      EXPECT_EQ(rle::ToBbox(visible), r.visible_box);
      if (r.occlusion) {
        EXPECT_GE(*r.occlusion, 0.0);
        EXPECT_LE(*r.occlusion, 1.0);
      }
      EXPECT_GE(r.truncation, 0.0);
      EXPECT_LE(r.truncation, 1.0);
    }
    // The id image and the visible masks describe the same pixels.
    uint64_t covered = 0;
    for (uint32_t id : g.masks.ids) covered += id != 0;
    uint64_t visible_total = 0;
    for (const InstanceRecord& r : g.masks.instances) visible_total += r.visible_area;
    EXPECT_EQ(covered, visible_total);
  }
}

TEST(Layout, RoomsFloatingObjectsKeepEveryInvariant) { CheckLayoutProperties(LayoutParams{}, 12); }

TEST(Layout, WhiteCubeObjectsRestOnTheFloorAndKeepEveryInvariant) {
  CheckLayoutProperties(WhiteCubeOnFloor(), 12);
}

TEST(Layout, SameSeedSameLayoutWhateverTheOrder) {
  auto sampler = LayoutSampler::Create(LayoutParams{}, testing::ProceduralLibrary()).value();
  const GeneratedLayout a = GenerateLayout(*sampler, 5, 3).value();
  GenerateLayout(*sampler, 5, 7).value();  // other work in between changes nothing
  const GeneratedLayout b = GenerateLayout(*sampler, 5, 3, MaskPassOptions{2}).value();
  ASSERT_EQ(a.masks.instances.size(), b.masks.instances.size());
  EXPECT_EQ(a.layout.camera.world_from_camera, b.layout.camera.world_from_camera);
  for (size_t k = 0; k < a.masks.instances.size(); ++k) {
    EXPECT_EQ(a.masks.instances[k].model_key, b.masks.instances[k].model_key);
    EXPECT_EQ(a.masks.instances[k].world_from_object, b.masks.instances[k].world_from_object);
    EXPECT_EQ(a.masks.instances[k].visible_rle, b.masks.instances[k].visible_rle);
    EXPECT_EQ(a.masks.instances[k].full_rle, b.masks.instances[k].full_rle);
  }
  const GeneratedLayout other_seed = GenerateLayout(*sampler, 6, 3).value();
  EXPECT_NE(a.layout.camera.world_from_camera, other_seed.layout.camera.world_from_camera);
}

// The optimizer's common random numbers: a knob that only changes where centres are
// accepted (here the minimum camera distance) changes how many proposals each try takes,
// but every attempt's model, size and rotation stay the draws they were. With one stream
// for poses and proposals, the second attempt's pose would shift with the first's
// proposal count.
TEST(Layout, PlacementKnobsLeaveEveryPoseDrawWhereItWas) {
  LayoutParams near = WhiteCubeOnFloor();
  near.cluster_prob = 0;
  near.occlude_prob = 0;
  near.min_hdist_m = 2.0;
  LayoutParams far = near;
  far.min_hdist_m = 3.0;
  auto a = LayoutSampler::Create(near, testing::ProceduralLibrary()).value();
  auto b = LayoutSampler::Create(far, testing::ProceduralLibrary()).value();
  int compared = 0, proposals_differ = 0;
  for (int i = 0; i < 24; ++i) {
    SCOPED_TRACE("layout " + std::to_string(i));
    const Layout x = a->Sample(4, i, 0).value();
    const Layout y = b->Sample(4, i, 0).value();
    ASSERT_EQ(x.stats.attempts, y.stats.attempts);
    // Every attempt placed at its first pose try in both: the objects pair up one to one.
    if (x.stats.pose_tries != x.stats.attempts || y.stats.pose_tries != y.stats.attempts) continue;
    ASSERT_EQ(x.objects.size(), y.objects.size());
    ++compared;
    proposals_differ += x.stats.proposals != y.stats.proposals;
    for (size_t k = 0; k < x.objects.size(); ++k) {
      EXPECT_EQ(x.objects[k].model_key, y.objects[k].model_key);
      EXPECT_EQ(x.objects[k].size_m, y.objects[k].size_m);
      EXPECT_EQ(x.objects[k].rotation, y.objects[k].rotation);
    }
  }
  EXPECT_GE(compared, 8);
  EXPECT_GE(proposals_differ, 4);  // the knob did change the placement
}

TEST(Layout, SampleReportIsTheSameForAnyNumberOfJobs) {
  auto sampler = LayoutSampler::Create(LayoutParams{}, testing::ProceduralLibrary()).value();
  SampleOptions options;
  options.seed = 3;
  options.layouts = 16;
  options.jobs = 1;
  nlohmann::json one = RunSample(*sampler, options).value().ToJson();
  options.jobs = 3;
  nlohmann::json three = RunSample(*sampler, options).value().ToJson();
  for (auto* j : {&one, &three}) {
    for (const char* timing : {"seconds", "sample_ms_per_layout", "mask_ms_per_layout"}) j->erase(timing);
  }
  EXPECT_EQ(one, three);
  EXPECT_EQ(one["layouts"], 16);
}

TEST(Layout, OcclusionPlacementRaisesOcclusion) {
  LayoutParams without = WhiteCubeOnFloor();
  without.occlude_prob = 0;
  without.cluster_prob = 0;
  LayoutParams with = WhiteCubeOnFloor();
  with.occlude_prob = 1;
  with.cluster_prob = 1;
  SampleOptions options;
  options.layouts = 60;
  auto a = RunSample(*LayoutSampler::Create(without, testing::ProceduralLibrary()).value(), options).value();
  auto b = RunSample(*LayoutSampler::Create(with, testing::ProceduralLibrary()).value(), options).value();
  EXPECT_GT(b.metrics.occlusion.mean, a.metrics.occlusion.mean + a.metrics.occlusion.ci95 + b.metrics.occlusion.ci95)
      << a.ToJson().dump() << "\n" << b.ToJson().dump();
}

}  // namespace
}  // namespace solid::render
