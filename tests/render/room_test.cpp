// Room shells: the lattice's floor and ceiling columns (solid-method.md 2.2).
#include "room.h"

#include <gtest/gtest.h>

#include <cmath>

#include "solid/render/assets.h"

namespace solid::render {
namespace {

std::shared_ptr<Device> TestDevice() {
  static std::shared_ptr<Device> device = Device::Create().value();
  return device;
}

// A horizontal rectangle over world x in [x0, x1], y in [y0, y1] at height z, tilted so
// that its far edge (y1) is `rise` higher; `up` faces +z (floors) or -z (ceilings).
gltf::Node Panel(const char* structure, double x0, double x1, double y0, double y1, double z, double rise, bool up) {
  gltf::Primitive p;
  const double corners[4][3] = {{x0, y0, z}, {x1, y0, z}, {x1, y1, z + rise}, {x0, y1, z + rise}};
  for (const auto& c : corners) {
    // world (x, y, z) is glTF (x, z, -y)
    p.positions.insert(p.positions.end(), {float(c[0]), float(c[2]), float(-c[1])});
  }
  p.indices = up ? std::vector<uint32_t>{0, 1, 2, 0, 2, 3} : std::vector<uint32_t>{0, 2, 1, 0, 3, 2};
  return {structure, {p}, {{"structure", structure}}};
}

// A 12 x 12 x 6 m room (so the shell keeps its size) with a floor, a ceiling and three
// pieces marked "floor": a 2 x 2 m shelf at 1 m, a 0.2 x 0.2 m ledge at 1.5 m, and a
// ramp rising 3 m over 1 m (|n_z| = 0.32).
std::shared_ptr<const RoomShell> RoomWithPieces() {
  gltf::Asset room;
  room.nodes.push_back(Panel("floor", -6, 6, -6, 6, 0, 0, true));
  room.nodes.push_back(Panel("ceiling", -6, 6, -6, 6, 6, 0, false));
  room.nodes.push_back(Panel("floor", 2, 4, 2, 4, 1, 0, true));
  room.nodes.push_back(Panel("floor", -3, -2.8, -3, -2.8, 1.5, 0, true));
  room.nodes.push_back(Panel("floor", -4, -2, 2, 3, 0.5, 3, true));
  auto asset = LoadedAsset::Build(TestDevice(), "room", room, false).value();
  LayoutParams params;
  return RoomShell::FromAsset(asset, TestDevice(), params).value();
}

double FloorAt(const RoomShell& room, double x, double y) {
  int i = 0, j = 0;
  EXPECT_TRUE(room.ColumnOf(x, y, &i, &j));
  EXPECT_TRUE(room.Covered(i, j));
  return room.FloorZ(i, j);
}

TEST(RoomShell, ShelvesRaiseTheFloorButSliversAndSlopesDoNot) {
  const auto room = RoomWithPieces();
  EXPECT_NEAR(FloorAt(*room, 3, 3), 1.0, 1e-6) << "a 4 m^2 horizontal piece is floor";
  EXPECT_NEAR(FloorAt(*room, -2.9, -2.9), 0.0, 1e-6) << "a 0.04 m^2 ledge is under 0.1 m^2";
  EXPECT_NEAR(FloorAt(*room, -3, 2.5), 0.0, 1e-6) << "a ramp with |n_z| = 0.32 is not a floor surface";
  EXPECT_NEAR(FloorAt(*room, 0, 0), 0.0, 1e-6);
  int i = 0, j = 0;
  ASSERT_TRUE(room->ColumnOf(0, 0, &i, &j));
  EXPECT_NEAR(room->CeilingZ(i, j), 6.0, 1e-6);
}

TEST(RoomShell, SmallPiecesJoinedByEdgesCountTogether) {
  // Twenty 0.05 x 1 m strips at 2 m, each sharing an edge with the next: each is
  // 0.05 m^2, under the 0.1 m^2 limit, but together they are 1 m^2.
  gltf::Asset room;
  room.nodes.push_back(Panel("floor", -6, 6, -6, 6, 0, 0, true));
  room.nodes.push_back(Panel("ceiling", -6, 6, -6, 6, 6, 0, false));
  gltf::Primitive strips;
  for (int k = 0; k <= 20; ++k) {
    for (double y : {0.0, 1.0}) {
      strips.positions.insert(strips.positions.end(), {float(k * 0.05), 2.0f, float(-y)});
    }
  }
  for (uint32_t k = 0; k < 20; ++k) {
    const uint32_t a = 2 * k, b = 2 * k + 2, c = 2 * k + 3, d = 2 * k + 1;
    strips.indices.insert(strips.indices.end(), {a, b, c, a, c, d});
  }
  room.nodes.push_back({"floor", {strips}, {{"structure", "floor"}}});
  auto asset = LoadedAsset::Build(TestDevice(), "room", room, false).value();
  const auto shell = RoomShell::FromAsset(asset, TestDevice(), LayoutParams{}).value();
  EXPECT_NEAR(FloorAt(*shell, 0.5, 0.5), 2.0, 1e-6);
}

}  // namespace
}  // namespace solid::render
