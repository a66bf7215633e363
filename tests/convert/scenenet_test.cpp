#include "scenenet.h"

#include <gtest/gtest.h>

#include <string>
#include <tuple>

namespace solid::convert {
namespace {

// The expected-label table of docs "input-formats" section 3.4, row for row.
TEST(SceneNetLabels, MatchTheReferenceTable) {
  const std::tuple<std::string, int, Structure> kTable[] = {
      {"wall.034", 1, Structure::kWall},          {"Walls.132", 1, Structure::kWall},
      {"Wall.242333", 1, Structure::kWall},       {"room_skeleton", 1, Structure::kWall},
      {"walls1_line01_12", 1, Structure::kWall},  {"wall_frame.001", 38, Structure::kNone},
      {"floor_enclose_1", 38, Structure::kFloor}, {"Floor1", 2, Structure::kFloor},
      {"floor.004", 2, Structure::kFloor},        {"floor_enclose", 2, Structure::kFloor},
      {"ground", 2, Structure::kFloor},           {"floor-mat", 20, Structure::kFloor},
      {"ceiling_enclose", 38, Structure::kCeiling}, {"Ceiling.1231", 22, Structure::kCeiling},
      {"ceiling", 22, Structure::kCeiling},       {"ceilingwall", 22, Structure::kCeiling},
      {"window.003", 9, Structure::kNone},        {"window_frame.012", 38, Structure::kNone},
      {"bed", 4, Structure::kNone},               {"light.001", 38, Structure::kNone},
      {"Table_3", 38, Structure::kNone},          {"chair_fx_4", 38, Structure::kNone},
      {"nightstand", 32, Structure::kNone},       {"painting.014", 11, Structure::kNone},
      {"books.001", 23, Structure::kNone},        {"Other-prop", 38, Structure::kNone},
      {"decoration.008_sphere.008", 38, Structure::kNone},
  };
  for (const auto& [name, category, structure] : kTable) {
    EXPECT_EQ(SceneNetCategory(name), category) << name;
    EXPECT_EQ(SceneNetStructure(name), structure) << name;
  }
}

TEST(SceneNetLabels, EmptyAndOddNamesAreOtherStructure) {
  EXPECT_EQ(SceneNetCategory(""), 38);
  EXPECT_EQ(SceneNetCategory("."), 38);
  EXPECT_EQ(SceneNetCategory("x"), 38);
  EXPECT_EQ(SceneNetStructure("Kitchen_Floor_Tiles"), Structure::kFloor);
}

// Docs 3.3: cut at the first '.', delete '_' and digits, keep case. The quirks: "Walls.132"
// and "metal_plastic.001" name folders the library does not have.
TEST(SceneNetTextureFolder, FollowsTheReferenceLoaderRule) {
  EXPECT_EQ(SceneNetTextureFolder("wall.034"), "wall");
  EXPECT_EQ(SceneNetTextureFolder("Walls.132"), "Walls");
  EXPECT_EQ(SceneNetTextureFolder("metal_plastic.001"), "metalplastic");
  EXPECT_EQ(SceneNetTextureFolder("chair_fx_mat.001"), "chairfxmat");
  EXPECT_EQ(SceneNetTextureFolder("decoration.008_sphere.008"), "decoration");
  EXPECT_EQ(SceneNetTextureFolder("walls1_line01_12"), "wallsline");
  EXPECT_EQ(SceneNetTextureFolder("wood"), "wood");
  EXPECT_EQ(SceneNetTextureFolder(".001"), "");
  EXPECT_EQ(SceneNetTextureFolder(""), "");
}

}  // namespace
}  // namespace solid::convert
