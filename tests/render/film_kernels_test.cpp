// The shader's kernel sets (render/film_kernels.h): every set this CPU runs shades a layout
// to the bytes of the baseline's, with the same rays, under adaptive and uniform sampling.
#include "film_kernels.h"

#include <gtest/gtest.h>

#include "render/test_assets.h"

namespace solid::render {
namespace {

TEST(FilmKernels, EverySetTheCpuRunsGivesTheBaselinesBytes) {
  const std::vector<const FilmKernels*> sets = RunnableFilmKernels();
  ASSERT_FALSE(sets.empty());
  EXPECT_EQ(&BestFilmKernels(), sets.back());
  EXPECT_TRUE(sets.front()->instruction_set == "x86-64" || sets.front()->instruction_set == "generic")
      << sets.front()->instruction_set;
  if (sets.size() == 1) GTEST_SKIP() << "this CPU runs only the baseline set";
  const testing::SmallLayout drawn = testing::DrawSmallLayout("more-objects", 5);
  TextureCache textures;
  struct Setting {
    Sampling sampling;
    int spp;
    int threads;
  };
  for (const Setting setting : {Setting{Sampling::kAdaptive, 4, 2}, Setting{Sampling::kUniform, 2, 1}}) {
    ShadeOptions options;
    options.sampling = setting.sampling;
    options.samples_per_pixel = setting.spp;
    options.threads = setting.threads;
    const MaskPassResult* masks = setting.sampling == Sampling::kAdaptive ? &drawn.g.masks : nullptr;
    const ShadeResult baseline =
        ShadeWith(drawn.g.layout, drawn.g.lights, options, textures, masks, *sets.front()).value();
    for (size_t k = 1; k < sets.size(); ++k) {
      const ShadeResult wide = ShadeWith(drawn.g.layout, drawn.g.lights, options, textures, masks, *sets[k]).value();
      EXPECT_EQ(wide.rays, baseline.rays) << sets[k]->instruction_set;
      EXPECT_TRUE(wide.image.pixels == baseline.image.pixels) << sets[k]->instruction_set;
    }
  }
}

}  // namespace
}  // namespace solid::render
