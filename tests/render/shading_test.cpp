// RenderFilm's lights (render/shading.cpp), on one procedural model as query views see it.
#include "shading.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include "instance_scene.h"
#include "render/test_assets.h"

namespace solid::render {
namespace {

// A point light at the eye lights whatever the camera sees, so marking it at_eye drops its
// shadow rays (about one per covered sample: the ones facing it) and changes the image only
// where a traced shadow ray wrongly hit the surface it left (acne along silhouettes).
TEST(Shading, ALightAtTheEyeTracesNoShadowRaysAndLightsTheSame) {
  const auto model = testing::ProceduralLibrary()->Model(5).value();
  TextureCache textures;
  const auto tex = textures.Get(model->textures(), model, model->key()).value();
  const RTCScene bottom = reinterpret_cast<RTCScene>(model->scene());
  const SceneInstance instance{bottom, kIdentityAffine};
  RTCDevice device = rtcGetSceneDevice(bottom);
  {
    const ObjectScene top(device, {&instance, 1});
    ShadingScene scene;
    scene.scene = top.get();
    scene.surfaces.push_back({&model->mesh(), &model->materials(), tex.get(), Mat3{}, 1.0, Vec3{}});
    scene.ambient = scene.background = {0.05f, 0.05f, 0.05f};
    scene.ambient_occlusion_m = static_cast<float>(2 * Length(model->half_extents()));
    const Vec3 eye{0, -2.2 * Length(model->half_extents()), 0};
    Camera camera;
    ASSERT_TRUE(LookAt(eye, {0, 0, 0}, 40, 64, 48, &camera));
    ShadingLight light;
    light.area = false;
    light.position = ToFloat(eye);
    light.power_w = 200;
    scene.lights.push_back(light);
    const Film traced = RenderFilm(scene, camera, 64, 48, 1e-3, FilmSampling{4, {}}, 1, 9);
    scene.lights[0].at_eye = true;
    const Film lit = RenderFilm(scene, camera, 64, 48, 1e-3, FilmSampling{4, {}}, 1, 9);

    size_t covered = 0;
    for (const uint8_t c : lit.covered) covered += c;
    EXPECT_EQ(lit.covered, traced.covered);
    ASSERT_GT(covered, lit.covered.size() / 4);
    // A shadow ray per sample that hit the model and faces the light: at most four per
    // covered pixel; fewer on silhouette pixels (some samples miss) and grazing faces. This
    // view: 83%.
    const uint64_t dropped = traced.rays - lit.rays;
    EXPECT_LE(dropped, 4 * covered);
    EXPECT_GE(dropped, 4 * covered * 3 / 4);
    // The same light: at_eye never darkens a value, and brightens under 2% of them.
    size_t brighter = 0;
    for (size_t i = 0; i < lit.rgb.size(); ++i) {
      EXPECT_GE(lit.rgb[i], traced.rgb[i] - 1e-6f) << i;
      brighter += lit.rgb[i] > traced.rgb[i] + 1e-6f;
    }
    EXPECT_LT(brighter, lit.rgb.size() / 50);
  }
  rtcReleaseDevice(device);
}

}  // namespace
}  // namespace solid::render
