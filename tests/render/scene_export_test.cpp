// --export-scene: a sampled layout as a glTF scene that viewers open and that holds
// exactly what was sampled (object and camera transforms, meshes, the room).
#include "scene_export.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <set>
#include <nlohmann/json.hpp>

#include "fixtures/gltf_validator.h"
#include "formats/test_util.h"
#include "render/test_assets.h"
#include "room.h"
#include "solid/formats/files.h"
#include "solid/formats/glb.h"
#include "solid/render/params.h"
#include "solid/render/sample.h"
#include "solid/render/shade.h"

namespace solid::render {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

Layout SampledLayout(const std::string& preset, int64_t index) {
  auto sampler = LayoutSampler::Create(LoadPreset(preset).value(), testing::ProceduralLibrary()).value();
  return GenerateLayout(*sampler, 5, index).value().layout;
}

json GlbJson(const std::vector<uint8_t>& glb) {
  uint32_t length = 0;
  std::memcpy(&length, glb.data() + 12, 4);
  return json::parse(glb.begin() + 20, glb.begin() + 20 + length);
}

// Node `matrix` (glTF column-major) against our row-major [R | t].
void ExpectMatrix(const json& m, const Affine3x4& a) {
  ASSERT_EQ(m.size(), 16u);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(m[c * 4 + r].get<double>(), a[r * 4 + c], 1e-12) << r << "," << c;
  }
}

TEST(ExportScene, NodesCarryTheSampledTransformsAndTheCamera) {
  const Layout layout = SampledLayout("more-objects", 3);
  ASSERT_GE(layout.objects.size(), 2u);
  const auto glb = ExportSceneGlb(layout);
  ASSERT_OK(glb.status());
  const json g = GlbJson(*glb);
  // room, the objects, the camera, then the Z-up-to-Y-up root
  ASSERT_EQ(g["nodes"].size(), layout.objects.size() + 3);
  const json& world = g["nodes"].back();
  EXPECT_EQ(world["name"], "world");
  EXPECT_EQ(world["children"].size(), layout.objects.size() + 2);
  EXPECT_EQ(g["scenes"][0]["extras"]["layout_index"], 3);
  // The rig `solid render` lights this layout with, for renderers that reproduce it.
  EXPECT_EQ(g["scenes"][0]["extras"]["lights"], SampleLights(layout).value().ToJson());
  for (size_t k = 0; k < layout.objects.size(); ++k) {
    const json& node = g["nodes"][k + 1];
    EXPECT_EQ(node["extras"]["model_key"], layout.objects[k].model_key);
    EXPECT_EQ(node["extras"]["render_id"], k);
    ExpectMatrix(node["matrix"], layout.objects[k].WorldFromObject());
  }
  const json& camera = g["nodes"][layout.objects.size() + 1];
  EXPECT_EQ(camera["camera"], 0);
  ExpectMatrix(camera["matrix"], layout.camera.world_from_camera);
  EXPECT_NEAR(g["cameras"][0]["perspective"]["aspectRatio"].get<double>(), 640.0 / 480.0, 1e-12);

  // One mesh per model: instances of a repeated model share it.
  std::set<std::string> models;
  for (const PlacedObject& o : layout.objects) models.insert(o.model_key);
  EXPECT_EQ(g["meshes"].size(), models.size() + 1);

  // Our own reader takes it back (a node per mesh use) with every triangle of the room and
  // of each instance.
  const auto asset = gltf::ReadGlb(*glb, "export");
  ASSERT_OK(asset.status());
  ASSERT_EQ(asset->nodes.size(), layout.objects.size() + 1);
  size_t triangles = 0, expected = layout.room->mesh().TriangleCount();
  for (const gltf::Node& node : asset->nodes) {
    for (const gltf::Primitive& p : node.primitives) triangles += p.indices.size() / 3;
  }
  for (const PlacedObject& o : layout.objects) expected += o.asset->mesh().TriangleCount();
  EXPECT_EQ(triangles, expected);
}

TEST(ExportScene, KhronosValidatorReportsNoErrorsForWhiteCubeAndRoomScenes) {
  if (auto why = fixtures::GltfValidatorUnavailable()) GTEST_SKIP() << *why;
  solid::testing::TempDir dir;
  std::vector<fs::path> files;
  for (const char* preset : {"random-placement", "more-objects"}) {
    const auto glb = ExportSceneGlb(SampledLayout(preset, 0));
    ASSERT_OK(glb.status());
    files.push_back(dir.path() / (std::string(preset) + ".glb"));
    ASSERT_OK(files::WriteFileAtomically(files.back(), *glb));
  }
  const fixtures::GltfValidatorRun run = fixtures::RunGltfValidator(files);
  EXPECT_EQ(run.exit_status, 0) << run.report;
  EXPECT_EQ(run.files_reported, files.size()) << run.report;
}

}  // namespace
}  // namespace solid::render
