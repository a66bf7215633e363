// The background of a layout in world coordinates (metres, Z up), with what the
// layout sampler asks of it: which lattice columns a floor covers, floor and ceiling
// heights, and whether a box touches the shell (solid-method.md 2.1, 2.2, D2).
//
// Rooms: only walls, floors and ceilings are kept (D12) and scaled together,
// non-uniformly, to exactly room_size_m, centred at x = y = 0 with the floor at z = 0.
// White cube: a 12 x 12 m floor at z = 0 inside a 12 x 12 x 24 m cube centred at the
// origin whose top face, at z = 12, is the ceiling (D14: no second, coplanar ceiling).
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "solid/render/assets.h"
#include "solid/render/geometry.h"
#include "solid/render/params.h"

namespace solid::render {

class RoomShell {
 public:
  // kInvalidArgument when the room has no floor, or its shell has no extent on an axis.
  static Result<std::shared_ptr<const RoomShell>> FromAsset(std::shared_ptr<const LoadedAsset> room,
                                                            std::shared_ptr<Device> device,
                                                            const LayoutParams& params);
  static Result<std::shared_ptr<const RoomShell>> WhiteCube(std::shared_ptr<Device> device,
                                                            const LayoutParams& params);
  ~RoomShell();
  RoomShell(const RoomShell&) = delete;
  RoomShell& operator=(const RoomShell&) = delete;

  const std::string& key() const { return key_; }  // the room's catalog key, or "white_cube"
  const MeshGeometry& mesh() const { return mesh_; }  // world coordinates
  const std::vector<gltf::Material>& materials() const { return materials_; }
  const std::vector<gltf::Texture>& textures() const;

  // The lattice (params.grid_*): point (i, j, k) of n = points() per axis.
  int points() const { return n_; }
  double X(int i) const { return x0_ + step_[0] * i; }
  double Y(int j) const { return y0_ + step_[1] * j; }
  double Z(int k) const { return step_[2] * k; }
  // Column (i, j) lies over a floor; floor height is the highest z of the covering floor
  // triangles, ceiling height the middle z of the lowest covering ceiling triangle
  // (the shell's top where none covers).
  bool Covered(int i, int j) const { return floor_z_[Cell(i, j)] == floor_z_[Cell(i, j)]; }  // not NaN
  double FloorZ(int i, int j) const { return floor_z_[Cell(i, j)]; }
  double CeilingZ(int i, int j) const { return ceiling_z_[Cell(i, j)]; }
  // The highest lattice level k at or below the ceiling of some covered column (at most
  // points() - 1): floating objects are placed on levels 0..TopLevel().
  int TopLevel() const { return top_level_; }
  // The covered columns (i, j) whose horizontal distance from the origin lies in
  // params.camera_ring_m, row by row: where cameras stand (solid-method.md 2.3). Computed
  // once per shell, not per layout draw.
  const std::vector<std::pair<int, int>>& CameraColumns() const { return camera_columns_; }
  // The nearest lattice column of (x, y), or false outside the lattice.
  bool ColumnOf(double x, double y, int* i, int* j) const;

  // Every corner of `box` lies inside the lattice box, over a covered column, between
  // its floor and ceiling.
  bool InsideValidVolume(const Obb& box) const;
  // `box` intersects (or touches) a wall, floor or ceiling triangle. Always false for
  // the white cube, which the reference never tests (its faces bound the lattice).
  bool TouchesShell(const Obb& box) const;

  const std::shared_ptr<Device>& device() const { return device_; }
  RTCSceneTy* scene() const { return scene_; }        // every piece; primitive ids index mesh()
  RTCSceneTy* walls_scene() const { return walls_; }  // walls only (camera clearance)

 private:
  RoomShell() = default;
  size_t Cell(int i, int j) const { return static_cast<size_t>(j) * n_ + i; }
  Status Finish(const std::shared_ptr<Device>& device, const LayoutParams& params);

  std::string key_;
  std::shared_ptr<const LoadedAsset> source_;  // textures of asset rooms
  MeshGeometry mesh_;
  std::vector<gltf::Material> materials_;
  bool test_shell_ = true;
  int n_ = 0;
  double x0_ = 0, y0_ = 0;
  std::array<double, 3> step_ = {0, 0, 0};
  std::vector<double> floor_z_, ceiling_z_;
  int top_level_ = 0;
  std::vector<std::pair<int, int>> camera_columns_;
  // Uniform grid over the shell's triangles for TouchesShell.
  Vec3 grid_min_;
  double grid_cell_ = 1;
  std::array<int, 3> grid_dims_ = {0, 0, 0};
  std::vector<std::vector<uint32_t>> grid_;
  std::vector<uint32_t> wall_indices_;  // shared with walls_
  std::shared_ptr<Device> device_;
  RTCSceneTy* scene_ = nullptr;
  RTCSceneTy* walls_ = nullptr;
};

}  // namespace solid::render
