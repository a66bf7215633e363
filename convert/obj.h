// Wavefront OBJ and MTL reading, from memory, for untrusted input (ShapeNet v1/v2,
// SceneNet, any exporter). Follows docs "input-formats" section 4 ("OBJ parsing"):
// LF/CRLF, '\' continuation, runs of blanks, v/vt/vn corners freely mixed, negative
// indices relative to the elements defined before that line, polygons triangulated
// (fan when convex, ear clipping in the polygon's plane when concave), numbers parsed
// locale-independently with std::from_chars. Errors name "name:line:column".
// Thread-safe: no shared state.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "solid/formats/status.h"

namespace solid::convert {

struct ObjReadOptions {
  uint64_t max_bytes = uint64_t{512} << 20;
  uint64_t max_vertices = 50'000'000;   // v, vt and vn each
  uint64_t max_faces = 50'000'000;      // triangles after triangulation
  uint64_t max_line_length = 1 << 20;   // bytes, after joining '\' continuations
  uint32_t max_polygon_corners = 4096;
};

// One triangle corner: 0-based indices into ObjData's arrays; -1 when absent.
struct ObjCorner {
  int64_t v = -1, vt = -1, vn = -1;
  friend bool operator==(const ObjCorner&, const ObjCorner&) = default;
};

struct ObjTriangle {
  std::array<ObjCorner, 3> corners;
  uint32_t line = 0;  // 1-based source line of the face record
};

// A run of faces sharing one object/group and one material, in file order.
struct ObjFaceBlock {
  std::string object;    // the current `o` name ("" before any)
  std::string group;     // the current `g` name(s), joined by ' ' ("" before any)
  std::string material;  // the current `usemtl` name ("" before any)
  std::vector<ObjTriangle> triangles;
  uint64_t line_records = 0, point_records = 0;  // `l` and `p` in this block, ignored
};

struct ObjData {
  std::vector<std::array<double, 3>> positions;
  std::vector<std::array<double, 2>> uvs;  // the optional w is dropped
  std::vector<std::array<double, 3>> normals;
  std::vector<ObjFaceBlock> blocks;        // blocks with no triangles are kept (counted, then dropped later)
  std::vector<std::string> mtllibs;        // `mtllib` arguments in order (file names as written). Several
                                           // names may share a line; when some end in ".mtl", blanks before
                                           // such a name belong to it ("mtllib my file.mtl" is one name)
  struct Counts {
    uint64_t polygons_triangulated = 0;    // faces with more than 3 corners
    uint64_t concave_polygons = 0;         // of those, not convex: ear clipped (or fanned, see below)
    uint64_t triangulation_fallbacks = 0;  // polygons fanned because they have no plane (all corners
                                           // collinear) or ear clipping could not finish (self-intersecting)
    uint64_t short_faces_dropped = 0;      // faces with fewer than 3 corners
    uint64_t unknown_records = 0;          // records we do not interpret (counted, ignored)
    uint64_t line_records = 0, point_records = 0;
  } counts;
};

// Parses OBJ text. Failure codes: kParseError (malformed number, corner or record,
// with "name:line:column"), kCorrupt with message containing "index_out_of_range"
// (index 0 or outside the elements defined so far), kLimitExceeded, and kParseError
// for non-finite coordinates ("name:line:column: non-finite coordinate").
// Records: v (x y z, then up to 4 ignored numbers: w or r g b [a]), vt (u [v [w]], more
// ignored), vn (x y z), f, l, p, o, g, s, usemtl, mtllib; anything else is counted in
// counts.unknown_records. On v/vt/vn/f/l/p lines a token starting with '#' ends the record.
// A line ending in '\' continues on the next one (the backslash becomes a blank). Text
// starting with a UTF-16 byte order mark is refused; a UTF-8 one is skipped.
Result<ObjData> ReadObj(std::span<const uint8_t> bytes, std::string_view name, const ObjReadOptions& options = {});

struct MtlMaterial {
  std::string name;
  std::array<double, 3> kd = {0.8, 0.8, 0.8};  // OBJ default when Kd is absent
  double d = 1.0;                              // dissolve; "Tr t" gives d = 1 - t unless the
                                               // material also has `d`, which wins in any order
  std::optional<std::string> map_kd;           // path as written (options like -s stripped)
  std::optional<std::string> map_d;
  uint32_t line = 0;                           // line of `newmtl`
};

struct MtlData {
  std::vector<MtlMaterial> materials;  // file order; a repeated name keeps the first (warning counted)
  uint64_t duplicate_names = 0;
  uint64_t unknown_records = 0;
};

// Parses MTL text: newmtl (the rest of the line, may be empty or hold blanks), Kd (r or r g b),
// d (optionally "-halo"), Tr, map_Kd and map_d (option flags such as "-s 1 1 1" or
// "-clamp on" stripped; the rest of the line is the path, blanks included; an unknown "-x"
// starts the path). Keywords are matched case-insensitively. Other keys, and keys before
// the first newmtl, are counted in unknown_records. Unlike OBJ, a trailing '\' is not a
// continuation: Windows paths such as "map_Kd ..\" end in one. Failure codes: kParseError
// (malformed or non-finite number, with "name:line:column"; UTF-16 text), kLimitExceeded
// (max_bytes, max_line_length).
Result<MtlData> ReadMtl(std::span<const uint8_t> bytes, std::string_view name, const ObjReadOptions& options = {});

}  // namespace solid::convert
