#include "room.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include <fmt/format.h>

namespace solid::render {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

RTCScene NewStaticScene(RTCDevice device, const MeshGeometry& mesh, const std::vector<uint32_t>& indices) {
  RTCScene scene = rtcNewScene(device);
  if (indices.empty()) {  // a room without walls: an empty scene, never hit
    rtcCommitScene(scene);
    return scene;
  }
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, mesh.positions.data(), 0,
                             3 * sizeof(float), mesh.VertexCount());
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, indices.data(), 0, 3 * sizeof(uint32_t),
                             indices.size() / 3);
  rtcCommitGeometry(g);
  rtcAttachGeometryByID(scene, g, 0);
  rtcReleaseGeometry(g);
  rtcCommitScene(scene);
  return scene;
}

Vec3 Vertex(const MeshGeometry& m, uint32_t v) {
  return {m.positions[3 * size_t{v}], m.positions[3 * size_t{v} + 1], m.positions[3 * size_t{v} + 2]};
}

// Inclusive 2D point-in-triangle test (either winding).
bool CoversXy(Vec3 a, Vec3 b, Vec3 c, double x, double y) {
  const double d1 = (x - b.x) * (a.y - b.y) - (a.x - b.x) * (y - b.y);
  const double d2 = (x - c.x) * (b.y - c.y) - (b.x - c.x) * (y - c.y);
  const double d3 = (x - a.x) * (c.y - a.y) - (c.x - a.x) * (y - a.y);
  const bool negative = d1 < 0 || d2 < 0 || d3 < 0, positive = d1 > 0 || d2 > 0 || d3 > 0;
  return !(negative && positive);
}

void AddQuad(MeshGeometry& m, Vec3 a, Vec3 b, Vec3 c, Vec3 d, Vec3 normal, Structure structure, double uv_scale) {
  const auto base = static_cast<uint32_t>(m.VertexCount());
  const Vec3 corners[4] = {a, b, c, d};
  const double uvs[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (int k = 0; k < 4; ++k) {
    m.positions.insert(m.positions.end(), {static_cast<float>(corners[k].x), static_cast<float>(corners[k].y),
                                           static_cast<float>(corners[k].z)});
    m.normals.insert(m.normals.end(),
                     {static_cast<float>(normal.x), static_cast<float>(normal.y), static_cast<float>(normal.z)});
    m.uvs.insert(m.uvs.end(), {static_cast<float>(uvs[k][0] * uv_scale), static_cast<float>(uvs[k][1] * uv_scale)});
  }
  m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  for (int t = 0; t < 2; ++t) {
    m.triangle_material.push_back(0);
    m.triangle_structure.push_back(structure);
  }
}

// Floor and ceiling triangles that bound the valid volume (solid-method.md 2.2): facing
// up or down (|n_z| >= 0.9), in edge-connected surfaces of at least 0.1 m^2, so that
// slivers, ledges and sloped pieces marked floor or ceiling do not open columns.
// Edges connect by bit-identical endpoint positions: converters may split vertices
// (per normal or UV) that lie at the same place.
std::vector<bool> LatticeSurfaces(const MeshGeometry& mesh) {
  constexpr double kMinNormalZ = 0.9, kMinArea = 0.1;
  const size_t n = mesh.TriangleCount();
  std::vector<bool> keep(n, false);
  std::vector<double> area(n, 0);
  std::vector<uint32_t> parent(n);
  for (size_t t = 0; t < n; ++t) parent[t] = static_cast<uint32_t>(t);
  auto find = [&](uint32_t t) {
    while (parent[t] != t) t = parent[t] = parent[parent[t]];
    return t;
  };
  using Position = std::array<float, 3>;
  std::map<std::pair<Position, Position>, uint32_t> first_with_edge;
  for (size_t t = 0; t < n; ++t) {
    const Structure s = mesh.triangle_structure[t];
    if (s != Structure::kFloor && s != Structure::kCeiling) continue;
    const Vec3 a = Vertex(mesh, mesh.indices[3 * t]), b = Vertex(mesh, mesh.indices[3 * t + 1]),
               c = Vertex(mesh, mesh.indices[3 * t + 2]);
    const Vec3 normal = Cross(b - a, c - a);
    const double twice_area = Length(normal);
    if (!(twice_area > 0) || std::fabs(normal.z) < kMinNormalZ * twice_area) continue;
    keep[t] = true;
    area[t] = twice_area / 2;
    for (int k = 0; k < 3; ++k) {
      const float* p = &mesh.positions[3 * size_t{mesh.indices[3 * t + k]}];
      const float* q = &mesh.positions[3 * size_t{mesh.indices[3 * t + (k + 1) % 3]}];
      Position u{p[0], p[1], p[2]}, v{q[0], q[1], q[2]};
      if (v < u) std::swap(u, v);
      const auto [it, inserted] = first_with_edge.try_emplace({u, v}, static_cast<uint32_t>(t));
      if (!inserted) parent[find(static_cast<uint32_t>(t))] = find(it->second);
    }
  }
  std::vector<double> surface_area(n, 0);
  for (size_t t = 0; t < n; ++t) {
    if (keep[t]) surface_area[find(static_cast<uint32_t>(t))] += area[t];
  }
  for (size_t t = 0; t < n; ++t) {
    if (keep[t]) keep[t] = surface_area[find(static_cast<uint32_t>(t))] >= kMinArea;
  }
  return keep;
}

}  // namespace

RoomShell::~RoomShell() {
  if (scene_ != nullptr) rtcReleaseScene(reinterpret_cast<RTCScene>(scene_));
  if (walls_ != nullptr) rtcReleaseScene(reinterpret_cast<RTCScene>(walls_));
}

const std::vector<gltf::Texture>& RoomShell::textures() const {
  static const std::vector<gltf::Texture> kNone;
  return source_ != nullptr ? source_->textures() : kNone;
}

Result<std::shared_ptr<const RoomShell>> RoomShell::FromAsset(std::shared_ptr<const LoadedAsset> room,
                                                              std::shared_ptr<Device> device,
                                                              const LayoutParams& params) {
  std::shared_ptr<RoomShell> shell(new RoomShell());
  shell->key_ = room->key();
  const MeshGeometry& in = room->mesh();
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  bool has_floor = false;
  for (size_t t = 0; t < in.TriangleCount(); ++t) {
    if (in.triangle_structure[t] == Structure::kOther) continue;
    has_floor = has_floor || in.triangle_structure[t] == Structure::kFloor;
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = Vertex(in, in.indices[3 * t + k]);
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
  }
  if (!has_floor) {
    return InvalidArgumentError(fmt::format("room {}: no piece with extras.structure \"floor\"; rooms need "
                                            "walls, floors and ceilings marked by convert::Convert",
                                            room->key()));
  }
  const Vec3 size = hi - lo;
  if (!(size.x > 0 && size.y > 0 && size.z > 0)) {
    return InvalidArgumentError(fmt::format("room {}: the shell is flat ({} x {} x {} m)", room->key(), size.x,
                                            size.y, size.z));
  }
  const Vec3 scale{params.room_size_m[0] / size.x, params.room_size_m[1] / size.y, params.room_size_m[2] / size.z};
  const Vec3 centre{(lo.x + hi.x) / 2, (lo.y + hi.y) / 2, lo.z};
  // Keep only shell triangles, with their vertices, rescaled.
  MeshGeometry& m = shell->mesh_;
  std::vector<uint32_t> remap(in.VertexCount(), UINT32_MAX);
  for (size_t t = 0; t < in.TriangleCount(); ++t) {
    if (in.triangle_structure[t] == Structure::kOther) continue;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = in.indices[3 * t + k];
      if (remap[v] == UINT32_MAX) {
        remap[v] = static_cast<uint32_t>(m.VertexCount());
        const Vec3 p = Vertex(in, v);
        m.positions.insert(m.positions.end(), {static_cast<float>((p.x - centre.x) * scale.x),
                                               static_cast<float>((p.y - centre.y) * scale.y),
                                               static_cast<float>((p.z - centre.z) * scale.z)});
        // Normals transform with the inverse transpose of the (diagonal) scale.
        Vec3 n{in.normals[3 * v] / scale.x, in.normals[3 * v + 1] / scale.y, in.normals[3 * v + 2] / scale.z};
        const double len = Length(n);
        if (len > 0) n = n * (1 / len);
        m.normals.insert(m.normals.end(),
                         {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)});
        m.uvs.insert(m.uvs.end(), {in.uvs[2 * v], in.uvs[2 * v + 1]});
      }
      m.indices.push_back(remap[v]);
    }
    m.triangle_material.push_back(in.triangle_material[t]);
    m.triangle_structure.push_back(in.triangle_structure[t]);
  }
  shell->materials_ = room->materials();
  shell->source_ = std::move(room);
  SOLID_RETURN_IF_ERROR(shell->Finish(device, params));
  return std::shared_ptr<const RoomShell>(std::move(shell));
}

Result<std::shared_ptr<const RoomShell>> RoomShell::WhiteCube(std::shared_ptr<Device> device,
                                                              const LayoutParams& params) {
  std::shared_ptr<RoomShell> shell(new RoomShell());
  shell->key_ = "white_cube";
  shell->test_shell_ = false;
  gltf::Material grey;
  grey.name = "white_cube";
  grey.base_color = {0.8f, 0.8f, 0.8f, 1.0f};
  shell->materials_ = {grey};
  MeshGeometry& m = shell->mesh_;
  const double h = 6, top = 12, bottom = -12;
  // Normals face inwards; every face is seen from inside.
  AddQuad(m, {-h, -h, 0}, {h, -h, 0}, {h, h, 0}, {-h, h, 0}, {0, 0, 1}, Structure::kFloor, 12);
  AddQuad(m, {-h, -h, top}, {-h, h, top}, {h, h, top}, {h, -h, top}, {0, 0, -1}, Structure::kCeiling, 12);
  AddQuad(m, {-h, -h, bottom}, {-h, -h, top}, {h, -h, top}, {h, -h, bottom}, {0, 1, 0}, Structure::kWall, 12);
  AddQuad(m, {h, -h, bottom}, {h, -h, top}, {h, h, top}, {h, h, bottom}, {-1, 0, 0}, Structure::kWall, 12);
  AddQuad(m, {h, h, bottom}, {h, h, top}, {-h, h, top}, {-h, h, bottom}, {0, -1, 0}, Structure::kWall, 12);
  AddQuad(m, {-h, h, bottom}, {-h, h, top}, {-h, -h, top}, {-h, -h, bottom}, {1, 0, 0}, Structure::kWall, 12);
  SOLID_RETURN_IF_ERROR(shell->Finish(device, params));
  return std::shared_ptr<const RoomShell>(std::move(shell));
}

Status RoomShell::Finish(const std::shared_ptr<Device>& device, const LayoutParams& params) {
  n_ = params.grid_points_per_axis;
  const auto& e = params.grid_extent_m;
  x0_ = -e[0] / 2;
  y0_ = -e[1] / 2;
  for (int k = 0; k < 3; ++k) step_[k] = e[k] / (n_ - 1);
  floor_z_.assign(static_cast<size_t>(n_) * n_, kNaN);
  ceiling_z_.assign(static_cast<size_t>(n_) * n_, kNaN);
  double top = 0;
  for (size_t v = 0; v < mesh_.VertexCount(); ++v) top = std::max<double>(top, mesh_.positions[3 * v + 2]);

  auto for_columns = [&](Vec3 a, Vec3 b, Vec3 c, auto&& visit) {
    const double min_x = std::min({a.x, b.x, c.x}), max_x = std::max({a.x, b.x, c.x});
    const double min_y = std::min({a.y, b.y, c.y}), max_y = std::max({a.y, b.y, c.y});
    const int i0 = std::max(0, static_cast<int>(std::ceil((min_x - x0_) / step_[0] - 1e-9)));
    const int i1 = std::min(n_ - 1, static_cast<int>(std::floor((max_x - x0_) / step_[0] + 1e-9)));
    const int j0 = std::max(0, static_cast<int>(std::ceil((min_y - y0_) / step_[1] - 1e-9)));
    const int j1 = std::min(n_ - 1, static_cast<int>(std::floor((max_y - y0_) / step_[1] + 1e-9)));
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        if (CoversXy(a, b, c, X(i), Y(j))) visit(Cell(i, j));
      }
    }
  };
  const std::vector<bool> lattice_surface = LatticeSurfaces(mesh_);
  for (size_t t = 0; t < mesh_.TriangleCount(); ++t) {
    const Structure s = mesh_.triangle_structure[t];
    if (!lattice_surface[t]) continue;
    const Vec3 a = Vertex(mesh_, mesh_.indices[3 * t]), b = Vertex(mesh_, mesh_.indices[3 * t + 1]),
               c = Vertex(mesh_, mesh_.indices[3 * t + 2]);
    const double max_z = std::max({a.z, b.z, c.z}), mid_z = (std::min({a.z, b.z, c.z}) + max_z) / 2;
    if (s == Structure::kFloor) {
      for_columns(a, b, c, [&](size_t cell) {
        if (!(floor_z_[cell] >= max_z)) floor_z_[cell] = max_z;  // also replaces NaN
      });
    } else {
      for_columns(a, b, c, [&](size_t cell) {
        if (!(ceiling_z_[cell] <= mid_z)) ceiling_z_[cell] = mid_z;
      });
    }
  }
  for (double& c : ceiling_z_) {
    if (c != c) c = top;
  }
  // Both computed once per shell rather than per layout draw: they visit every column.
  for (int j = 0; j < n_; ++j) {
    for (int i = 0; i < n_; ++i) {
      if (Covered(i, j)) top_level_ = std::max(top_level_, static_cast<int>(std::floor(CeilingZ(i, j) / Z(1))));
      const double r = std::hypot(X(i), Y(j));
      if (Covered(i, j) && r >= params.camera_ring_m.lo && r <= params.camera_ring_m.hi) {
        camera_columns_.emplace_back(i, j);
      }
    }
  }
  top_level_ = std::min(top_level_, n_ - 1);

  // Triangle grid for TouchesShell, over the shell's bounding box.
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (size_t v = 0; v < mesh_.VertexCount(); ++v) {
    const Vec3 p = Vertex(mesh_, static_cast<uint32_t>(v));
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  grid_min_ = lo - Vec3{1e-6, 1e-6, 1e-6};
  grid_cell_ = 0.5;
  for (int k = 0; k < 3; ++k) grid_dims_[k] = std::max(1, static_cast<int>(std::ceil((hi[k] - lo[k]) / grid_cell_)) + 1);
  grid_.assign(static_cast<size_t>(grid_dims_[0]) * grid_dims_[1] * grid_dims_[2], {});
  auto cell_of = [&](double v, int k) {
    return std::clamp(static_cast<int>(std::floor((v - grid_min_[k]) / grid_cell_)), 0, grid_dims_[k] - 1);
  };
  std::vector<uint32_t> wall_indices;
  for (size_t t = 0; t < mesh_.TriangleCount(); ++t) {
    const Vec3 a = Vertex(mesh_, mesh_.indices[3 * t]), b = Vertex(mesh_, mesh_.indices[3 * t + 1]),
               c = Vertex(mesh_, mesh_.indices[3 * t + 2]);
    if (mesh_.triangle_structure[t] == Structure::kWall) {
      wall_indices.insert(wall_indices.end(), &mesh_.indices[3 * t], &mesh_.indices[3 * t] + 3);
    }
    int c0[3], c1[3];
    for (int k = 0; k < 3; ++k) {
      c0[k] = cell_of(std::min({a[k], b[k], c[k]}), k);
      c1[k] = cell_of(std::max({a[k], b[k], c[k]}), k);
    }
    for (int z = c0[2]; z <= c1[2]; ++z) {
      for (int y = c0[1]; y <= c1[1]; ++y) {
        for (int x = c0[0]; x <= c1[0]; ++x) {
          grid_[(static_cast<size_t>(z) * grid_dims_[1] + y) * grid_dims_[0] + x].push_back(static_cast<uint32_t>(t));
        }
      }
    }
  }

  device_ = device;
  RTCDevice dev = device->handle();
  mesh_.positions.reserve(mesh_.positions.size() + 4);  // Embree reads up to 16 bytes past the end
  scene_ = reinterpret_cast<RTCSceneTy*>(NewStaticScene(dev, mesh_, mesh_.indices));
  wall_indices_ = std::move(wall_indices);
  walls_ = reinterpret_cast<RTCSceneTy*>(NewStaticScene(dev, mesh_, wall_indices_));
  if (rtcGetDeviceError(dev) != RTC_ERROR_NONE) return InternalError("room " + key_ + ": Embree scene build failed");
  return Status::Ok();
}

bool RoomShell::ColumnOf(double x, double y, int* i, int* j) const {
  const double fi = std::round((x - x0_) / step_[0]), fj = std::round((y - y0_) / step_[1]);
  if (!(fi >= 0 && fi <= n_ - 1 && fj >= 0 && fj <= n_ - 1)) return false;
  *i = static_cast<int>(fi);
  *j = static_cast<int>(fj);
  return true;
}

bool RoomShell::InsideValidVolume(const Obb& box) const {
  const double x1 = x0_ + step_[0] * (n_ - 1), y1 = y0_ + step_[1] * (n_ - 1), z1 = step_[2] * (n_ - 1);
  for (int c = 0; c < 8; ++c) {
    const Vec3 p = box.Corner(c);
    if (p.x < x0_ || p.x > x1 || p.y < y0_ || p.y > y1 || p.z < 0 || p.z > z1) return false;
    int i = 0, j = 0;
    if (!ColumnOf(p.x, p.y, &i, &j) || !Covered(i, j)) return false;
    if (p.z < FloorZ(i, j) || p.z > CeilingZ(i, j)) return false;
  }
  return true;
}

bool RoomShell::TouchesShell(const Obb& box) const {
  if (!test_shell_) return false;
  int c0[3], c1[3];
  for (int k = 0; k < 3; ++k) {
    const double r = box.WorldHalfExtent(k);
    c0[k] = static_cast<int>(std::floor((box.center[k] - r - grid_min_[k]) / grid_cell_));
    c1[k] = static_cast<int>(std::floor((box.center[k] + r - grid_min_[k]) / grid_cell_));
    if (c1[k] < 0 || c0[k] >= grid_dims_[k]) return false;
    c0[k] = std::max(c0[k], 0);
    c1[k] = std::min(c1[k], grid_dims_[k] - 1);
  }
  for (int z = c0[2]; z <= c1[2]; ++z) {
    for (int y = c0[1]; y <= c1[1]; ++y) {
      for (int x = c0[0]; x <= c1[0]; ++x) {
        for (uint32_t t : grid_[(static_cast<size_t>(z) * grid_dims_[1] + y) * grid_dims_[0] + x]) {
          if (Intersects(box, Vertex(mesh_, mesh_.indices[3 * t]), Vertex(mesh_, mesh_.indices[3 * t + 1]),
                         Vertex(mesh_, mesh_.indices[3 * t + 2]))) {
            return true;
          }
        }
      }
    }
  }
  return false;
}

}  // namespace solid::render
