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
constexpr int kShapesPerFamily = 3;

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

// Closed, allowing non-manifold edges: every edge is crossed as often in one direction as
// in the other. Where two solid blocks of a room meet only along a vertical edge (a
// pillar and a beam's side, say), four faces share it.
std::string WatertightnessProblem(const WeldedMesh& mesh) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) ++directed[{t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)]}];
  }
  for (const auto& [edge, count] : directed) {
    const auto reverse = directed.find({edge.second, edge.first});
    if (reverse == directed.end() || reverse->second != count) return "an edge crossed more often one way than the other";
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
    EXPECT_GE(m.roughness, 0.1f);
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

ShapeFamily Family(int f) { return static_cast<ShapeFamily>(f); }

// Model `family` of the set that holds only that family: its first model is index 0.
Result<Asset> ShapeOf(ShapeFamily family, int index, const ProceduralShapeOptions& base = {}) {
  ProceduralShapeOptions options = base;
  options.families = {family};
  return MakeProceduralShape(kSeed, index, "procedural/shape-" + std::to_string(index), options);
}

TEST(ProceduralShape, EveryFamilyMeetsTheGeometricContract) {
  const ProceduralShapeOptions options;
  for (int f = 0; f < kShapeFamilyCount; ++f) {
    const ShapeFamily family = Family(f);
    double ms = 0;
    uint64_t lo = UINT64_MAX, hi = 0;
    for (int index = 0; index < kShapesPerFamily; ++index) {
      SCOPED_TRACE("repro: MakeProceduralShape(" + std::to_string(kSeed) + ", " + std::to_string(index) +
                   ", families = {" + std::string(ShapeFamilyName(family)) + "})");
      const auto start = std::chrono::steady_clock::now();
      auto asset = ShapeOf(family, index);
      ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      ASSERT_OK(asset.status());
      ASSERT_EQ(asset->nodes.size(), 1u);
      EXPECT_EQ(asset->nodes[0].name, "procedural/shape-" + std::to_string(index));
      const uint64_t triangles = TriangleCount(*asset);
      EXPECT_GE(triangles, static_cast<uint64_t>(options.min_triangles));
      EXPECT_LE(triangles, static_cast<uint64_t>(options.max_triangles));
      lo = std::min(lo, triangles);
      hi = std::max(hi, triangles);

      // ShapeNetCore.v2's normalisation: vertex mean at the origin, bounding-box diagonal 1.
      const Bounds bounds = ComputeBounds(*asset);
      double diagonal2 = 0;
      for (int k = 0; k < 3; ++k) diagonal2 += (bounds.max[k] - bounds.min[k]) * (bounds.max[k] - bounds.min[k]);
      EXPECT_NEAR(std::sqrt(diagonal2), 1.0, 1e-5);
      Vec mean{0, 0, 0};
      double vertices = 0;
      for (const Primitive& p : asset->nodes[0].primitives) {
        for (uint32_t v = 0; v < p.positions.size() / 3; ++v) {
          for (size_t k = 0; k < 3; ++k) mean[k] += Position(p, v)[k];
          vertices += 1;
        }
      }
      for (size_t k = 0; k < 3; ++k) EXPECT_NEAR(mean[k] / vertices, 0.0, 1e-5) << "axis " << k;

      ExpectWellFormedPrimitives(*asset);
      ASSERT_FALSE(::testing::Test::HasFatalFailure());
      ExpectValidPngTextures(*asset, options.texture_size);
      EXPECT_GE(asset->materials.size(), 1u);
      EXPECT_LE(asset->nodes[0].primitives.size(), asset->materials.size());

      // Every part is closed and wound outwards, so the union of parts is too (parts
      // overlap but share no vertex).
      const WeldedMesh mesh = Weld({&asset->nodes[0]});
      EXPECT_EQ(ClosednessProblem(mesh), "");
      EXPECT_GT(SignedVolume(mesh), 0.0);

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
      EXPECT_EQ(asset->extras.value("synset_name", ""), ShapeFamilyName(family));
      EXPECT_EQ(asset->extras.value("synset", ""), ShapeFamilySynset(family));
      EXPECT_EQ(asset->extras.value("index", -1), index);
      EXPECT_EQ(asset->extras.value("seed", ""), "0x000000005eed0001");
    }
    std::printf("%-10s triangles %6llu..%6llu  %.1f ms/shape\n", std::string(ShapeFamilyName(family)).c_str(),
                static_cast<unsigned long long>(lo), static_cast<unsigned long long>(hi), ms / kShapesPerFamily);
  }
}

// +Y up: bottles and guitars are taller than wide.
TEST(ProceduralShape, TallFamiliesStandUpright) {
  for (const ShapeFamily family : {ShapeFamily::kBottle, ShapeFamily::kGuitar}) {
    for (int index = 0; index < 3; ++index) {
      auto asset = ShapeOf(family, index);
      ASSERT_OK(asset.status());
      const Bounds b = ComputeBounds(*asset);
      EXPECT_GT(b.max[1] - b.min[1], std::max(b.max[0] - b.min[0], b.max[2] - b.min[2]))
          << ShapeFamilyName(family) << " " << index;
    }
  }
  // Cars and airplanes are longer (front -Z) than wide or tall.
  for (const ShapeFamily family : {ShapeFamily::kCar, ShapeFamily::kAirplane}) {
    for (int index = 0; index < 3; ++index) {
      auto asset = ShapeOf(family, index);
      ASSERT_OK(asset.status());
      const Bounds b = ComputeBounds(*asset);
      EXPECT_GT(b.max[2] - b.min[2], b.max[1] - b.min[1]) << ShapeFamilyName(family) << " " << index;
    }
  }
}

TEST(ProceduralShape, IsDeterministicToTheByte) {
  for (int f = 0; f < kShapeFamilyCount; ++f) {
    auto a = ShapeOf(Family(f), 1);
    auto b = ShapeOf(Family(f), 1);
    ASSERT_OK(a.status());
    ASSERT_OK(b.status());
    SCOPED_TRACE(ShapeFamilyName(Family(f)));
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

TEST(ProceduralShape, DefaultMixesEveryFamilyAndLeansLikeShapeNet) {
  std::map<std::string, int> counts;
  for (int index = 0; index < 64; ++index) {
    const std::string family(ShapeFamilyName(FamilyOfIndex(index, {})));
    if (index < kShapeFamilyCount) {
      EXPECT_EQ(family, ShapeFamilyName(Family(index)));
    }
    ++counts[family];
  }
  EXPECT_EQ(counts.size(), static_cast<size_t>(kShapeFamilyCount));
  EXPECT_EQ(counts["table"], 10);
  EXPECT_EQ(counts["chair"], 8);
  EXPECT_EQ(counts["guitar"], 2);
  auto asset = MakeProceduralShape(kSeed, 20, "k", {.texture_size = 8});
  ASSERT_OK(asset.status());
  EXPECT_EQ(asset->extras.value("family", ""), ShapeFamilyName(FamilyOfIndex(20, {})));
}

TEST(ProceduralShape, FamiliesOptionPicksAndOrdersFamilies) {
  auto families = ParseShapeFamilies({"car", "lamp", "trash_bin"});
  ASSERT_OK(families.status());
  const ProceduralShapeOptions options{.texture_size = 8, .families = *families};
  for (int index = 0; index < 6; ++index) {
    auto asset = MakeProceduralShape(kSeed, index, "k", options);
    ASSERT_OK(asset.status());
    EXPECT_EQ(asset->extras.value("family", ""), (std::array<const char*, 3>{"car", "lamp", "trash_bin"})[index % 3]);
  }
  auto unknown = ParseShapeFamilies({"chair", "spaceship"});
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(unknown.status().message().find("unknown shape family 'spaceship'"), std::string::npos);
  EXPECT_NE(unknown.status().message().find("trash_bin"), std::string::npos) << "lists the valid names";
  auto twice = MakeProceduralShape(kSeed, 0, "k", {.families = {ShapeFamily::kCar, ShapeFamily::kCar}});
  ASSERT_FALSE(twice.ok());
  EXPECT_NE(twice.status().message().find("'car' listed twice"), std::string::npos) << twice.status().ToString();
}

TEST(ProceduralShape, MeetsNarrowTriangleRangesInEveryFamily) {
  for (const auto& [lo, hi] : {std::pair{kMinProceduralTriangles, kMinProceduralTriangles * 5 / 4}, std::pair{8000, 10000}}) {
    for (int f = 0; f < kShapeFamilyCount; ++f) {
      for (int index = 0; index < 2; ++index) {
        auto asset = ShapeOf(Family(f), index, {.min_triangles = lo, .max_triangles = hi, .texture_size = 8});
        SCOPED_TRACE(std::string(ShapeFamilyName(Family(f))) + " " + std::to_string(index));
        ASSERT_OK(asset.status());
        EXPECT_GE(TriangleCount(*asset), static_cast<uint64_t>(lo)) << ShapeFamilyName(Family(f));
        EXPECT_LE(TriangleCount(*asset), static_cast<uint64_t>(hi)) << ShapeFamilyName(Family(f));
      }
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
  expect_invalid(0, {.min_triangles = 500, .max_triangles = 5000}, "triangle range [500, 5000]");
  expect_invalid(0, {.min_triangles = 2000, .max_triangles = 2200}, "triangle range");
  expect_invalid(0, {.texture_size = 0}, "texture_size 0");
}

TEST(ProceduralShape, FamilyNamesAndSynsetsAreDistinct) {
  std::set<std::string_view> names, synsets;
  for (int f = 0; f < kShapeFamilyCount; ++f) {
    names.insert(ShapeFamilyName(Family(f)));
    synsets.insert(ShapeFamilySynset(Family(f)));
    EXPECT_EQ(ShapeFamilySynset(Family(f)).size(), 8u);
  }
  EXPECT_EQ(names.size(), static_cast<size_t>(kShapeFamilyCount));
  EXPECT_EQ(synsets.size(), static_cast<size_t>(kShapeFamilyCount));
}

// ---------------------------------------------------------------------------------------

const Node* FindNode(const Asset& asset, const std::string& name) {
  for (const Node& n : asset.nodes) {
    if (n.name == name) return &n;
  }
  return nullptr;
}

TEST(ProceduralRoom, RoomsAreClosedInwardFacingAndInRange) {
  const ProceduralRoomOptions options{.texture_size = 16};
  std::set<std::string> plans, features;
  for (int index = 0; index < 40; ++index) {
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
    for (const auto& f : room->extras["features"]) features.insert(f.get<std::string>());
    EXPECT_EQ(room->extras.value("family", ""), "room");
    EXPECT_EQ(room->extras.value("key", ""), "room-" + std::to_string(index));

    // SceneNet-sized: 2.5-7 m across (a thick wall may take 0.3 m off), 2.4-3.1 m
    // high, floor at 0, centred in x and z.
    const Bounds bounds = ComputeBounds(*room);
    const double width = bounds.max[0] - bounds.min[0], height = bounds.max[1], depth = bounds.max[2] - bounds.min[2];
    EXPECT_EQ(bounds.min[1], 0.0);
    for (const double d : {width, depth}) {
      EXPECT_GE(d, 2.2);
      EXPECT_LE(d, 7.02);
    }
    EXPECT_GE(height, 2.4);
    EXPECT_LE(height, 3.1);
    EXPECT_LE(std::max(width, depth) / std::min(width, depth), 2.51);
    EXPECT_NEAR(bounds.max[0] + bounds.min[0], 0.0, 1e-5);
    EXPECT_NEAR(bounds.max[2] + bounds.min[2], 0.0, 1e-5);
    const size_t triangles = TriangleCount(*room);
    EXPECT_GE(triangles, 36u);
    EXPECT_LE(triangles, 8000u);

    // Floors face up, ceilings down (sloped at most about 20 degrees).
    for (const Primitive& p : floor->primitives) {
      for (uint32_t v = 0; v < p.positions.size() / 3; ++v) {
        const Vec n = Normal(p, v);
        EXPECT_TRUE(n[1] > 0.999 || std::fabs(n[1]) < 1e-6) << "a floor or a step's riser";
      }
    }
    for (const Primitive& p : ceiling->primitives) {
      for (uint32_t v = 0; v < p.positions.size() / 3; ++v) {
        const Vec n = Normal(p, v);
        EXPECT_TRUE(n[1] < -0.93 || std::fabs(n[1]) < 1e-6) << "a ceiling or the side of a drop";
      }
    }
    for (const Primitive& p : wall->primitives) {
      for (uint32_t v = 0; v < p.positions.size() / 3; ++v) {
        const Vec n = Normal(p, v);
        // Sideways; or up or down (sills, lintels, half-wall tops, shelves), a lintel under
        // a sloped ceiling sloping with it.
        EXPECT_TRUE(std::fabs(n[1]) < 1e-6 || n[1] > 1 - 1e-6 || n[1] < -0.93);
      }
    }
    // No zero-area triangle (a sliver cell between two nearly equal feature edges):
    // Draco drops them, so the decoded room would differ from the generated one.
    int degenerate = 0;
    for (const Node* node : {floor, wall, ceiling}) {
      for (const Primitive& p : node->primitives) {
        for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
          const Vec a = Position(p, p.indices[t]), b = Position(p, p.indices[t + 1]), c = Position(p, p.indices[t + 2]);
          degenerate += Norm(Cross(Sub(b, a), Sub(c, a))) < 1e-8;
        }
      }
    }
    EXPECT_EQ(degenerate, 0);
    // The shell is one closed mesh wound inwards (no light leaks through seams), shelves
    // closed boxes wound outwards.
    const WeldedMesh mesh = Weld({floor, wall, ceiling});
    EXPECT_EQ(WatertightnessProblem(mesh), "");
    EXPECT_LT(SignedVolume(mesh), 0.0);
    EXPECT_GT(-SignedVolume(mesh), 0.3 * width * depth * height);
  }
  EXPECT_EQ(plans, (std::set<std::string>{"box", "L", "U", "T"}));
  for (const char* f : {"pillar", "wing_wall", "half_wall", "platform", "step", "alcove", "door", "window", "soffit",
                        "beam", "sloped_ceiling", "shelf"}) {
    EXPECT_TRUE(features.contains(f)) << f;
  }
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
