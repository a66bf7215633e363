// Our OBJ reader (convert/obj_reader.cpp) against Debian's tinyobjloader, the library we
// would otherwise use (docs/dependencies.md): read speed on real OBJ files and on a large
// generated one, and what each says about malformed input. Both parse from memory into
// doubles and triangulate, so the I/O is out of the timing.
//   obj_reader_vs_tinyobjloader [--repeat N] [--grid N] [OBJ_FILE...]
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <tiny_obj_loader.h>

#include <algorithm>
#include <fstream>
#include <sstream>

#include "obj.h"
#include "best_time.h"

namespace {

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

// An n x n grid of quads with positions, uvs and normals on every corner, as exporters write.
std::string GridObj(int n) {
  std::string obj;
  obj.reserve(static_cast<size_t>(n + 1) * (n + 1) * 90 + static_cast<size_t>(n) * n * 60);
  for (int y = 0; y <= n; ++y) {
    for (int x = 0; x <= n; ++x) {
      obj += fmt::format("v {:.6f} {:.6f} {:.6f}\nvt {:.6f} {:.6f}\nvn 0 0 1\n", x / double(n), y / double(n),
                         0.01 * ((x * 7 + y * 13) % 17), x / double(n), y / double(n));
    }
  }
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const int a = y * (n + 1) + x + 1, b = a + 1, c = a + n + 2, d = a + n + 1;
      obj += fmt::format("f {0}/{0}/{0} {1}/{1}/{1} {2}/{2}/{2} {3}/{3}/{3}\n", a, b, c, d);
    }
  }
  return obj;
}

struct Outcome {
  bool ok = false;
  size_t triangles = 0;
  std::string message;  // error, or warnings on success
};

Outcome Ours(const std::string& text, const std::string& name) {
  auto data = solid::convert::ReadObj(
      std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size()), name);
  Outcome out;
  if (!data.ok()) {
    out.message = data.status().ToString();
    return out;
  }
  out.ok = true;
  for (const auto& block : data->blocks) out.triangles += block.triangles.size();
  return out;
}

Outcome Theirs(const std::string& text) {
  tinyobj::ObjReader reader;
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  Outcome out;
  out.ok = reader.ParseFromString(text, "", config);
  out.message = reader.Error() + reader.Warning();
  while (!out.message.empty() && out.message.back() == '\n') out.message.pop_back();
  for (const auto& shape : reader.GetShapes()) out.triangles += shape.mesh.num_face_vertices.size();
  return out;
}

using solid::bench::BestMs;

void Time(const std::string& label, const std::string& text, int repeat) {
  const Outcome ours = Ours(text, label), theirs = Theirs(text);
  const double ours_ms = BestMs(repeat, [&] { Ours(text, label); });
  const double theirs_ms = BestMs(repeat, [&] { Theirs(text); });
  const double mb = text.size() / 1e6;
  fmt::print("{:<70} {:>7.2f} MB  ours {:>8.2f} ms ({:>6.1f} MB/s, {} tri{})  tinyobjloader {:>8.2f} ms ({:>6.1f} MB/s, "
             "{} tri{})\n",
             label, mb, ours_ms, mb / ours_ms * 1e3, ours.triangles, ours.ok ? "" : ", FAILED", theirs_ms,
             mb / theirs_ms * 1e3, theirs.triangles, theirs.ok ? "" : ", FAILED");
}

// Malformed inputs a converter meets, each with what a correct reader must do.
struct BadCase {
  const char* what;
  const char* obj;
};
constexpr BadCase kBadCases[] = {
    {"face index past the vertices", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n"},
    {"face index 0", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"},
    {"garbage in a coordinate", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n"},
    {"NaN coordinate", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"},
    {"overflowing coordinate", "v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n"},
    {"negative index before any vertex", "f -1 -2 -3\nv 0 0 0\n"},
    {"corner with an empty index", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/ 2// /3\n"},
    {"truncated vertex", "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n"},
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"OBJ reading: convert/obj_reader.cpp vs tinyobjloader"};
  int repeat = 5;
  int grid = 1000;
  std::vector<std::string> files;
  app.add_option("--repeat", repeat, "timed runs per input (the best is shown)")->check(CLI::PositiveNumber);
  app.add_option("--grid", grid, "side of the generated quad grid (grid^2 quads)")->check(CLI::PositiveNumber);
  app.add_option("files", files, "OBJ files to time (read into memory first)");
  CLI11_PARSE(app, argc, argv);

  fmt::print("== speed (best of {}, from memory, triangulated)\n", repeat);
  for (const std::string& path : files) Time(path, ReadText(path), repeat);
  Time(fmt::format("generated {0}x{0} quad grid (v/vt/vn)", grid), GridObj(grid), repeat);

  fmt::print("\n== malformed input: what each reader says\n");
  for (const BadCase& bad : kBadCases) {
    const Outcome ours = Ours(bad.obj, "bad.obj"), theirs = Theirs(bad.obj);
    fmt::print("-- {}\n   ours:          {}\n   tinyobjloader: {} ({} triangles){}\n", bad.what,
               ours.ok ? fmt::format("accepted ({} triangles)", ours.triangles) : ours.message,
               theirs.ok ? "accepted" : "refused", theirs.triangles,
               theirs.message.empty() ? "" : ": " + theirs.message);
  }
  return 0;
}
