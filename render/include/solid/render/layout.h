// The layout sampler: room, camera and object placement of one image, as the SOLID
// paper intends (docs solid-method.md 2, with the fixes of section 3).
//
// Determinism: layout `index` of a dataset with seed S depends only on
// (params, asset set, S, index): its item seed is MixSeed(S, index), restart r uses
// MixSeed(item seed, r), and each concern draws from its own stream of that seed
// (room, camera, objects), so that changing how one is drawn never moves another.
//
// Placement is exact where the reference was not: free space is a separating-axis
// test against every placed box and the room shell (D2, D3); the candidate centre is
// uniform over the lattice points that pass every active constraint, drawn by
// rejection from a superset (the whole valid lattice, or the union of the cluster
// balls of placed objects) with max_proposals draws per pose try. A pose try whose
// candidate set is non-empty but smaller than about 1/max_proposals of that superset
// may therefore be missed; LayoutStats counts the proposals spent. The draws that fail
// the camera's own tests are counted, not made (a geometric count): the same law, at a
// fifth of the cost where clusters are wide (render/placement.h).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "solid/formats/records.h"
#include "solid/render/assets.h"
#include "solid/render/geometry.h"
#include "solid/render/params.h"

namespace solid::render {

// The room a layout stands in, internal to the stage (render/room.h): a library user passes
// it along with its layout but never looks into it.
class RoomShell;

// Pinhole camera for an image of width x height pixels with the given horizontal FOV,
// at `eye` looking at `target` with no roll (its X axis stays horizontal). Camera
// convention as records.h: looks along its -Z, +Y up. False when the view is vertical.
bool LookAt(Vec3 eye, Vec3 target, double hfov_deg, int width, int height, Camera* camera);
// The world-space direction (not normalized) through image point (u, v), in pixels
// from the top-left corner of the image. Inline: the shader asks for three per pixel.
inline Vec3 RayDirection(const Camera& camera, double u, double v) {
  const auto& a = camera.world_from_camera;
  const Vec3 c{(u - camera.cx) / camera.fx, -(v - camera.cy) / camera.fy, -1.0};
  return {a[0] * c.x + a[1] * c.y + a[2] * c.z, a[4] * c.x + a[5] * c.y + a[6] * c.z,
          a[8] * c.x + a[9] * c.y + a[10] * c.z};
}
Vec3 CameraPosition(const Camera& camera);
// Image coordinates of world point p; false when p is not in front of the camera by
// more than `near`.
bool Project(const Camera& camera, Vec3 p, double near, double* u, double* v);

struct PlacedObject {
  size_t model_index = 0;  // into AssetLibrary::models()
  std::string model_key;
  std::shared_ptr<const LoadedAsset> asset;
  Mat3 rotation;
  double size_m = 0;  // s: the largest local extent after scaling
  double scale = 0;   // uniform factor from mesh-local to world
  Vec3 position;      // world position of the mesh-local origin (the bounding-box centre)
  Obb box;            // the placed bounding box
  Affine3x4 WorldFromObject() const { return MakeAffine(rotation, scale, position); }
};

struct LayoutStats {
  int camera_draws = 0;
  int attempts = 0;     // N
  int pose_tries = 0;
  int64_t proposals = 0;
  int placed = 0;
};

struct Layout {
  int64_t index = 0;
  uint64_t seed = 0;  // item seed, MixSeed(dataset seed, index)
  int restart = 0;
  std::shared_ptr<const RoomShell> room;
  Camera camera;
  int width = 0, height = 0;
  double near = 0.1;
  std::vector<PlacedObject> objects;
  LayoutStats stats;
  // Why this draw cannot be used (no camera pose, no object placed); empty when usable.
  std::string rejection;
};

class LayoutSampler {
 public:
  // kInvalidArgument when the params are inconsistent or the library lacks what they
  // need (no models; no rooms for scene "rooms").
  static Result<std::unique_ptr<LayoutSampler>> Create(const LayoutParams& params,
                                                       std::shared_ptr<AssetLibrary> library);

  // One draw of layout `index`, restart `restart`. Errors are those of loading assets;
  // an unusable draw is a Layout with `rejection` set. Thread-safe.
  Result<Layout> Sample(uint64_t dataset_seed, int64_t index, int restart) const;

  const LayoutParams& params() const { return params_; }
  const std::shared_ptr<AssetLibrary>& library() const { return library_; }

 private:
  LayoutSampler() = default;
  Result<std::shared_ptr<const RoomShell>> Shell(size_t room_index) const;

  LayoutParams params_;
  std::shared_ptr<AssetLibrary> library_;
  mutable std::mutex rooms_mutex_;
  mutable std::map<size_t, std::shared_ptr<const RoomShell>> rooms_;
  std::shared_ptr<const RoomShell> white_cube_;
};

}  // namespace solid::render
