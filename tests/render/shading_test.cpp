// RenderFilm's lights (render/shading.cpp), on one procedural model as query views see it.
#include "shading.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include "instance_scene.h"
#include "render/test_assets.h"
#include "solid/formats/image_codec.h"

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

// A flat pixel's base colour (FilmSampling) on a camera-facing textured square lit only by
// a unit ambient, so that the film holds the base colour itself: the bilinear texture value
// at the pixel centre's uv when the footprint is under half a texel (one lookup), and the
// mean of the four taps at the footprint's quarter points when it is larger. Both are
// computed here from the camera's intrinsics, in double.
class FlatFootprint : public ::testing::Test {
 protected:
  static constexpr int kWidth = 64, kHeight = 48, kTexels = 4;
  static constexpr double kSide = 2, kDistance = 2;

  // The texture, sRGB 8-bit, linear values read back through SrgbToLinear.
  static Image8 Texture() {
    Image8 image{kTexels, kTexels, 3, {}};
    for (int i = 0; i < kTexels * kTexels * 3; ++i) image.pixels.push_back(static_cast<uint8_t>(37 + 71 * i % 219));
    return image;
  }
  static double Linear(const Image8& t, int x, int y, int c) {
    x = ((x % kTexels) + kTexels) % kTexels;
    y = ((y % kTexels) + kTexels) % kTexels;
    return SrgbToLinear(t.pixels[3 * (y * kTexels + x) + c]);
  }
  static double Bilinear(const Image8& t, double u, double v, int c) {
    const double x = u * kTexels - 0.5, y = v * kTexels - 0.5;
    const double x0 = std::floor(x), y0 = std::floor(y), ax = x - x0, ay = y - y0;
    const int ix = static_cast<int>(x0), iy = static_cast<int>(y0);
    return (Linear(t, ix, iy, c) * (1 - ax) + Linear(t, ix + 1, iy, c) * ax) * (1 - ay) +
           (Linear(t, ix, iy + 1, c) * (1 - ax) + Linear(t, ix + 1, iy + 1, c) * ax) * ay;
  }

  // Renders the square with its uvs spanning `repeats` copies of the texture, adaptive,
  // every pixel flat, and checks each pixel against the expected base colour.
  void Check(double repeats) {
    gltf::Primitive p;
    for (int i = 0; i < 4; ++i) {
      const float x = (i & 1 ? 0.5f : -0.5f), y = (i & 2 ? 0.5f : -0.5f);
      p.positions.insert(p.positions.end(), {x * static_cast<float>(kSide), y * static_cast<float>(kSide), 0.0f});
      // glTF's uv (0, 0) is the image's top-left corner; the square's top is glTF +y.
      p.uvs.insert(p.uvs.end(), {(x + 0.5f) * static_cast<float>(repeats), (0.5f - y) * static_cast<float>(repeats)});
    }
    p.indices = {0, 1, 3, 0, 3, 2};
    p.material = 0;
    gltf::Asset asset;
    asset.nodes.push_back({"square", {p}, nlohmann::json::object()});
    gltf::Material material;
    material.base_color_texture = 0;
    asset.materials.push_back(material);
    const Image8 texture = Texture();
    asset.textures.push_back({"t.png", "image/png", EncodeImage(texture, ImageFormat::kPng).value()});
    const auto device = Device::Create().value();
    const auto square = LoadedAsset::Build(device, "square", asset, true).value();
    const DecodedTextures decoded = DecodeTextures(asset.textures, "square").value();
    const SceneInstance instance{reinterpret_cast<RTCScene>(square->scene()), kIdentityAffine};
    const ObjectScene top(device->handle(), {&instance, 1});
    ShadingScene scene;
    scene.scene = top.get();
    scene.surfaces.push_back({&square->mesh(), &square->materials(), &decoded, Mat3{}, 1.0, Vec3{}});
    scene.ambient = {1, 1, 1};
    scene.ambient_occlusion_m = 1;
    // glTF's square in its z = 0 plane is the world's y = 0 plane, glTF +y up world +z.
    Camera camera;
    ASSERT_TRUE(LookAt({0, -kDistance, 0}, {0, 0, 0}, 40, kWidth, kHeight, &camera));
    FilmSampling sampling{4, std::vector<uint8_t>(kWidth * kHeight, 0), nullptr};
    const Film film = RenderFilm(scene, camera, kWidth, kHeight, 1e-3, sampling, 2, 3);

    // Texture coordinates per pixel along x and y; the footprint's taps lie a quarter
    // pixel from its centre.
    const double du = kDistance / (camera.fx * kSide) * repeats, dv = kDistance / (camera.fy * kSide) * repeats;
    const bool one_lookup = du * kTexels / 4 < 0.25 && dv * kTexels / 4 < 0.25;
    int checked = 0;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const double wx = (x + 0.5 - camera.cx) / camera.fx * kDistance;
        const double wz = -(y + 0.5 - camera.cy) / camera.fy * kDistance;
        if (std::fabs(wx) > kSide / 2 - 0.05 || std::fabs(wz) > kSide / 2 - 0.05) continue;
        const double u = (wx / kSide + 0.5) * repeats, v = (0.5 - wz / kSide) * repeats;
        const size_t pixel = static_cast<size_t>(y) * kWidth + x;
        ASSERT_EQ(film.covered[pixel], 1) << x << "," << y;
        for (int c = 0; c < 3; ++c) {
          double expected = 0;
          if (one_lookup) {
            expected = Bilinear(texture, u, v, c);
          } else {
            for (const double sx : {-0.25, 0.25}) {
              for (const double sy : {-0.25, 0.25}) expected += Bilinear(texture, u + sx * du, v + sy * dv, c) / 4;
            }
          }
          EXPECT_NEAR(film.rgb[3 * pixel + c], expected, 2e-3) << x << "," << y << " channel " << c;
        }
        ++checked;
      }
    }
    EXPECT_GT(checked, kWidth * kHeight / 2);
  }
};

// 22 pixels per texel: a footprint of 1/22 texel, one lookup at the centre.
TEST_F(FlatFootprint, UnderHalfATexelIsTheBilinearValueAtTheCentre) { Check(1); }

// About 3 texels per pixel: four taps at the footprint's quarter points.
TEST_F(FlatFootprint, OverHalfATexelIsTheMeanOfFourTaps) { Check(64); }

}  // namespace
}  // namespace solid::render
