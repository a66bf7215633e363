// ReadObj / ReadMtl: one test per generic-OBJ quirk of docs "input-formats" 5.3, error
// locations, limits, MTL keys, the Debian assimp-testmodels corpus and seeded mutations.
#include <gtest/gtest.h>

#include <algorithm>
#include <clocale>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <locale>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "obj.h"

namespace solid::convert {
namespace {

using Point2 = std::array<double, 2>;

std::span<const uint8_t> Bytes(std::string_view text) {
  return {reinterpret_cast<const uint8_t*>(text.data()), text.size()};
}

Result<ObjData> Obj(std::string_view text, const ObjReadOptions& options = {}) {
  return ReadObj(Bytes(text), "t.obj", options);
}

Result<MtlData> Mtl(std::string_view text, const ObjReadOptions& options = {}) {
  return ReadMtl(Bytes(text), "t.mtl", options);
}

ObjData ObjOk(std::string_view text) {
  Result<ObjData> result = Obj(text);
  EXPECT_TRUE(result.ok()) << result.status().ToString();
  return result.ok() ? std::move(result).value() : ObjData{};
}

std::vector<ObjTriangle> AllTriangles(const ObjData& data) {
  std::vector<ObjTriangle> all;
  for (const ObjFaceBlock& block : data.blocks) all.insert(all.end(), block.triangles.begin(), block.triangles.end());
  return all;
}

std::vector<std::array<int64_t, 3>> PositionIndices(const ObjData& data) {
  std::vector<std::array<int64_t, 3>> out;
  for (const ObjTriangle& t : AllTriangles(data)) out.push_back({t.corners[0].v, t.corners[1].v, t.corners[2].v});
  return out;
}

void ExpectError(std::string_view text, StatusCode code, std::string_view substring) {
  Result<ObjData> result = Obj(text);
  ASSERT_FALSE(result.ok()) << "parsed: " << text;
  EXPECT_EQ(result.status().code(), code) << result.status().ToString();
  EXPECT_NE(result.status().message().find(substring), std::string::npos)
      << "message '" << result.status().message() << "' lacks '" << substring << "'";
}

// Positions of a planar polygon given by 2D coordinates in a tilted plane, so that the reader
// must find the plane itself; returns the OBJ text with one face over all of them.
std::string PolygonObj(const std::vector<Point2>& polygon) {
  const std::array<double, 3> origin = {1.5, -2.0, 0.25};
  const std::array<double, 3> u = {0.6, 0.8, 0.0};                      // unit
  const std::array<double, 3> v = {-0.8 * 0.6, 0.6 * 0.6, 0.8};         // unit, orthogonal to u
  std::ostringstream obj;
  obj.precision(17);
  for (const Point2& p : polygon) {
    obj << "v";
    for (int k = 0; k < 3; ++k) obj << ' ' << origin[k] + p[0] * u[k] + p[1] * v[k];
    obj << '\n';
  }
  obj << "f";
  for (size_t i = 1; i <= polygon.size(); ++i) obj << ' ' << i;
  obj << '\n';
  return obj.str();
}

double SignedArea(const std::vector<Point2>& polygon) {
  double area = 0;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const Point2& a = polygon[i];
    const Point2& b = polygon[(i + 1) % polygon.size()];
    area += a[0] * b[1] - a[1] * b[0];
  }
  return area / 2;
}

bool InsidePolygon(const std::vector<Point2>& polygon, Point2 p) {
  bool inside = false;
  for (size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const Point2& a = polygon[i];
    const Point2& b = polygon[j];
    if ((a[1] > p[1]) != (b[1] > p[1]) && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0]) inside = !inside;
  }
  return inside;
}

// The triangles tile the polygon: n - 2 of them, each wound like the polygon, each centroid
// inside it, and their areas summing to the polygon's.
void ExpectTilesPolygon(const std::vector<Point2>& polygon, const std::vector<std::array<int64_t, 3>>& triangles) {
  ASSERT_EQ(triangles.size(), polygon.size() - 2);
  const double area = SignedArea(polygon);
  double sum = 0;
  for (const auto& t : triangles) {
    const std::vector<Point2> tri = {polygon[static_cast<size_t>(t[0])], polygon[static_cast<size_t>(t[1])],
                                     polygon[static_cast<size_t>(t[2])]};
    const double a = SignedArea(tri);
    EXPECT_GE(a * (area > 0 ? 1 : -1), -1e-12) << "triangle wound against the polygon";
    if (std::abs(a) > 1e-12) {
      const Point2 centroid = {(tri[0][0] + tri[1][0] + tri[2][0]) / 3, (tri[0][1] + tri[1][1] + tri[2][1]) / 3};
      EXPECT_TRUE(InsidePolygon(polygon, centroid)) << "triangle " << t[0] << " " << t[1] << " " << t[2];
    }
    sum += a;
  }
  EXPECT_NEAR(sum, area, 1e-9 * std::abs(area));
}

TEST(ObjReader, QuadsNgons_ConvexQuadIsFanned) {
  ObjData data = ObjOk("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
  EXPECT_EQ(PositionIndices(data), (std::vector<std::array<int64_t, 3>>{{0, 1, 2}, {0, 2, 3}}));
  EXPECT_EQ(data.counts.polygons_triangulated, 1u);
  EXPECT_EQ(data.counts.concave_polygons, 0u);
  EXPECT_EQ(data.counts.triangulation_fallbacks, 0u);
}

TEST(ObjReader, QuadsNgons_ConcaveHexagonIsEarClippedInItsPlane) {
  // Corner 3 is reflex and hidden from corner 0, so the fan triangle (0, 2, 3) would be wound
  // backwards and stick out of the polygon.
  const std::vector<Point2> hexagon = {{0, 0}, {4, 0}, {4, 4}, {3, 1}, {0, 4}, {-1, 2}};
  for (bool clockwise : {false, true}) {
    std::vector<Point2> polygon = hexagon;
    if (clockwise) std::reverse(polygon.begin() + 1, polygon.end());
    ObjData data = ObjOk(PolygonObj(polygon));
    EXPECT_EQ(data.counts.polygons_triangulated, 1u);
    EXPECT_EQ(data.counts.concave_polygons, 1u);
    EXPECT_EQ(data.counts.triangulation_fallbacks, 0u);
    ExpectTilesPolygon(polygon, PositionIndices(data));
  }
}

TEST(ObjReader, QuadsNgons_Concave66GonLikeAssimpConcavePolygon) {
  // A 33-pointed star: 66 corners alternating between two radii, half of them reflex.
  std::vector<Point2> star;
  for (int i = 0; i < 66; ++i) {
    const double angle = 2 * 3.141592653589793 * i / 66;
    const double radius = i % 2 ? 0.4 : 1.0;
    star.push_back({radius * std::cos(angle), radius * std::sin(angle)});
  }
  ObjData data = ObjOk(PolygonObj(star));
  EXPECT_EQ(data.counts.concave_polygons, 1u);
  EXPECT_EQ(data.counts.triangulation_fallbacks, 0u);
  ExpectTilesPolygon(star, PositionIndices(data));
}

TEST(ObjReader, QuadsNgons_CollinearPolygonFallsBackToFanAndIsCounted) {
  ObjData data = ObjOk("v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3 4\n");
  EXPECT_EQ(AllTriangles(data).size(), 2u);
  EXPECT_EQ(data.counts.triangulation_fallbacks, 1u);
}

TEST(ObjReader, QuadsNgons_SelfIntersectingPentagramGivesThreeTriangles) {
  std::vector<Point2> pentagram;
  for (int i = 0; i < 5; ++i) {
    const double angle = 2 * 3.141592653589793 * (2 * i) / 5;
    pentagram.push_back({std::cos(angle), std::sin(angle)});
  }
  ObjData data = ObjOk(PolygonObj(pentagram));
  EXPECT_EQ(AllTriangles(data).size(), 3u);
  EXPECT_EQ(data.counts.concave_polygons, 1u);  // turns twice: never fanned as convex
}

TEST(ObjReader, QuadsNgons_ShortFacesAreDroppedAndCounted) {
  ObjData data = ObjOk("v 0 0 0\nv 1 0 0\nf 1 2\nf 1\nf\n");
  EXPECT_TRUE(AllTriangles(data).empty());
  EXPECT_EQ(data.counts.short_faces_dropped, 3u);
}

TEST(ObjReader, NegativeIndices_RelativeToTheVerticesBeforeTheirLine) {
  ObjData data = ObjOk(
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
      "f -3/-1/-1 -2/-1/-1 -1/-1/-1\n"
      "v 0 0 1\nv 1 0 1\nv 0 1 1\nvt 1 1\nvn 0 0 -1\n"
      "f -3/-1/-1 -2/-1/-1 -1/-1/-1\n"
      "f -6 2 -1\n");
  const std::vector<ObjTriangle> triangles = AllTriangles(data);
  ASSERT_EQ(triangles.size(), 3u);
  EXPECT_EQ(triangles[0].corners[0], (ObjCorner{0, 0, 0}));
  EXPECT_EQ(triangles[0].corners[2], (ObjCorner{2, 0, 0}));
  EXPECT_EQ(triangles[1].corners[0], (ObjCorner{3, 1, 1}));
  EXPECT_EQ(triangles[1].corners[2], (ObjCorner{5, 1, 1}));
  EXPECT_EQ(triangles[2].corners[0].v, 0);
  EXPECT_EQ(triangles[2].corners[1].v, 1);
  EXPECT_EQ(triangles[2].corners[2].v, 5);
}

TEST(ObjReader, IndexOutOfRange_FailsWithLocation) {
  const std::string vertices = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  ExpectError(vertices + "f 1 2 4\n", StatusCode::kCorrupt, "t.obj:4:7: index_out_of_range");
  ExpectError(vertices + "f 0 1 2\n", StatusCode::kCorrupt, "t.obj:4:3: index_out_of_range");
  ExpectError(vertices + "f -4 1 2\n", StatusCode::kCorrupt, "t.obj:4:3: index_out_of_range");
  ExpectError(vertices + "vt 0 0\nf 1/1 2/2 3/1\n", StatusCode::kCorrupt, "t.obj:5:9: index_out_of_range");
  ExpectError(vertices + "f 1//1 2//1 3//1\n", StatusCode::kCorrupt, "t.obj:4:6: index_out_of_range");
  ExpectError(vertices + "f 1 2 99999999999999999999999\n", StatusCode::kCorrupt, "index_out_of_range");
  ExpectError(vertices + "f 1 2 -9223372036854775808\n", StatusCode::kCorrupt, "index_out_of_range");
  // A vertex defined after the face does not count.
  ExpectError("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n", StatusCode::kCorrupt, "t.obj:3:7: index_out_of_range");
}

TEST(ObjReader, MalformedCornersAndNumbers_FailWithLocation) {
  const std::string vertices = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  ExpectError(vertices + "f 1 2 x\n", StatusCode::kParseError, "t.obj:4:7: malformed face corner 'x'");
  ExpectError(vertices + "f 1 2 /1\n", StatusCode::kParseError, "t.obj:4:7: face corner '/1' has no vertex index");
  ExpectError(vertices + "f 1 2 3/1/1/1\n", StatusCode::kParseError, "t.obj:4:7:");
  ExpectError(vertices + "f 1 2 3.0\n", StatusCode::kParseError, "t.obj:4:7:");
  ExpectError("v 1 2 3.1+e2\n", StatusCode::kParseError, "t.obj:1:7: malformed number '3.1+e2'");
  ExpectError("v 1 2 1.5e\n", StatusCode::kParseError, "t.obj:1:7:");
  ExpectError("v 1,5 2 3\n", StatusCode::kParseError, "t.obj:1:3:");
  ExpectError("v 1 2\n", StatusCode::kParseError, "t.obj:1:6: 'v' record needs 3 numbers, found 2");
  ExpectError("v 1 2 3 4 5 6 7 8\n", StatusCode::kParseError, "t.obj:1:17: unexpected '8'");
  ExpectError("vn 1 2 3 4\n", StatusCode::kParseError, "t.obj:1:10:");
  ExpectError("vt\n", StatusCode::kParseError, "t.obj:1:3:");
  ExpectError("v 1e999 0 0\n", StatusCode::kParseError, "t.obj:1:3: number '1e999' is out of double range");
  ExpectError("v ++1 0 0\n", StatusCode::kParseError, "t.obj:1:3:");
}

TEST(ObjReader, NonFiniteNumbers_RejectedWithLine) {
  for (std::string_view bad : {"nan", "NaN", "-nan", "inf", "-inf", "+inf", "infinity"}) {
    SCOPED_TRACE(bad);
    ExpectError("v 0 0 0\n\nv 1 " + std::string(bad) + " 0\n", StatusCode::kParseError,
                "t.obj:3:5: non-finite coordinate");
  }
  ExpectError("vt 0 nan\n", StatusCode::kParseError, "t.obj:1:6: non-finite");
  ExpectError("vn 0 0 inf\n", StatusCode::kParseError, "t.obj:1:8: non-finite");
  ExpectError("v 0 0 0 nan 0 0\n", StatusCode::kParseError, "t.obj:1:9: non-finite");
}

TEST(ObjReader, Crlf_AndLoneCrGiveTheSameDataAsLf) {
  const std::string lf = "# c\nv 0 0 0\nv 1 0 0\nv 0 1 0\ng a\nf 1 2 3\nl 1 2\n";
  auto replace = [&](std::string_view eol) {
    std::string out;
    for (char c : lf) c == '\n' ? out += eol : out += c;
    return out;
  };
  const ObjData reference = ObjOk(lf);
  for (std::string_view eol : {"\r\n", "\r"}) {
    const ObjData data = ObjOk(replace(eol));
    EXPECT_EQ(data.positions, reference.positions);
    ASSERT_EQ(data.blocks.size(), 1u);
    EXPECT_EQ(data.blocks[0].group, "a");
    ASSERT_EQ(data.blocks[0].triangles.size(), 1u);
    EXPECT_EQ(data.blocks[0].triangles[0].line, 6u);
    EXPECT_EQ(data.blocks[0].line_records, 1u);
  }
  ExpectError("v 0 0 0\r\nv 0 0 0\r\nv 0 x 0\r\n", StatusCode::kParseError, "t.obj:3:5:");
  ExpectError("v 0 0 0\rv 0 0 0\rv 0 x 0\r", StatusCode::kParseError, "t.obj:3:5:");
}

TEST(ObjReader, LineContinuation_JoinsLinesAndKeepsLocations) {
  ObjData data = ObjOk("v 0 0 \\\n0\nv 1 0 0\nv 0 1 0\nf 1 \\\r\n 2 \\\n3\nf 1 2 3\n");
  ASSERT_EQ(data.positions.size(), 3u);
  const std::vector<ObjTriangle> triangles = AllTriangles(data);
  ASSERT_EQ(triangles.size(), 2u);
  EXPECT_EQ(triangles[0].corners[2].v, 2);
  EXPECT_EQ(triangles[0].line, 5u);
  EXPECT_EQ(triangles[1].line, 8u);
  // The error is on the third physical line of the record, column 1.
  ExpectError("v 0 0 0\nf 1 \\\n1 \\\n7\n", StatusCode::kCorrupt, "t.obj:4:1: index_out_of_range");
  // A backslash that is not last on its line is not a continuation.
  ExpectError("v 0 0 0 \\ \n", StatusCode::kParseError, "t.obj:1:9:");
}

TEST(ObjReader, OAndSRecords_ObjectsMakeBlocksAndSmoothingIsIgnored) {
  ObjData data = ObjOk(
      "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
      "o chair_1\ns off\nusemtl wood\nf 1 2 3\ns 1\nf 1 2 3\n"
      "o Walls.132\nusemtl wood\nf 3 2 1\n"
      "o floor_enclose\nl 1 2\n");
  ASSERT_EQ(data.blocks.size(), 3u);
  EXPECT_EQ(data.blocks[0].object, "chair_1");
  EXPECT_EQ(data.blocks[0].material, "wood");
  EXPECT_EQ(data.blocks[0].triangles.size(), 2u);
  EXPECT_EQ(data.blocks[1].object, "Walls.132");
  EXPECT_EQ(data.blocks[2].object, "floor_enclose");
  EXPECT_TRUE(data.blocks[2].triangles.empty());
  EXPECT_EQ(data.blocks[2].line_records, 1u);
  EXPECT_EQ(data.counts.unknown_records, 0u);
}

TEST(ObjReader, TabsAndSpaces_AnyRunOfBlanksSeparates) {
  ObjData data = ObjOk("v\t0  0\t\t0 \nv 1\t 0 0\t\n  v 0 1 0\nf\t1 \t2   3  \t\n\t\n   \n");
  EXPECT_EQ(data.positions[1], (std::array<double, 3>{1, 0, 0}));
  EXPECT_EQ(PositionIndices(data), (std::vector<std::array<int64_t, 3>>{{0, 1, 2}}));
}

TEST(ObjReader, AssimpTwoSpacesAfterF) {
  ObjData data = ObjOk("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf  1//1 2//1 3//1\nl  1 2\n");
  ASSERT_EQ(AllTriangles(data).size(), 1u);
  EXPECT_EQ(AllTriangles(data)[0].corners[2], (ObjCorner{2, -1, 0}));
  EXPECT_EQ(data.counts.line_records, 1u);
}

TEST(ObjReader, MixedCorners_FreelyMixedWithinAFace) {
  ObjData data = ObjOk(
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0 0\nvt 0.5 0.5 0\nvn 0 0 1\n"
      "f 1//1 2/2/1 3/1/1\nf 2 4/2 3//1\nf 1/1/ 2// 3/2\n");
  const std::vector<ObjTriangle> t = AllTriangles(data);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].corners[0], (ObjCorner{0, -1, 0}));
  EXPECT_EQ(t[0].corners[1], (ObjCorner{1, 1, 0}));
  EXPECT_EQ(t[0].corners[2], (ObjCorner{2, 0, 0}));
  EXPECT_EQ(t[1].corners[0], (ObjCorner{1, -1, -1}));
  EXPECT_EQ(t[1].corners[1], (ObjCorner{3, 1, -1}));
  EXPECT_EQ(t[1].corners[2], (ObjCorner{2, -1, 0}));
  EXPECT_EQ(t[2].corners[0], (ObjCorner{0, 0, -1}));
  EXPECT_EQ(t[2].corners[1], (ObjCorner{1, -1, -1}));
  ASSERT_EQ(data.blocks.size(), 1u);
}

TEST(ObjReader, GFormatNumbers_ExponentsNegativeZeroAndPlus) {
  ObjData data = ObjOk(
      "v -0.250000 0.125000 0.300000\nv 1e2 2.E1 +3.1e+2\nv .5 5. -1E-2\n"
      "vt -0 3.75 0\nvt 0.5\nvt 1 2 3 4\n"
      "vn 0.0254 -0 4.19608e-05\n");
  EXPECT_EQ(data.positions[0], (std::array<double, 3>{-0.25, 0.125, 0.3}));
  EXPECT_EQ(data.positions[1], (std::array<double, 3>{100, 20, 310}));
  EXPECT_EQ(data.positions[2], (std::array<double, 3>{0.5, 5, -0.01}));
  EXPECT_TRUE(std::signbit(data.uvs[0][0]));
  EXPECT_EQ(data.uvs[0][1], 3.75);
  EXPECT_EQ(data.uvs[1], (std::array<double, 2>{0.5, 0}));
  EXPECT_EQ(data.uvs[2], (std::array<double, 2>{1, 2}));
  EXPECT_EQ(data.normals[0][0], 0.0254);
  EXPECT_TRUE(std::signbit(data.normals[0][1]));
  EXPECT_EQ(data.normals[0][2], 4.19608e-05);
}

TEST(ObjReader, VertexColoursAreIgnored) {
  ObjData data = ObjOk("v 0 0 0 0.48627 0.43137 0.47059\nv 1 0 0 1\n");
  EXPECT_EQ(data.positions.size(), 2u);
  EXPECT_EQ(data.positions[1], (std::array<double, 3>{1, 0, 0}));
}

// Stands in for a comma-decimal locale when none is installed: the global C++ locale gets a
// numpunct facet whose decimal point is ','.
struct CommaDecimal : std::numpunct<char> {
  char do_decimal_point() const override { return ','; }
};

TEST(ObjReader, CommaDecimalLocale_DoesNotChangeResults) {
  const std::string text =
      "v -0.250000 0.125000 0.300000\nv 1.5 2.5e-3 4.19608e-05\nv 0 1 0\nvt 0.5 0.25\nvn 0 0.0254 0\n"
      "f 1/1/1 2/1/1 3/1/1\n";
  const ObjData reference = ObjOk(text);
  const std::string previous_c_locale = std::setlocale(LC_NUMERIC, nullptr);
  const std::locale previous_cpp_locale = std::locale::global(std::locale(std::locale::classic(), new CommaDecimal));
  const char* comma_locale = nullptr;
  for (const char* candidate : {"de_DE.UTF-8", "de_DE.utf8", "fr_FR.UTF-8", "fr_FR.utf8", "de_DE", "ru_RU.UTF-8"}) {
    if (std::setlocale(LC_NUMERIC, candidate)) {
      comma_locale = candidate;
      break;
    }
  }
  if (comma_locale) {
    EXPECT_STREQ(std::localeconv()->decimal_point, ",");
  } else {
    std::printf("no comma-decimal C locale installed: checking under a C++ global locale with ',' only\n");
  }
  const Result<ObjData> under_comma = Obj(text);
  const Result<MtlData> mtl_under_comma = Mtl("newmtl m\nKd 0.5 0.25 0.125\nd 0.75\n");
  std::setlocale(LC_NUMERIC, previous_c_locale.c_str());
  std::locale::global(previous_cpp_locale);
  ASSERT_TRUE(under_comma.ok()) << under_comma.status().ToString();
  EXPECT_EQ(under_comma->positions, reference.positions);
  EXPECT_EQ(under_comma->uvs, reference.uvs);
  EXPECT_EQ(under_comma->normals, reference.normals);
  ASSERT_TRUE(mtl_under_comma.ok());
  EXPECT_EQ(mtl_under_comma->materials[0].kd, (std::array<double, 3>{0.5, 0.25, 0.125}));
  EXPECT_EQ(mtl_under_comma->materials[0].d, 0.75);
}

TEST(ObjReader, Comments_MtllibAndUnknownRecords) {
  ObjData data = ObjOk(
      "# banner\n#mtllib hidden.mtl\nmtllib a.mtl b.MTL\nmtllib my model.mtl\nmtllib cube.mat\n"
      "mtllib a.mtl\nv 0 0 0 # trailing comment\nvp 0.5\ncstype bezier\nfo 1 2 3\nusemap x\n");
  EXPECT_EQ(data.mtllibs, (std::vector<std::string>{"a.mtl", "b.MTL", "my model.mtl", "cube.mat", "a.mtl"}));
  EXPECT_EQ(data.positions.size(), 1u);
  EXPECT_EQ(data.counts.unknown_records, 4u);
}

TEST(ObjReader, Blocks_StartWhenObjectGroupOrMaterialChanges) {
  ObjData data = ObjOk(
      "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
      "f 1 2 3\n"
      "g mesh1 part\tB\nusemtl material_0_24\nf 1 2 3\n"
      "g other\ng mesh1  part B\nf 1 2 3\n"  // back to the same state: the block continues
      "usemtl material_1_0\nf 1 2 3\n"
      "g mesh1 part B\nusemtl material_0_24\nf 1 2 3\n"  // recurring name after another block
      "g lines\nusemtl material_1_0\nl  1 2\nl 2 3\np 1\n"
      "g\nf 1 2 3\n");
  ASSERT_EQ(data.blocks.size(), 6u);
  EXPECT_EQ(data.blocks[0].group, "");
  EXPECT_EQ(data.blocks[0].material, "");
  EXPECT_EQ(data.blocks[1].group, "mesh1 part B");
  EXPECT_EQ(data.blocks[1].material, "material_0_24");
  EXPECT_EQ(data.blocks[1].triangles.size(), 2u);
  EXPECT_EQ(data.blocks[2].material, "material_1_0");
  EXPECT_EQ(data.blocks[3].material, "material_0_24");
  EXPECT_TRUE(data.blocks[4].triangles.empty());
  EXPECT_EQ(data.blocks[4].line_records, 2u);
  EXPECT_EQ(data.blocks[4].point_records, 1u);
  EXPECT_EQ(data.blocks[5].group, "");
  EXPECT_EQ(data.counts.line_records, 2u);
  EXPECT_EQ(data.counts.point_records, 1u);
}

TEST(ObjReader, EncodingsAndEmptyInput) {
  EXPECT_TRUE(ObjOk("").positions.empty());
  EXPECT_EQ(ObjOk("\xEF\xBB\xBFv 0 0 0").positions.size(), 1u);  // BOM, no final newline
  const std::string utf16 = std::string("\xFE\xFF\0v\0 \0" "1", 8);
  ExpectError(utf16, StatusCode::kParseError, "t.obj:1:1: UTF-16");
}

TEST(ObjReader, Limits_LineLength) {
  ObjReadOptions options;
  options.max_line_length = 16;
  EXPECT_TRUE(Obj("v 0.5 0.5 0.5\n", options).ok());
  Result<ObjData> result = Obj("v 0 0 0\nv 0.5 0.5 0.5 # long\n", options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), StatusCode::kLimitExceeded);
  EXPECT_NE(result.status().message().find("t.obj:2:17: line is longer than max_line_length"), std::string::npos)
      << result.status().message();
  result = Obj("v 0.5 0.5 \\\n 0.5 0.5 0.5 0.5\n", options);  // long only once joined
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), StatusCode::kLimitExceeded);
  EXPECT_NE(result.status().message().find("t.obj:2:"), std::string::npos) << result.status().message();
}

TEST(ObjReader, Limits_VerticesFacesCornersBytes) {
  ObjReadOptions options;
  options.max_vertices = 3;
  const std::string three = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
  EXPECT_TRUE(Obj(three, options).ok());
  for (std::string_view extra : {"v 1 1 0\n", "vt 0 0\nvt 0 0\nvt 0 0\n", "vn 0 0 1\nvn 0 0 1\nvn 0 0 1\n"}) {
    Result<ObjData> result = Obj(three + std::string(extra), options);
    ASSERT_FALSE(result.ok()) << extra;
    EXPECT_EQ(result.status().code(), StatusCode::kLimitExceeded);
    EXPECT_NE(result.status().message().find("max_vertices"), std::string::npos);
  }
  Result<ObjData> result = Obj(three + "v 1 1 0\n", options);
  EXPECT_NE(result.status().message().find("t.obj:6:1:"), std::string::npos) << result.status().message();

  options = {};
  options.max_faces = 3;
  const std::string quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
  EXPECT_TRUE(Obj(quad + "f 1 2 3\nf 1 2 3 4\n", options).ok());
  result = Obj(quad + "f 1 2 3\nf 1 2 3\nf 1 2 3 4\n", options);  // the quad makes triangles 3 and 4
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), StatusCode::kLimitExceeded);
  EXPECT_NE(result.status().message().find("t.obj:7:1: more than max_faces (3)"), std::string::npos)
      << result.status().message();

  options = {};
  options.max_polygon_corners = 4;
  EXPECT_TRUE(Obj(quad + "f 1 2 3 4\n", options).ok());
  result = Obj(quad + "f 1 2 3 4 1\n", options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), StatusCode::kLimitExceeded);
  EXPECT_NE(result.status().message().find("t.obj:5:11:"), std::string::npos) << result.status().message();

  options = {};
  options.max_bytes = 10;
  result = Obj(quad, options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), StatusCode::kLimitExceeded);
  EXPECT_EQ(Mtl("newmtl a\nKd 1 1 1\n", options).status().code(), StatusCode::kLimitExceeded);
}

TEST(MtlReader, KdDissolveTransparencyAndMaps) {
  Result<MtlData> result = Mtl(
      "# Blender MTL File\r\nnewmtl material_0_24\r\nKd 0.5 0.25 1\r\nKa 0 0 0\r\nd 0.5\r\nillum 2\r\n"
      "newmtl glass\nTr 0.25\nKd 0.3\n"
      "newmtl both\nd 0.9\nTr 0.5\n"
      "newmtl tr_first\nTr 0.5\nd 0.9\n"
      "newmtl halo\nd -halo 0.6\n"
      "newmtl textured\nKd 1 1 1\nmap_Kd -s 1 1 1 -o 0.5 0.5 -bm 0.2 -clamp on ../images/my texture 0.jpg  \n"
      "map_d -imfchan m ../images/alpha.png\n"
      "newmtl windows\nmap_Kd ..\\images\\t.jpg\nmap_kd .\\\n"
      "newmtl \n"
      "newmtl options_only\nmap_Kd -s 2 2\n"
      "newmtl short_scale\nmap_Kd -s 2 tex.png\n");
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  const std::vector<MtlMaterial>& m = result->materials;
  ASSERT_EQ(m.size(), 10u);
  EXPECT_EQ(m[0].name, "material_0_24");
  EXPECT_EQ(m[0].line, 2u);
  EXPECT_EQ(m[0].kd, (std::array<double, 3>{0.5, 0.25, 1}));
  EXPECT_EQ(m[0].d, 0.5);
  EXPECT_EQ(m[1].d, 0.75);
  EXPECT_EQ(m[1].kd, (std::array<double, 3>{0.3, 0.3, 0.3}));
  EXPECT_EQ(m[2].d, 0.9);
  EXPECT_EQ(m[3].d, 0.9);
  EXPECT_EQ(m[4].d, 0.6);
  EXPECT_EQ(m[5].map_kd, "../images/my texture 0.jpg");
  EXPECT_EQ(m[5].map_d, "../images/alpha.png");
  EXPECT_EQ(m[6].map_kd, ".\\");  // the later map_kd wins; a trailing '\' does not continue the line
  EXPECT_EQ(m[7].name, "");
  EXPECT_EQ(m[7].kd, (std::array<double, 3>{0.8, 0.8, 0.8}));
  EXPECT_FALSE(m[8].map_kd.has_value());
  EXPECT_EQ(m[9].map_kd, "tex.png");
  EXPECT_EQ(result->unknown_records, 3u);  // Ka, illum, the options-only map_Kd
}

TEST(MtlReader, DuplicateNamesKeepTheFirst) {
  Result<MtlData> result = Mtl("newmtl a\nKd 1 0 0\nnewmtl b\nnewmtl a\nKd 0 1 0\nmap_Kd x.jpg\nKs 1 1 1\n");
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  ASSERT_EQ(result->materials.size(), 2u);
  EXPECT_EQ(result->materials[0].kd, (std::array<double, 3>{1, 0, 0}));
  EXPECT_FALSE(result->materials[0].map_kd.has_value());
  EXPECT_EQ(result->duplicate_names, 1u);
  EXPECT_EQ(result->unknown_records, 1u);
}

TEST(MtlReader, ErrorsNameTheLocation) {
  auto expect_error = [](std::string_view text, std::string_view substring) {
    Result<MtlData> result = Mtl(text);
    ASSERT_FALSE(result.ok()) << text;
    EXPECT_EQ(result.status().code(), StatusCode::kParseError);
    EXPECT_NE(result.status().message().find(substring), std::string::npos) << result.status().message();
  };
  expect_error("newmtl a\nKd 1 nan 1\n", "t.mtl:2:6: non-finite");
  expect_error("newmtl a\nKd 1 0\n", "t.mtl:2:7: missing number");
  expect_error("newmtl a\nd 0,5\n", "t.mtl:2:3: malformed number");
  expect_error("newmtl a\nTr\n", "t.mtl:2:3:");
  expect_error(std::string("\xFF\xFEn\0e\0", 6), "t.mtl:1:1: UTF-16");
  Result<MtlData> before_newmtl = Mtl("Kd 1 1 1\nnewmtl a\n");
  ASSERT_TRUE(before_newmtl.ok());
  EXPECT_EQ(before_newmtl->unknown_records, 1u);
}

std::vector<uint8_t> ReadFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

constexpr const char* kAssimpObjDir = "/usr/share/assimp/models/OBJ";

TEST(ObjReaderCorpus, AssimpTestModelsParseOrFailCleanly) {
  if (!std::filesystem::is_directory(kAssimpObjDir)) {
    GTEST_SKIP() << kAssimpObjDir << " absent: install Debian package assimp-testmodels to run this test";
  }
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(kAssimpObjDir)) {
    const std::string ext = entry.path().extension().string();
    if (ext == ".obj" || ext == ".mtl") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  int parsed = 0, failed = 0;
  for (const auto& path : files) {
    const std::vector<uint8_t> bytes = ReadFile(path);
    const Status status = path.extension() == ".obj" ? ReadObj(bytes, path.filename().string()).status()
                                                     : ReadMtl(bytes, path.filename().string()).status();
    status.ok() ? ++parsed : ++failed;
    if (!status.ok()) std::printf("  %s\n", status.ToString().c_str());
  }
  std::printf("assimp-testmodels OBJ/MTL: %d parsed, %d failed of %zu\n", parsed, failed, files.size());
  EXPECT_GT(parsed, 0);
}

TEST(ObjReaderCorpus, AssimpConcavePolygonIsTiledByEarClipping) {
  const std::filesystem::path path = std::filesystem::path(kAssimpObjDir) / "concave_polygon.obj";
  if (!std::filesystem::exists(path)) {
    GTEST_SKIP() << path << " absent: install Debian package assimp-testmodels to run this test";
  }
  const std::vector<uint8_t> bytes = ReadFile(path);
  Result<ObjData> result = ReadObj(bytes, "concave_polygon.obj");
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  const ObjData& data = *result;
  EXPECT_EQ(data.counts.concave_polygons, 1u);
  EXPECT_EQ(data.counts.triangulation_fallbacks, 0u);
  const std::vector<ObjTriangle> triangles = AllTriangles(data);
  ASSERT_EQ(triangles.size(), 64u);
  // The 66-gon lies in a plane x = const: tile it in y/z over the face's own corner order.
  std::vector<Point2> polygon;
  std::vector<int64_t> corner_of_vertex(data.positions.size(), -1);
  std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  const size_t face = text.find("\nf ");
  ASSERT_NE(face, std::string_view::npos);
  std::istringstream corners(std::string(text.substr(face + 3, text.find('\n', face + 1) - face - 3)));
  for (std::string corner; corners >> corner;) {
    const auto v = static_cast<size_t>(std::stoll(corner) - 1);
    corner_of_vertex[v] = static_cast<int64_t>(polygon.size());
    polygon.push_back({data.positions[v][1], data.positions[v][2]});
  }
  ASSERT_EQ(polygon.size(), 66u);
  std::vector<std::array<int64_t, 3>> local;
  for (const ObjTriangle& t : triangles) {
    local.push_back({corner_of_vertex[static_cast<size_t>(t.corners[0].v)],
                     corner_of_vertex[static_cast<size_t>(t.corners[1].v)],
                     corner_of_vertex[static_cast<size_t>(t.corners[2].v)]});
  }
  ExpectTilesPolygon(polygon, local);
}

// Every corner a successful parse returns indexes its arrays: the property the converter
// relies on without rechecking.
void ExpectIndicesInRange(const ObjData& data) {
  for (const ObjFaceBlock& block : data.blocks) {
    for (const ObjTriangle& t : block.triangles) {
      for (const ObjCorner& c : t.corners) {
        ASSERT_GE(c.v, 0);
        ASSERT_LT(static_cast<size_t>(c.v), data.positions.size());
        ASSERT_LT(c.vt, static_cast<int64_t>(data.uvs.size()));
        ASSERT_LT(c.vn, static_cast<int64_t>(data.normals.size()));
        ASSERT_GE(c.vt, -1);
        ASSERT_GE(c.vn, -1);
      }
    }
  }
}

TEST(ObjReaderRobustness, SeededMutationsNeverCrash) {
  const std::string seed_obj =
      "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\nvt 0 0 0\nvt 1 1\nvn 0 0 1\n"
      "o obj\ng grp\nusemtl m\nf 1/1/1 2/2/1 3//1 4\nf -5 -4 -1\nf  1 2 3 4 5\nl 1 2\np 3\ns 1\n"
      "f 1 \\\n 3 4\r\nf 1/1 2/2 3/1\n";
  const std::string seed_mtl =
      "newmtl m\nKd 1 0.5 0\nd 0.5\nTr 0.2\nmap_Kd -s 1 1 1 -clamp on my tex.png\nmap_d -o 1 a.png\nnewmtl m\n";
  const std::vector<std::string> insertions = {
      "/", "//", "-", "-1", "0", "\\\n", "\n", "\r", "#", "f ", "v ", "vt ", "vn ", " ", "\t", "99999999999999999999",
      "nan", "1e308", "-0", "e", ".", "+", "-s", "\xEF\xBB\xBF", "\xFE\xFF", "g ", "usemtl ", "newmtl ", "-9223372036854775808"};
  std::mt19937_64 rng(0x5eed0b1);
  ObjReadOptions options;
  options.max_line_length = 4096;
  int ok = 0;
  for (int iteration = 0; iteration < 4000; ++iteration) {
    std::string text = iteration % 2 ? seed_obj : seed_mtl;
    const int edits = 1 + static_cast<int>(rng() % 8);
    for (int e = 0; e < edits; ++e) {
      const size_t at = text.empty() ? 0 : rng() % (text.size() + 1);
      switch (rng() % 4) {
        case 0:
          if (!text.empty() && at < text.size()) text[at] = static_cast<char>(rng());
          break;
        case 1:
          text.insert(at, insertions[rng() % insertions.size()]);
          break;
        case 2:
          text.erase(at, rng() % 6);
          break;
        case 3:
          text.insert(at, text.substr(rng() % (text.size() + 1), rng() % 40));
          break;
      }
    }
    Result<ObjData> obj = Obj(text, options);
    if (obj.ok()) {
      ++ok;
      ExpectIndicesInRange(*obj);
    } else {
      EXPECT_NE(obj.status().message().find("t.obj"), std::string::npos) << obj.status().message();
    }
    Result<MtlData> mtl = Mtl(text, options);
    if (!mtl.ok()) {
      EXPECT_NE(mtl.status().message().find("t.mtl"), std::string::npos) << mtl.status().message();
    }
    if (HasFatalFailure()) {
      ADD_FAILURE() << "iteration " << iteration << " input:\n" << text;
      return;
    }
  }
  EXPECT_GT(ok, 100);  // the mutations must not all be rejected, or they test nothing past the first line
}

}  // namespace
}  // namespace solid::convert
