#include "solid/convert/procedural.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "formats/test_util.h"
#include "solid/formats/image_codec.h"

namespace solid::convert {
// The asset model and its glb codec live in formats (render reads them too).
using namespace solid::gltf;
namespace {

constexpr uint64_t kSeed = 0x5eed0001;
constexpr int kShapesPerFamily = 5;

using Vec = std::array<double, 3>;

Vec Sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec Cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double Dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double Norm(const Vec& a) { return std::sqrt(Dot(a, a)); }

Vec Position(const Primitive& p, uint32_t v) {
  return {p.positions[3 * v], p.positions[3 * v + 1], p.positions[3 * v + 2]};
}
Vec Normal(const Primitive& p, uint32_t v) { return {p.normals[3 * v], p.normals[3 * v + 1], p.normals[3 * v + 2]}; }

// The triangles of some nodes, with vertices welded by exact float position (the
// generators duplicate seam and pole vertices at bit-identical positions).
struct WeldedMesh {
  std::vector<Vec> positions;
  std::vector<std::array<uint32_t, 3>> triangles;
};

WeldedMesh Weld(const std::vector<const Node*>& nodes) {
  WeldedMesh mesh;
  std::map<std::array<float, 3>, uint32_t> ids;
  for (const Node* node : nodes) {
    for (const Primitive& p : node->primitives) {
      std::vector<uint32_t> remap;
      for (size_t v = 0; v < p.positions.size() / 3; ++v) {
        const std::array<float, 3> key = {p.positions[3 * v], p.positions[3 * v + 1], p.positions[3 * v + 2]};
        const auto [it, fresh] = ids.try_emplace(key, static_cast<uint32_t>(mesh.positions.size()));
        if (fresh) mesh.positions.push_back({key[0], key[1], key[2]});
        remap.push_back(it->second);
      }
      for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
        mesh.triangles.push_back({remap[p.indices[t]], remap[p.indices[t + 1]], remap[p.indices[t + 2]]});
      }
    }
  }
  return mesh;
}

// Closed and consistently wound: every directed edge occurs exactly once and its
// reverse occurs too, so every edge has exactly two triangles, traversed oppositely.
std::string ClosednessProblem(const WeldedMesh& mesh) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) ++directed[{t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)]}];
  }
  for (const auto& [edge, count] : directed) {
    if (count != 1) return "directed edge used " + std::to_string(count) + " times";
    if (!directed.contains({edge.second, edge.first})) return "boundary edge (no reverse)";
  }
  return "";
}

// Divergence theorem: sum of centroid . normal * area over a closed mesh is 3 * volume,
// positive when the winding faces outwards. This holds for any closed shape, star-shaped
// or not, which is why it is the orientation test here.
double SignedVolume(const WeldedMesh& mesh) {
  double six_volume = 0;
  for (const auto& t : mesh.triangles) {
    six_volume += Dot(mesh.positions[t[0]], Cross(mesh.positions[t[1]], mesh.positions[t[2]]));
  }
  return six_volume / 6;
}

void ExpectValidPngTextures(const Asset& asset, int size) {
  for (const Material& m : asset.materials) {
    ASSERT_TRUE(m.base_color_texture.has_value()) << m.name;
    ASSERT_LT(*m.base_color_texture, asset.textures.size());
    EXPECT_EQ(m.base_color, (std::array<float, 4>{1, 1, 1, 1})) << "textured materials keep a white factor";
    EXPECT_GE(m.roughness, 0.3f);
    EXPECT_LE(m.roughness, 1.0f);
  }
  for (const Texture& t : asset.textures) {
    EXPECT_EQ(t.mime_type, "image/png");
    auto image = DecodeImage(t.bytes, ImageFormat::kPng);
    ASSERT_OK(image.status());
    EXPECT_EQ(image->width, static_cast<uint32_t>(size));
    EXPECT_EQ(image->height, static_cast<uint32_t>(size));
  }
}

void ExpectWellFormedPrimitives(const Asset& asset) {
  for (const Node& node : asset.nodes) {
    for (const Primitive& p : node.primitives) {
      const size_t vertices = p.positions.size() / 3;
      ASSERT_EQ(p.positions.size() % 3, 0u);
      ASSERT_EQ(p.normals.size(), p.positions.size());
      ASSERT_EQ(p.uvs.size(), 2 * vertices);
      ASSERT_EQ(p.indices.size() % 3, 0u);
      ASSERT_TRUE(p.material.has_value());
      EXPECT_LT(*p.material, asset.materials.size());
      for (uint32_t i : p.indices) ASSERT_LT(i, vertices);
      for (float x : p.positions) ASSERT_TRUE(std::isfinite(x));
      for (float x : p.uvs) ASSERT_TRUE(std::isfinite(x));
      for (uint32_t v = 0; v < vertices; ++v) ASSERT_NEAR(Norm(Normal(p, v)), 1.0, 1e-5) << node.name << " vertex " << v;
    }
  }
}

bool BitIdentical(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

void ExpectIdentical(const Asset& a, const Asset& b) {
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  for (size_t n = 0; n < a.nodes.size(); ++n) {
    EXPECT_EQ(a.nodes[n].name, b.nodes[n].name);
    ASSERT_EQ(a.nodes[n].primitives.size(), b.nodes[n].primitives.size());
    for (size_t k = 0; k < a.nodes[n].primitives.size(); ++k) {
      const Primitive &pa = a.nodes[n].primitives[k], &pb = b.nodes[n].primitives[k];
      EXPECT_TRUE(BitIdentical(pa.positions, pb.positions));
      EXPECT_TRUE(BitIdentical(pa.normals, pb.normals));
      EXPECT_TRUE(BitIdentical(pa.uvs, pb.uvs));
      EXPECT_EQ(pa.indices, pb.indices);
      EXPECT_EQ(pa.material, pb.material);
    }
  }
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (size_t m = 0; m < a.materials.size(); ++m) {
    EXPECT_EQ(a.materials[m].name, b.materials[m].name);
    EXPECT_EQ(std::memcmp(&a.materials[m].roughness, &b.materials[m].roughness, sizeof(float)), 0);
  }
  ASSERT_EQ(a.textures.size(), b.textures.size());
  for (size_t t = 0; t < a.textures.size(); ++t) EXPECT_EQ(a.textures[t].bytes, b.textures[t].bytes);
  EXPECT_EQ(a.extras, b.extras);
}

TEST(ProceduralShape, EveryFamilyMeetsTheGeometricContract) {
  const ProceduralShapeOptions options;
  std::map<std::string, std::vector<double>> triangles_by_family, ms_by_family;
  for (int index = 0; index < kShapesPerFamily * kShapeFamilyCount; ++index) {
    const auto family = static_cast<ShapeFamily>(index % kShapeFamilyCount);
    SCOPED_TRACE("repro: MakeProceduralShape(" + std::to_string(kSeed) + ", " + std::to_string(index) + ") " +
                 std::string(ShapeFamilyName(family)));
    const auto start = std::chrono::steady_clock::now();
    auto asset = MakeProceduralShape(kSeed, index, "procedural/shape-" + std::to_string(index), options);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    ASSERT_OK(asset.status());

    ASSERT_EQ(asset->nodes.size(), 1u);
    EXPECT_EQ(asset->nodes[0].name, "procedural/shape-" + std::to_string(index));
    const uint64_t triangles = TriangleCount(*asset);
    EXPECT_GE(triangles, static_cast<uint64_t>(options.min_triangles));
    EXPECT_LE(triangles, static_cast<uint64_t>(options.max_triangles));
    triangles_by_family[std::string(ShapeFamilyName(family))].push_back(static_cast<double>(triangles));
    ms_by_family[std::string(ShapeFamilyName(family))].push_back(ms);

    const Bounds bounds = ComputeBounds(*asset);
    double largest = 0;
    for (int k = 0; k < 3; ++k) {
      largest = std::max(largest, bounds.max[k] - bounds.min[k]);
      EXPECT_NEAR(bounds.max[k] + bounds.min[k], 0.0, 1e-5) << "axis " << k << " not centred";
    }
    EXPECT_NEAR(largest, 1.0, 1e-5);

    ExpectWellFormedPrimitives(*asset);
    ASSERT_FALSE(::testing::Test::HasFatalFailure());
    ExpectValidPngTextures(*asset, options.texture_size);
    EXPECT_GE(asset->materials.size(), 1u);
    EXPECT_LE(asset->materials.size(), 2u);

    const WeldedMesh mesh = Weld({&asset->nodes[0]});
    EXPECT_EQ(ClosednessProblem(mesh), "");
    // Union parts overlap, so their volumes add up to more than the union's; still positive.
    EXPECT_GT(SignedVolume(mesh), 1e-3);

    // No zero-area triangles (1e-12 is about a 1e-6 x 1e-6 sliver on a unit shape), and
    // vertex normals agree with the winding of the faces they belong to.
    int degenerate = 0, disagreeing_corners = 0;
    for (const Primitive& p : asset->nodes[0].primitives) {
      for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
        const Vec a = Position(p, p.indices[t]), b = Position(p, p.indices[t + 1]), c = Position(p, p.indices[t + 2]);
        const Vec face = Cross(Sub(b, a), Sub(c, a));
        if (Norm(face) / 2 < 1e-12) ++degenerate;
        for (size_t k = 0; k < 3; ++k) disagreeing_corners += Dot(face, Normal(p, p.indices[t + k])) <= 0;
      }
    }
    EXPECT_EQ(degenerate, 0);
    EXPECT_EQ(disagreeing_corners, 0);

    EXPECT_EQ(asset->extras.value("generator", ""), "solid procedural");
    EXPECT_EQ(asset->extras.value("family", ""), ShapeFamilyName(family));
    EXPECT_EQ(asset->extras.value("index", -1), index);
    EXPECT_EQ(asset->extras.value("seed", ""), "0x000000005eed0001");
  }
  for (const auto& [family, counts] : triangles_by_family) {
    const auto [lo, hi] = std::minmax_element(counts.begin(), counts.end());
    double ms = 0;
    for (double x : ms_by_family[family]) ms += x;
    std::printf("%-13s triangles %6.0f..%6.0f  %.1f ms/shape\n", family.c_str(), *lo, *hi,
                ms / static_cast<double>(counts.size()));
  }
}

TEST(ProceduralShape, IsDeterministicToTheByte) {
  for (int index = 0; index < kShapeFamilyCount; ++index) {
    auto a = MakeProceduralShape(kSeed, index, "k");
    auto b = MakeProceduralShape(kSeed, index, "k");
    ASSERT_OK(a.status());
    ASSERT_OK(b.status());
    SCOPED_TRACE(index);
    ExpectIdentical(*a, *b);
  }
}

TEST(ProceduralShape, IndicesAndSeedsGiveDifferentShapes) {
  std::set<std::vector<float>> distinct_positions;
  std::set<std::vector<uint8_t>> distinct_textures;
  for (uint64_t seed : {kSeed, kSeed + 1}) {
    for (int index = 0; index < 2 * kShapeFamilyCount; ++index) {
      auto asset = MakeProceduralShape(seed, index, "k");
      ASSERT_OK(asset.status());
      distinct_positions.insert(asset->nodes[0].primitives[0].positions);
      distinct_textures.insert(asset->textures[0].bytes);
    }
  }
  EXPECT_EQ(distinct_positions.size(), 4u * kShapeFamilyCount);
  EXPECT_EQ(distinct_textures.size(), 4u * kShapeFamilyCount);
}

TEST(ProceduralShape, MeetsNarrowTriangleRangesInEveryFamily) {
  // The smallest accepted range, and a narrow one in the middle.
  for (const auto& [lo, hi] : {std::pair{kMinProceduralTriangles, kMinProceduralTriangles * 5 / 4}, std::pair{1000, 1250}}) {
    const ProceduralShapeOptions options{.min_triangles = lo, .max_triangles = hi, .texture_size = 16};
    for (int index = 0; index < 3 * kShapeFamilyCount; ++index) {
      auto asset = MakeProceduralShape(kSeed, index, "k", options);
      ASSERT_OK(asset.status());
      EXPECT_GE(TriangleCount(*asset), static_cast<uint64_t>(lo)) << index;
      EXPECT_LE(TriangleCount(*asset), static_cast<uint64_t>(hi)) << index;
    }
  }
}

TEST(ProceduralShape, RejectsBadOptions) {
  const auto expect_invalid = [](int index, ProceduralShapeOptions options, const std::string& substring) {
    auto asset = MakeProceduralShape(kSeed, index, "k", options);
    ASSERT_FALSE(asset.ok());
    EXPECT_EQ(asset.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(asset.status().message().find(substring), std::string::npos) << asset.status().ToString();
  };
  expect_invalid(-1, {}, "index");
  expect_invalid(0, {.min_triangles = 100, .max_triangles = 1000}, "triangle range [100, 1000]");
  expect_invalid(0, {.min_triangles = 1000, .max_triangles = 1100}, "triangle range");
  expect_invalid(0, {.texture_size = 0}, "texture_size 0");
}

TEST(ProceduralShape, FamilyNamesAreDistinct) {
  std::set<std::string_view> names;
  for (int f = 0; f < kShapeFamilyCount; ++f) names.insert(ShapeFamilyName(static_cast<ShapeFamily>(f)));
  EXPECT_EQ(names.size(), static_cast<size_t>(kShapeFamilyCount));
}

// ---------------------------------------------------------------------------------------

const Node* FindNode(const Asset& asset, const std::string& name) {
  for (const Node& n : asset.nodes) {
    if (n.name == name) return &n;
  }
  return nullptr;
}

// Whether (x, z) lies inside the floor, i.e. the room's plan.
bool InsideFloor(const Node& floor, double x, double z) {
  for (const Primitive& p : floor.primitives) {
    for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
      const Vec a = Position(p, p.indices[t]), b = Position(p, p.indices[t + 1]), c = Position(p, p.indices[t + 2]);
      const auto side = [&](const Vec& u, const Vec& v) { return (v[0] - u[0]) * (z - u[2]) - (v[2] - u[2]) * (x - u[0]); };
      const double s0 = side(a, b), s1 = side(b, c), s2 = side(c, a);
      if ((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0)) return true;
    }
  }
  return false;
}

TEST(ProceduralRoom, RoomsAreClosedInwardFacingAndInRange) {
  const ProceduralRoomOptions options{.texture_size = 64};
  std::set<std::string> plans;
  for (int index = 0; index < 24; ++index) {
    SCOPED_TRACE("repro: MakeProceduralRoom(" + std::to_string(kSeed) + ", " + std::to_string(index) + ")");
    auto room = MakeProceduralRoom(kSeed, index, "room-" + std::to_string(index), options);
    ASSERT_OK(room.status());
    ExpectWellFormedPrimitives(*room);
    ASSERT_FALSE(::testing::Test::HasFatalFailure());
    ExpectValidPngTextures(*room, options.texture_size);
    ASSERT_EQ(room->nodes.size(), 3u);
    const Node *floor = FindNode(*room, "floor"), *wall = FindNode(*room, "wall"), *ceiling = FindNode(*room, "ceiling");
    ASSERT_TRUE(floor && wall && ceiling);
    std::set<std::string> material_names;
    for (const Material& m : room->materials) material_names.insert(m.name);
    EXPECT_EQ(material_names, (std::set<std::string>{"floor", "wall", "ceiling"}));
    plans.insert(room->extras.value("plan", ""));
    EXPECT_EQ(room->extras.value("family", ""), "room");
    EXPECT_EQ(room->extras.value("key", ""), "room-" + std::to_string(index));

    const Bounds bounds = ComputeBounds(*room);
    const double width = bounds.max[0] - bounds.min[0], height = bounds.max[1], depth = bounds.max[2] - bounds.min[2];
    EXPECT_EQ(bounds.min[1], 0.0);
    EXPECT_GE(width, 4.0);
    EXPECT_LE(width, 16.0);
    EXPECT_GE(depth, 4.0);
    EXPECT_LE(depth, 16.0);
    EXPECT_GE(height, 2.5);
    EXPECT_LE(height, 4.0);
    EXPECT_NEAR(bounds.max[0] + bounds.min[0], 0.0, 1e-5);
    EXPECT_NEAR(bounds.max[2] + bounds.min[2], 0.0, 1e-5);
    const size_t triangles = TriangleCount(*room);
    EXPECT_GE(triangles, 36u);
    EXPECT_LE(triangles, 4000u);

    // Floor and ceiling: flat, facing into the room, UVs spanning the plan in metres.
    for (const auto& [node, y, ny] : {std::tuple{floor, 0.0, 1.0}, std::tuple{ceiling, height, -1.0}}) {
      for (const Primitive& p : node->primitives) {
        float u_min = 1e9f, u_max = -1e9f, v_min = 1e9f, v_max = -1e9f;
        for (uint32_t v = 0; v < p.positions.size() / 3; ++v) {
          EXPECT_EQ(Position(p, v)[1], y);
          EXPECT_EQ(Normal(p, v), (Vec{0, ny, 0}));
          u_min = std::min(u_min, p.uvs[2 * v]);
          u_max = std::max(u_max, p.uvs[2 * v]);
          v_min = std::min(v_min, p.uvs[2 * v + 1]);
          v_max = std::max(v_max, p.uvs[2 * v + 1]);
        }
        EXPECT_NEAR(u_max - u_min, width, 1e-4);
        EXPECT_NEAR(v_max - v_min, depth, 1e-4);
      }
    }
    // Walls: vertical, and a step along the normal from each panel stays inside the plan
    // while a step against it leaves it; this works for L plans as well as boxes.
    for (const Primitive& p : wall->primitives) {
      float v_min = 1e9f, v_max = -1e9f;
      for (uint32_t v = 0; v < p.positions.size() / 3; ++v) {
        v_min = std::min(v_min, p.uvs[2 * v + 1]);
        v_max = std::max(v_max, p.uvs[2 * v + 1]);
      }
      EXPECT_NEAR(v_max - v_min, height, 1e-4);
      for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
        const Vec a = Position(p, p.indices[t]), b = Position(p, p.indices[t + 1]), c = Position(p, p.indices[t + 2]);
        const Vec n = Normal(p, p.indices[t]);
        EXPECT_EQ(n[1], 0.0);
        EXPECT_GT(Dot(Cross(Sub(b, a), Sub(c, a)), n), 0.0) << "winding disagrees with the normal";
        const double cx = (a[0] + b[0] + c[0]) / 3, cz = (a[2] + b[2] + c[2]) / 3;
        EXPECT_TRUE(InsideFloor(*floor, cx + 0.05 * n[0], cz + 0.05 * n[2]));
        EXPECT_FALSE(InsideFloor(*floor, cx - 0.05 * n[0], cz - 0.05 * n[2]));
        if (room->extras.value("plan", "") == "box") {
          EXPECT_GT(-(cx * n[0] + cz * n[2]), 0.0) << "faces the centre";
        }
      }
    }
    // The whole room is one closed mesh wound inwards: no light leaks through seams.
    const WeldedMesh mesh = Weld({floor, wall, ceiling});
    EXPECT_EQ(ClosednessProblem(mesh), "");
    EXPECT_LT(SignedVolume(mesh), 0.0);
    EXPECT_GT(-SignedVolume(mesh), 0.6 * width * depth * height) << "an L plan removes at most 36%";
  }
  EXPECT_EQ(plans, (std::set<std::string>{"box", "L"}));
}

TEST(ProceduralRoom, IsDeterministicAndVaried) {
  auto a = MakeProceduralRoom(kSeed, 3, "r");
  auto b = MakeProceduralRoom(kSeed, 3, "r");
  auto c = MakeProceduralRoom(kSeed, 4, "r");
  ASSERT_OK(a.status());
  ASSERT_OK(b.status());
  ASSERT_OK(c.status());
  ExpectIdentical(*a, *b);
  EXPECT_NE(a->extras["size_m"], c->extras["size_m"]);
  EXPECT_NE(a->textures[0].bytes, c->textures[0].bytes);
}

TEST(ProceduralRoom, RejectsBadOptions) {
  auto room = MakeProceduralRoom(kSeed, 0, "r", {.texture_size = 100000});
  ASSERT_FALSE(room.ok());
  EXPECT_EQ(room.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(room.status().message().find("texture_size 100000"), std::string::npos);
}

}  // namespace
}  // namespace solid::convert
