// Shading: determinism, what a lit scene must show (base colour at an object's
// pixels, shadows), texture sampling, and light sampling rules.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>

#include "render/test_assets.h"
#include "room.h"
#include "shading.h"
#include "solid/render/mask_pass.h"
#include "solid/render/sample.h"
#include "solid/render/shade.h"

namespace solid::render {
namespace {

constexpr int kWidth = 64, kHeight = 48;

std::shared_ptr<Device> TestDevice() {
  static std::shared_ptr<Device> device = Device::Create().value();
  return device;
}

// An axis-aligned box of the given size, world axes, one material of `colour`.
gltf::Asset BoxAsset(double sx, double sy, double sz, std::array<float, 4> colour) {
  gltf::Primitive p;
  for (int i = 0; i < 8; ++i) {
    const double x = (i & 1 ? 0.5 : -0.5) * sx, y = (i & 2 ? 0.5 : -0.5) * sy, z = (i & 4 ? 0.5 : -0.5) * sz;
    p.positions.insert(p.positions.end(), {float(x), float(z), float(-y)});  // world (x, y, z) is glTF (x, z, -y)
  }
  p.indices = {0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3};
  p.material = 0;
  gltf::Asset a;
  gltf::Material m;
  m.base_color = colour;
  a.materials.push_back(m);
  a.nodes.push_back({"box", {p}, nlohmann::json::object()});
  return a;
}

AreaLight Aimed(Vec3 position, Vec3 target, double power, double size) {
  return {position, Normalize(target - position), size, power};
}

// A white-cube layout with one box, seen from `eye`, and a rig whose key light hangs
// at `key` (fill and back off).
struct OneBox {
  Layout layout;
  LightRig lights;
  OneBox(Vec3 box_at, Vec3 box_size, std::array<float, 4> colour, Vec3 eye, Vec3 look, Vec3 key) {
    LayoutParams params;
    params.scene = SceneKind::kWhiteCube;
    layout.room = RoomShell::WhiteCube(TestDevice(), params).value();
    layout.width = kWidth;
    layout.height = kHeight;
    layout.seed = 99;
    EXPECT_TRUE(LookAt(eye, look, 50, kWidth, kHeight, &layout.camera));
    PlacedObject o;
    o.asset = LoadedAsset::Build(TestDevice(), "box", BoxAsset(box_size.x, box_size.y, box_size.z, colour), true).value();
    o.model_key = "test/box";
    o.scale = 1;
    o.size_m = o.asset->largest_extent();
    o.position = box_at;
    o.box = Obb{box_at, Mat3{}, o.asset->half_extents()};
    layout.objects.push_back(o);
    lights.key = Aimed(key, box_at, 300, 0.05);
    lights.fill = Aimed({0, -4, 1}, box_at, 0, 0.25);
    lights.back = Aimed({0, 4, 6}, box_at, 0, 0.25);
    lights.ceiling_strength = 0;
  }
};

double Luma(const Image8& image, int x, int y) {
  const uint8_t* p = &image.pixels[3 * (static_cast<size_t>(y) * image.width + x)];
  return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
}

TEST(Shade, SameBytesForAnyThreadCountAndRerun) {
  const testing::SmallLayout drawn = testing::DrawSmallLayout("random-placement", 3);
  const GeneratedLayout& g = drawn.g;
  const LightRig lights = SampleLights(g.layout).value();
  EXPECT_EQ(lights.ToJson(), SampleLights(g.layout).value().ToJson());
  TextureCache textures;
  const ShadeResult one = Shade(g.layout, lights, ShadeOptions{4, 1}, textures, &g.masks).value();
  const ShadeResult two = Shade(g.layout, lights, ShadeOptions{4, 2}, textures, &g.masks).value();
  const ShadeResult again = Shade(g.layout, lights, ShadeOptions{4, 3}, textures, &g.masks).value();
  ASSERT_EQ(one.image.width, 96u);
  ASSERT_EQ(one.image.height, 72u);
  ASSERT_EQ(one.image.channels, 3u);
  EXPECT_EQ(one.image.pixels, two.image.pixels);
  EXPECT_EQ(one.image.pixels, again.image.pixels);
  EXPECT_GT(textures.bytes(), 0u);  // the procedural models are textured
  // Shaded, not flat: many distinct colours.
  std::set<uint32_t> colours;
  for (size_t i = 0; i < one.image.pixels.size(); i += 3) {
    colours.insert(one.image.pixels[i] << 16 | one.image.pixels[i + 1] << 8 | one.image.pixels[i + 2]);
  }
  EXPECT_GT(colours.size(), 500u);
}

TEST(Shade, RedObjectIsRedAtItsMaskPixels) {
  OneBox scene({0, 0, 1}, {1, 1, 1}, {0.8f, 0.05f, 0.05f, 1}, {0, -5, 1.5}, {0, 0, 1}, {-1.5, -3, 3});
  const MaskPassResult masks = RunMaskPass(scene.layout, 1).value();
  TextureCache textures;
  const Image8 image = Shade(scene.layout, scene.lights, ShadeOptions{4, 1}, textures, &masks).value().image;
  int checked = 0;
  for (int y = 1; y + 1 < kHeight; ++y) {
    for (int x = 1; x + 1 < kWidth; ++x) {
      // Interior pixels only: anti-aliased edges blend in the background.
      bool inside = true;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) inside = inside && masks.ids[(y + dy) * kWidth + x + dx] == 1;
      }
      if (!inside) continue;
      const uint8_t* p = &image.pixels[3 * (y * kWidth + x)];
      EXPECT_GT(p[0], p[1] + 20) << x << "," << y;
      EXPECT_GT(p[0], p[2] + 20) << x << "," << y;
      ++checked;
    }
  }
  EXPECT_GT(checked, 50);
  // The room around it is grey: equal channels.
  const uint8_t* corner = &image.pixels[3 * (2 * kWidth + 2)];
  EXPECT_EQ(masks.ids[2 * kWidth + 2], 0u);
  EXPECT_EQ(corner[0], corner[1]);
  EXPECT_EQ(corner[1], corner[2]);
}

TEST(Shade, FloorUnderALitBoxIsInItsShadow) {
  // Key light straight above a floating box; the floor below it is in shadow.
  OneBox scene({0, 0, 0.8}, {0.6, 0.6, 0.2}, {0.8f, 0.8f, 0.8f, 1}, {0, -5, 2}, {0, 0, 0}, {0, 0, 4});
  const MaskPassResult masks = RunMaskPass(scene.layout, 1).value();
  TextureCache textures;
  const Image8 image = Shade(scene.layout, scene.lights, ShadeOptions{4, 1}, textures, &masks).value().image;
  double u = 0, v = 0, lu = 0, lv = 0;
  ASSERT_TRUE(Project(scene.layout.camera, {0, 0, 0}, 0.1, &u, &v));
  ASSERT_TRUE(Project(scene.layout.camera, {1.5, 0, 0}, 0.1, &lu, &lv));
  const double shadow = Luma(image, int(u), int(v)), lit = Luma(image, int(lu), int(lv));
  EXPECT_GT(lit, 2 * shadow) << "lit " << lit << " shadow " << shadow;
  // The box's top faces the key light: brighter than the floor in its shadow.
  double tu = 0, tv = 0;
  ASSERT_TRUE(Project(scene.layout.camera, {0, 0, 0.9}, 0.1, &tu, &tv));
  EXPECT_GT(Luma(image, int(tu), int(tv)), 2 * shadow);
}

TEST(Shade, RejectsBadOptions) {
  OneBox scene({0, 0, 1}, {1, 1, 1}, {1, 1, 1, 1}, {0, -5, 1.5}, {0, 0, 1}, {0, -3, 3});
  TextureCache textures;
  EXPECT_EQ(Shade(scene.layout, scene.lights, ShadeOptions{0, 1}, textures).status().code(),
            StatusCode::kInvalidArgument);
  scene.lights.target = 1;
  EXPECT_EQ(Shade(scene.layout, scene.lights, ShadeOptions{1, 1}, textures).status().code(),
            StatusCode::kInvalidArgument);
}

TEST(Shade, CheckerTextureRepeatsWithBilinearFilter) {
  // 2 x 2 checker: black at (0, 0) and (1, 1), white elsewhere.
  Image8 checker{2, 2, 3, {0, 0, 0, 255, 255, 255, 255, 255, 255, 0, 0, 0}};
  std::vector<gltf::Texture> textures = {{"checker.png", "image/png", EncodeImage(checker, ImageFormat::kPng).value()}};
  const DecodedTextures decoded = DecodeTextures(textures, "test").value();
  gltf::Material m;
  m.base_color = {0.5f, 1, 1, 1};
  m.base_color_texture = 0;
  auto at = [&](float u, float v) { return BaseColor(&m, &decoded, u, v); };
  // Texel centres are exact; repeat wrap in both directions.
  for (float shift : {0.0f, 1.0f, -1.0f, 7.0f}) {
    EXPECT_FLOAT_EQ(at(0.25f + shift, 0.25f).y, 0.0f);
    EXPECT_FLOAT_EQ(at(0.75f + shift, 0.25f).y, 1.0f);
    EXPECT_FLOAT_EQ(at(0.25f, 0.75f + shift).y, 1.0f);
    EXPECT_FLOAT_EQ(at(0.75f, 0.75f + shift).y, 0.0f);
  }
  EXPECT_FLOAT_EQ(at(0.75f, 0.25f).x, 0.5f);  // times the base colour factor
  // Halfway between texels: the mean of their linear values, across the wrap too.
  EXPECT_NEAR(at(0.5f, 0.25f).y, 0.5f, 1e-6);
  EXPECT_NEAR(at(0.0f, 0.25f).y, 0.5f, 1e-6);
  EXPECT_NEAR(at(0.0f, 0.0f).y, 0.5f, 1e-6);
  // sRGB decode: 128 is linear 0.2158.
  EXPECT_NEAR(SrgbToLinear(128), 0.21586f, 1e-4);
  EXPECT_EQ(decoded.textures[0].mean_linear.y, 0.5f);
}

TEST(Shade, FilmEncodingIsTheToneCurveThenSrgb) {
  // EncodeFilm searches precomputed code thresholds; over a dense sweep that reaches
  // every code (and each value's float neighbours), it must give exactly the curve's codes.
  Film film;
  for (int i = 0; i <= 200000; ++i) {
    const float v = std::ldexp(static_cast<float>(i) / 200000, 4) - 0.5f;  // [-0.5, 15.5], through 0 and the knee
    film.rgb.insert(film.rgb.end(), {v, std::nextafter(v, 1e9f), std::nextafter(v, -1e9f)});
  }
  film.width = static_cast<int>(film.rgb.size() / 3);
  film.height = 1;
  const Image8 image = EncodeFilm(film);
  for (size_t i = 0; i < film.rgb.size(); ++i) {
    ASSERT_EQ(image.pixels[i], LinearToSrgb8(ToneMap(film.rgb[i]))) << film.rgb[i];
  }
}

TEST(Shade, LightsFollowTheRules) {
  auto sampler = LayoutSampler::Create(LoadPreset("occlusion").value(), testing::ProceduralLibrary()).value();
  for (int i = 0; i < 4; ++i) {
    const Layout layout = GenerateLayout(*sampler, 8, i).value().layout;
    const LightRig rig = SampleLights(layout).value();
    ASSERT_LT(rig.target, layout.objects.size());
    const Vec3 eye = CameraPosition(layout.camera);
    const double ring = std::hypot(eye.x, eye.y);
    for (const AreaLight* l : {&rig.key, &rig.fill, &rig.back}) {
      const double r = std::hypot(l->position.x, l->position.y);
      EXPECT_GE(r, 0.8 * ring - 1e-9);
      EXPECT_LE(r, ring + 1e-9);
      const Vec3 to_target = Normalize(layout.objects[rig.target].position - l->position);
      EXPECT_NEAR(Dot(to_target, l->direction), 1.0, 1e-9);
    }
    EXPECT_GE(rig.key.power_w, 150);
    EXPECT_LE(rig.key.power_w, 300);
    EXPECT_GE(rig.fill.power_w, 10);
    EXPECT_LE(rig.fill.power_w, 30);
    EXPECT_GE(rig.back.power_w, 20);
    EXPECT_LE(rig.back.power_w, 60);
    auto azimuth = [](Vec3 p) { return std::atan2(p.y, p.x); };
    const double pi = std::numbers::pi;
    EXPECT_LE(std::fabs(std::remainder(azimuth(rig.fill.position) - azimuth(rig.key.position), 2 * pi)),
              pi / 3 + 1e-9);
    EXPECT_GE(std::fabs(std::remainder(azimuth(rig.back.position) - azimuth(eye), 2 * pi)), 5 * pi / 6 - 1e-9);
  }
}

}  // namespace
}  // namespace solid::render
