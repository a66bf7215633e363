// Query views: count, size, azimuths, tight crops, background, determinism.
#include <gtest/gtest.h>

#include <cstdlib>

#include "render/test_assets.h"
#include "solid/render/query_views.h"

namespace solid::render {
namespace {

constexpr uint8_t kBackground = 59;  // linear grey 0.05, tone mapped, sRGB

bool IsBackground(const Image8& image, uint32_t x, uint32_t y, int tolerance) {
  const uint8_t* p = &image.pixels[3 * (static_cast<size_t>(y) * image.width + x)];
  for (int c = 0; c < 3; ++c) {
    if (std::abs(p[c] - kBackground) > tolerance) return false;
  }
  return true;
}

QueryViewOptions Small(int threads) {
  QueryViewOptions o;
  o.render_size = 96;
  o.samples_per_pixel = 4;
  o.threads = threads;
  return o;
}

TEST(QueryViews, EightTightViewsWithLongSide224) {
  auto library = testing::ProceduralLibrary();
  TextureCache textures;
  const auto model = library->Model(0).value();
  const QueryViewsResult r = RenderQueryViews(model, 42, Small(1), textures).value();
  ASSERT_EQ(r.views.size(), 8u);
  EXPECT_TRUE(r.failed.empty());
  EXPECT_EQ(r.euler_xyz_deg[0], -30.0);
  for (size_t v = 0; v < r.views.size(); ++v) {
    const QueryView& view = r.views[v];
    SCOPED_TRACE(v);
    EXPECT_EQ(view.azimuth_deg, 45.0 * v);
    EXPECT_EQ(view.elevation_deg, 0.0);
    EXPECT_EQ(view.image.channels, 3u);
    EXPECT_EQ(std::max(view.image.width, view.image.height), 224u);
    // The aspect ratio is the crop's, to within a pixel of rounding.
    const double crop_aspect = double(view.crop_x1 - view.crop_x0) / (view.crop_y1 - view.crop_y0);
    EXPECT_NEAR(double(view.image.width) / view.image.height, crop_aspect, 2.0 * crop_aspect / 224 + 1e-9);
    EXPECT_GE(view.crop_x0, 0);
    EXPECT_LE(view.crop_x1, 96);
    EXPECT_GE(view.crop_y0, 0);
    EXPECT_LE(view.crop_y1, 96);
    // Tight: the object reaches every side, within 2 output pixels (a thin extreme part
    // may fall between the samples of the border pixels).
    const Image8& im = view.image;
    auto side_has_object = [&](bool vertical, bool far) {
      for (uint32_t d = 0; d < 2; ++d) {
        const uint32_t n = vertical ? im.height : im.width;
        for (uint32_t i = 0; i < n; ++i) {
          const uint32_t x = vertical ? (far ? im.width - 1 - d : d) : i;
          const uint32_t y = vertical ? i : (far ? im.height - 1 - d : d);
          if (!IsBackground(im, x, y, 4)) return true;
        }
      }
      return false;
    };
    EXPECT_TRUE(side_has_object(true, false));
    EXPECT_TRUE(side_has_object(true, true));
    EXPECT_TRUE(side_has_object(false, false));
    EXPECT_TRUE(side_has_object(false, true));
  }
}

TEST(QueryViews, BackgroundIsTheWorldGrey) {
  auto library = testing::ProceduralLibrary();
  TextureCache textures;
  // Every model: corners of the crop that the object does not reach are the world grey exactly.
  int exact_corners = 0;
  for (size_t m = 0; m < 4; ++m) {
    const QueryViewsResult r = RenderQueryViews(library->Model(m).value(), m, Small(2), textures).value();
    for (const QueryView& view : r.views) {
      const Image8& im = view.image;
      for (uint32_t y : {0u, im.height - 1}) {
        for (uint32_t x : {0u, im.width - 1}) exact_corners += IsBackground(im, x, y, 0);
      }
    }
  }
  EXPECT_GT(exact_corners, 32);  // of 128 corners; a convex silhouette leaves most of them empty
}

TEST(QueryViews, SameBytesForAnyThreadCount) {
  auto library = testing::ProceduralLibrary();
  TextureCache textures;
  const auto model = library->Model(3).value();
  const QueryViewsResult a = RenderQueryViews(model, 7, Small(1), textures).value();
  const QueryViewsResult b = RenderQueryViews(model, 7, Small(2), textures).value();
  ASSERT_EQ(a.views.size(), b.views.size());
  for (size_t v = 0; v < a.views.size(); ++v) EXPECT_EQ(a.views[v].image.pixels, b.views[v].image.pixels);
  const QueryViewsResult other = RenderQueryViews(model, 8, Small(1), textures).value();
  EXPECT_NE(a.euler_xyz_deg, other.euler_xyz_deg);
}

TEST(QueryViews, RejectsBadOptions) {
  TextureCache textures;
  QueryViewOptions o;
  o.views = 0;
  EXPECT_EQ(RenderQueryViews(testing::ProceduralLibrary()->Model(0).value(), 1, o, textures).status().code(),
            StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace solid::render
