#include "solid/render/layout.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "solid/formats/random.h"
#include "placement.h"
#include "room.h"
#include "streams.h"

namespace solid::render {

namespace {

constexpr double kPi = std::numbers::pi;

Mat3 CameraRotation(const Camera& c) {
  const auto& a = c.world_from_camera;
  return Mat3{{a[0], a[1], a[2], a[4], a[5], a[6], a[8], a[9], a[10]}};
}

}  // namespace

bool LookAt(Vec3 eye, Vec3 target, double hfov_deg, int width, int height, Camera* camera) {
  const Vec3 forward = target - eye;
  const double horizontal = std::hypot(forward.x, forward.y);
  if (horizontal < 1e-9 * Length(forward) || Length(forward) == 0) return false;
  const Vec3 f = Normalize(forward);
  const Vec3 right = Normalize(Cross(f, {0, 0, 1}));
  const Vec3 up = Cross(right, f);
  camera->fx = camera->fy = (width / 2.0) / std::tan(hfov_deg * kPi / 360.0);
  camera->cx = width / 2.0;
  camera->cy = height / 2.0;
  camera->world_from_camera = {right.x, up.x, -f.x, eye.x, right.y, up.y, -f.y, eye.y, right.z, up.z, -f.z, eye.z};
  return true;
}

Vec3 CameraPosition(const Camera& camera) {
  const auto& a = camera.world_from_camera;
  return {a[3], a[7], a[11]};
}

bool Project(const Camera& camera, Vec3 p, double near, double* u, double* v) {
  const Vec3 local = CameraRotation(camera).Transposed() * (p - CameraPosition(camera));
  if (!(-local.z > near)) return false;
  *u = camera.cx + camera.fx * local.x / -local.z;
  *v = camera.cy - camera.fy * local.y / -local.z;
  return true;
}

Result<std::unique_ptr<LayoutSampler>> LayoutSampler::Create(const LayoutParams& params,
                                                             std::shared_ptr<AssetLibrary> library) {
  SOLID_RETURN_IF_ERROR(CheckParams(params, "params"));
  if (library->models().empty()) {
    return InvalidArgumentError("the assets directory has no usable model (kind \"model\", status ok)");
  }
  std::unique_ptr<LayoutSampler> s(new LayoutSampler());
  s->params_ = params;
  s->library_ = std::move(library);
  if (params.scene == SceneKind::kWhiteCube) {
    SOLID_ASSIGN_OR_RETURN(s->white_cube_, RoomShell::WhiteCube(s->library_->device(), params));
  } else if (s->library_->rooms().empty()) {
    return InvalidArgumentError("scene.kind is \"rooms\" but the rooms directory has no usable room; give one "
                                "that convert::Convert made from procedural or SceneNet rooms");
  }
  return s;
}

Result<std::shared_ptr<const RoomShell>> LayoutSampler::Shell(size_t room_index) const {
  {
    std::lock_guard lock(rooms_mutex_);
    const auto it = rooms_.find(room_index);
    if (it != rooms_.end()) return it->second;
  }
  SOLID_ASSIGN_OR_RETURN(std::shared_ptr<const LoadedAsset> asset, library_->Room(room_index));
  SOLID_ASSIGN_OR_RETURN(std::shared_ptr<const RoomShell> shell,
                         RoomShell::FromAsset(std::move(asset), library_->device(), params_));
  std::lock_guard lock(rooms_mutex_);
  return rooms_.emplace(room_index, std::move(shell)).first->second;
}

namespace {

// Everything one layout draw needs while placing objects (placement.h says how a pose
// try draws).
class Placer {
 public:
  Placer(const LayoutParams& p, const RoomShell& room, const Camera& camera)
      : p_(p),
        room_(room),
        camera_(camera),
        eye_(CameraPosition(camera)),
        k_max_(room.TopLevel()),
        floor_(p.support == Support::kFloor),
        candidates_(ListCandidates(p, room, camera)) {}

  // One pose try: a centre for a box of `half` extents and `rotation`, or false. The
  // proposals draw from `rng` alone.
  bool TryPlace(const Mat3& rotation, Vec3 half, double size_m, bool cluster, bool occlude, bool depth_by_size,
                const std::vector<PlacedObject>& placed, Rng& rng, Vec3* centre, int64_t* proposals) {
    const int n = room_.points();
    // Cluster balls and the lattice cubes (squares for floor support) around them.
    cubes_.Clear();
    uint64_t total = 0;
    if (cluster) {
      for (const PlacedObject& o : placed) {
        const Vec3 c = o.box.center;
        const double r = o.box.HalfDiagonal() + p_.cluster_margin_m;
        int lo[3], hi[3];
        auto range = [&](double x, double origin, double step, int axis) {
          lo[axis] = std::max(0, static_cast<int>(std::ceil((x - r - origin) / step)));
          hi[axis] = std::min(n - 1, static_cast<int>(std::floor((x + r - origin) / step)));
        };
        range(c.x, room_.X(0), room_.X(1) - room_.X(0), 0);
        range(c.y, room_.Y(0), room_.Y(1) - room_.Y(0), 1);
        if (floor_) {
          lo[2] = hi[2] = 0;
        } else {
          range(c.z, 0, room_.Z(1), 2);
          hi[2] = std::min(hi[2], k_max_);
        }
        if (lo[0] > hi[0] || lo[1] > hi[1] || lo[2] > hi[2]) continue;
        total += cubes_.Add(c, r, lo, hi);
      }
      if (cubes_.size() == 0) return false;
    }
    const double zhalf = std::fabs(rotation(2, 0)) * half.x + std::fabs(rotation(2, 1)) * half.y +
                         std::fabs(rotation(2, 2)) * half.z;
    if (occlude) ProjectPlaced(placed);
    const Pose pose{rotation, half, zhalf, size_m, cluster, occlude, depth_by_size};
    const std::vector<LatticePoint>& candidates = floor_ ? FloorCandidates(zhalf) : candidates_.points;
    const auto lattice = static_cast<uint64_t>(n) * static_cast<uint64_t>(n) *
                         (floor_ ? 1 : static_cast<uint64_t>(k_max_) + 1);
    const uint64_t drawn_from = cluster ? total : lattice;
    if (candidates.size() > drawn_from) return ProposeFromCubes(total, pose, placed, rng, centre, proposals);
    return ProposeCandidates(candidates, drawn_from, pose, placed, rng, centre, proposals);
  }

 private:
  struct Pose {
    const Mat3& rotation;
    Vec3 half;
    double zhalf;  // half the box's vertical extent
    double size_m;
    bool cluster, occlude, depth_by_size;
  };

  const std::vector<LatticePoint>& FloorCandidates(double zhalf) {
    floor_points_.clear();
    for (const FloorColumn& c : candidates_.floor_columns) {
      if (c.lo <= zhalf && zhalf <= c.hi) floor_points_.push_back({c.i, c.j, 0});
    }
    return floor_points_;
  }

  bool ProposeCandidates(const std::vector<LatticePoint>& candidates, uint64_t drawn_from, const Pose& pose,
                         const std::vector<PlacedObject>& placed, Rng& rng, Vec3* centre, int64_t* proposals) {
    if (candidates.empty()) {
      *proposals += p_.max_proposals;
      return false;
    }
    int64_t spent = 0;
    const bool placed_it = DrawCandidates(
        candidates.size(), drawn_from, p_.max_proposals, rng,
        [&](uint64_t index) {
          const LatticePoint& c = candidates[index];
          // A candidate outside every cube is a point the cubes never draw.
          if (pose.cluster && cubes_.Containing(c.i, c.j, c.k) == 0) return false;
          return Accept(c.i, c.j, c.k, pose, placed, centre);
        },
        &spent);
    *proposals += spent;
    return placed_it;
  }

  // The try's draws one by one from the cluster cubes, when they hold fewer points than
  // the candidates: uniform over the union of the cubes (a cube by its size, a point in
  // it, kept with probability 1 / the cubes containing it).
  bool ProposeFromCubes(uint64_t total, const Pose& pose, const std::vector<PlacedObject>& placed, Rng& rng,
                        Vec3* centre, int64_t* proposals) {
    const IndexRange total_range(total);
    for (int attempt = 0; attempt < p_.max_proposals; ++attempt) {
      ++*proposals;
      uint64_t pick = rng.Index(total_range);
      size_t b = 0;
      while (pick >= cubes_.count[b]) pick -= cubes_.count[b++];
      const int i = cubes_.lo[0][b] + static_cast<int>(rng.Index(cubes_.extent[0][b]));
      const int j = cubes_.lo[1][b] + static_cast<int>(rng.Index(cubes_.extent[1][b]));
      const int k = cubes_.lo[2][b] + static_cast<int>(rng.Index(cubes_.extent[2][b]));
      const int containing = cubes_.Containing(i, j, k);
      if (containing > 1 && !rng.Chance(1.0 / containing)) continue;
      if (Accept(i, j, k, pose, placed, centre)) return true;
    }
    return false;
  }

  // Every test of a drawn lattice point, camera tests first.
  bool Accept(int i, int j, int k, const Pose& pose, const std::vector<PlacedObject>& placed, Vec3* centre) {
    if (!room_.Covered(i, j)) return false;
    const Vec3 c{room_.X(i), room_.Y(j), floor_ ? room_.FloorZ(i, j) + pose.zhalf + kFloorGap : room_.Z(k)};
    if (!floor_ && (c.z < room_.FloorZ(i, j) || c.z > room_.CeilingZ(i, j))) return false;
    double u = 0, v = 0;
    if (!Project(camera_, c, p_.camera_near_m, &u, &v)) return false;
    if (std::fabs(u - camera_.cx) > p_.frustum_inset * camera_.cx ||
        std::fabs(v - camera_.cy) > p_.frustum_inset * camera_.cy) {
      return false;
    }
    if (!(std::hypot(c.x - eye_.x, c.y - eye_.y) > p_.min_hdist_m)) return false;
    if (pose.cluster && !cubes_.NearSome(c)) return false;
    if (pose.occlude && !Occludes(c, u, v, placed)) return false;
    if (pose.depth_by_size && !InDepthBand(c, pose.size_m, placed)) return false;
    const Obb box{c, pose.rotation, pose.half};
    if (!room_.InsideValidVolume(box)) return false;
    for (const PlacedObject& o : placed) {
      if (Intersects(box, o.box)) return false;
    }
    if (room_.TouchesShell(box)) return false;
    *centre = c;
    return true;
  }

  // The cluster balls of a pose try and their lattice cubes, as arrays: every proposal
  // counts the cubes that contain it, a loop the compiler vectorizes over these.
  struct Cubes {
    std::vector<Vec3> centre;
    std::vector<double> radius;
    std::array<std::vector<int>, 3> lo, hi;
    std::array<std::vector<IndexRange>, 3> extent;
    std::vector<uint64_t> count;

    size_t size() const { return count.size(); }
    void Clear() {
      centre.clear();
      radius.clear();
      count.clear();
      for (int a = 0; a < 3; ++a) {
        lo[a].clear();
        hi[a].clear();
        extent[a].clear();
      }
    }
    uint64_t Add(Vec3 c, double r, const int* low, const int* high) {
      centre.push_back(c);
      radius.push_back(r);
      uint64_t cells = 1;
      for (int a = 0; a < 3; ++a) {
        lo[a].push_back(low[a]);
        hi[a].push_back(high[a]);
        extent[a].emplace_back(static_cast<uint64_t>(high[a] - low[a] + 1));
        cells *= static_cast<uint64_t>(high[a] - low[a] + 1);
      }
      count.push_back(cells);
      return cells;
    }
    int Containing(int i, int j, int k) const {
      int containing = 0;
      const size_t m = size();
      const int *i0 = lo[0].data(), *i1 = hi[0].data(), *j0 = lo[1].data(), *j1 = hi[1].data(),
                *k0 = lo[2].data(), *k1 = hi[2].data();
      for (size_t o = 0; o < m; ++o) {
        containing += (i >= i0[o]) & (i <= i1[o]) & (j >= j0[o]) & (j <= j1[o]) & (k >= k0[o]) & (k <= k1[o]);
      }
      return containing;
    }
    bool NearSome(Vec3 c) const {
      for (size_t b = 0; b < size(); ++b) {
        if (Length(c - centre[b]) < radius[b]) return true;
      }
      return false;
    }
  };

  // The image box of each placed object whose corners all lie beyond the near plane, once
  // per pose try: the occlusion tests of its thousands of proposals then skip most objects
  // at the cost of a comparison (see Occludes).
  struct ImageBox {
    bool valid = false;
    double u0 = 0, u1 = 0, v0 = 0, v1 = 0;
  };
  void ProjectPlaced(const std::vector<PlacedObject>& placed) {
    image_boxes_.assign(placed.size(), {});
    for (size_t i = 0; i < placed.size(); ++i) {
      ImageBox b{true, 1e300, -1e300, 1e300, -1e300};
      for (int k = 0; k < 8 && b.valid; ++k) {
        double cu = 0, cv = 0;
        b.valid = Project(camera_, placed[i].box.Corner(k), p_.camera_near_m, &cu, &cv);
        b.u0 = std::min(b.u0, cu);
        b.u1 = std::max(b.u1, cu);
        b.v0 = std::min(b.v0, cv);
        b.v1 = std::max(b.v1, cv);
      }
      image_boxes_[i] = b;
    }
  }

  // (u, v): c's projection. An object beyond the near plane lies in the convex hull of its
  // corners, which projects inside their image box; so when (u, v) is outside it (by more
  // than rounding: kSlackPx), no point of the ray through c in front of the camera meets
  // the object, and both tests below are false for it: skipping it changes no result.
  bool Occludes(Vec3 c, double u, double v, const std::vector<PlacedObject>& placed) const {
    constexpr double kSlackPx = 1e-6;
    for (size_t i = 0; i < placed.size(); ++i) {
      const PlacedObject& o = placed[i];
      const ImageBox& b = image_boxes_[i];
      if (b.valid && (u < b.u0 - kSlackPx || u > b.u1 + kSlackPx || v < b.v0 - kSlackPx || v > b.v1 + kSlackPx)) {
        continue;
      }
      if (p_.occlusion_test == OcclusionTest::kRayObb) {
        // The half-line from the camera through c, t > 0; c is at t = 1.
        double t0 = 0, t1 = 0;
        if (!RayInterval(eye_, c - eye_, o.box, &t0, &t1) || t1 <= 0) continue;
        if (p_.occlude_side == OccludeSide::kAny || (p_.occlude_side == OccludeSide::kFront && t0 > 1) ||
            (p_.occlude_side == OccludeSide::kBehind && t1 < 1)) {
          return true;
        }
      } else {
        double u = 0, v = 0;
        if (!Project(camera_, c, p_.camera_near_m, &u, &v)) return false;
        double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
        bool all_in_front = true;
        for (int k = 0; k < 8 && all_in_front; ++k) {
          double cu = 0, cv = 0;
          all_in_front = Project(camera_, o.box.Corner(k), p_.camera_near_m, &cu, &cv);
          u0 = std::min(u0, cu);
          u1 = std::max(u1, cu);
          v0 = std::min(v0, cv);
          v1 = std::max(v1, cv);
        }
        if (!all_in_front || u < u0 || u > u1 || v < v0 || v > v1) continue;
        const double dc = Length(c - eye_), doj = Length(o.box.center - eye_);
        if (p_.occlude_side == OccludeSide::kAny || (p_.occlude_side == OccludeSide::kFront && dc < doj) ||
            (p_.occlude_side == OccludeSide::kBehind && dc > doj)) {
          return true;
        }
      }
    }
    return false;
  }

  // Larger objects sit farther: the camera distance of c lies strictly between those
  // of the placed objects with the next smaller and the next larger size.
  bool InDepthBand(Vec3 c, double size_m, const std::vector<PlacedObject>& placed) const {
    const PlacedObject* smaller = nullptr;
    const PlacedObject* larger = nullptr;
    for (const PlacedObject& o : placed) {
      if (o.size_m < size_m && (smaller == nullptr || o.size_m > smaller->size_m)) smaller = &o;
      if (o.size_m > size_m && (larger == nullptr || o.size_m < larger->size_m)) larger = &o;
    }
    const double d = Length(c - eye_);
    if (smaller != nullptr && !(d > Length(smaller->box.center - eye_))) return false;
    if (larger != nullptr && !(d < Length(larger->box.center - eye_))) return false;
    return true;
  }

  const LayoutParams& p_;
  const RoomShell& room_;
  const Camera& camera_;
  Vec3 eye_;
  int k_max_;
  bool floor_;
  PlacementCandidates candidates_;
  std::vector<LatticePoint> floor_points_;  // of the pose try in progress
  Cubes cubes_;                             // of the pose try in progress
  std::vector<ImageBox> image_boxes_;     // of `placed`, for the pose try in progress
};

// Camera draws (solid-method.md 2.3, D9): a floor-covered lattice column in the ring,
// a height above that column's floor, a look-at point, and in rooms a clearance test.
bool SampleCamera(const LayoutParams& p, const RoomShell& room, bool test_walls, Rng& rng, Camera* camera,
                  int* draws) {
  const std::vector<std::pair<int, int>>& ring = room.CameraColumns();
  if (ring.empty()) return false;
  RTCScene walls = reinterpret_cast<RTCScene>(room.walls_scene());
  for (*draws = 1; *draws <= p.camera_max_draws; ++*draws) {
    const auto [i, j] = ring[rng.Index(ring.size())];
    const double h0 = std::max(p.camera_height_m.lo, room.FloorZ(i, j) + 0.001);
    const double z = rng.Uniform(h0, p.camera_height_m.hi);
    const Vec3 target{rng.Uniform(p.camera_look_xy_m.lo, p.camera_look_xy_m.hi),
                      rng.Uniform(p.camera_look_xy_m.lo, p.camera_look_xy_m.hi),
                      rng.Uniform(p.camera_look_z_m.lo, p.camera_look_z_m.hi)};
    if (h0 > p.camera_height_m.hi || z > room.CeilingZ(i, j)) continue;
    const Vec3 eye{room.X(i), room.Y(j), z};
    if (!LookAt(eye, target, p.camera_hfov_deg, p.width, p.height, camera)) continue;
    if (!test_walls) return true;
    bool clear = true;
    const int m = p.camera_clearance_rays;
    for (int b = 0; b < m && clear; ++b) {
      for (int a = 0; a < m && clear; ++a) {
        const double u = m == 1 ? p.width / 2.0 : p.width * a / double(m - 1);
        const double v = m == 1 ? p.height / 2.0 : p.height * b / double(m - 1);
        const Vec3 d = Normalize(RayDirection(*camera, u, v));
        RTCRay ray{};
        ray.org_x = static_cast<float>(eye.x);
        ray.org_y = static_cast<float>(eye.y);
        ray.org_z = static_cast<float>(eye.z);
        ray.dir_x = static_cast<float>(d.x);
        ray.dir_y = static_cast<float>(d.y);
        ray.dir_z = static_cast<float>(d.z);
        ray.tnear = 0;
        ray.tfar = static_cast<float>(p.camera_clearance_m);
        ray.mask = UINT32_MAX;
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        rtcOccluded1(walls, &context, &ray);
        clear = ray.tfar >= 0;  // Embree sets tfar to -inf on a hit
      }
    }
    if (clear) return true;
  }
  *draws = p.camera_max_draws;
  return false;
}

Mat3 SampleRotation(const LayoutParams& p, Rng& rng) {
  if (p.rotation_axes == RotationAxes::kZ) return RotationEulerXyz(0, 0, rng.Uniform(-kPi, kPi));
  const double x = rng.Uniform(-kPi, kPi), y = rng.Uniform(-kPi, kPi), z = rng.Uniform(-kPi, kPi);
  return RotationEulerXyz(x, y, z);
}

double SampleSize(const ScaleLaw& law, Rng& rng) {
  if (!law.mixture) return rng.Uniform(law.buckets[0].size_m.lo, law.buckets[0].size_m.hi);
  const double u = rng.Uniform();
  double acc = 0;
  const ScaleBucket* chosen = &law.buckets.back();
  for (const ScaleBucket& b : law.buckets) {
    acc += b.probability;
    if (u < acc) {
      chosen = &b;
      break;
    }
  }
  return rng.Uniform(chosen->size_m.lo, chosen->size_m.hi);
}

}  // namespace

Result<Layout> LayoutSampler::Sample(uint64_t dataset_seed, int64_t index, int restart) const {
  Layout layout;
  layout.index = index;
  layout.seed = MixSeed(dataset_seed, static_cast<uint64_t>(index));
  layout.restart = restart;
  layout.width = params_.width;
  layout.height = params_.height;
  layout.near = params_.camera_near_m;
  const uint64_t draw_seed = MixSeed(layout.seed, static_cast<uint64_t>(restart));

  if (params_.scene == SceneKind::kWhiteCube) {
    layout.room = white_cube_;
  } else {
    Rng room_rng(draw_seed, kRoomStream);
    SOLID_ASSIGN_OR_RETURN(layout.room, Shell(room_rng.Index(library_->rooms().size())));
  }

  Rng camera_rng(draw_seed, kCameraStream);
  if (!SampleCamera(params_, *layout.room, params_.scene == SceneKind::kRooms, camera_rng, &layout.camera,
                    &layout.stats.camera_draws)) {
    layout.rejection = fmt::format("no camera pose in room {} after {} draws (ring, height and clearance)",
                                   layout.room->key(), layout.stats.camera_draws);
    return layout;
  }

  // Each attempt draws its model and poses from its own stream, with a fixed number of
  // draws per pose try, and each try's proposals from another: a knob that changes how
  // many proposals a try takes, or whether it succeeds, leaves every other draw where it
  // was. Nearby parameters then give nearby layouts, which the optimizer's common random
  // numbers rely on.
  Rng count_rng(draw_seed, kObjectStream);
  const auto& models = library_->models();
  const int attempts =
      static_cast<int>(std::floor(count_rng.Uniform(params_.attempts.lo, params_.attempts.hi + 1)));
  layout.stats.attempts = attempts;
  Placer placer(params_, *layout.room, layout.camera);
  size_t previous = SIZE_MAX;
  for (int a = 0; a < attempts; ++a) {
    const uint64_t attempt_seed = MixSeed(draw_seed, static_cast<uint64_t>(a));
    Rng pose_rng(attempt_seed, kObjectStream);
    const bool reuse = pose_rng.Chance(params_.reuse_prob);
    const size_t drawn = pose_rng.Index(models.size());
    const size_t model = previous != SIZE_MAX && reuse ? previous : drawn;
    previous = model;
    SOLID_ASSIGN_OR_RETURN(std::shared_ptr<const LoadedAsset> asset, library_->Model(model));
    const double extent = asset->largest_extent();
    if (!(extent > 0)) return InvalidArgumentError("model " + asset->key() + " has no extent");
    for (int t = 0; t < params_.max_pose_tries; ++t) {
      ++layout.stats.pose_tries;
      const Mat3 rotation = SampleRotation(params_, pose_rng);
      const double size = SampleSize(params_.scale, pose_rng);
      const double scale = size / extent;
      const bool placed_any = !layout.objects.empty();
      const bool cluster = pose_rng.Chance(params_.cluster_prob) && placed_any;
      const bool occlude = pose_rng.Chance(params_.occlude_prob) && placed_any;
      const bool depth = pose_rng.Chance(params_.depth_by_size_prob) && occlude;
      const Vec3 half = asset->half_extents() * scale;
      Rng proposal_rng(MixSeed(attempt_seed, static_cast<uint64_t>(t)), kPlacementStream);
      Vec3 centre;
      if (placer.TryPlace(rotation, half, size, cluster, occlude, depth, layout.objects, proposal_rng, &centre,
                          &layout.stats.proposals)) {
        PlacedObject o;
        o.model_index = model;
        o.model_key = models[model].key;
        o.asset = asset;
        o.rotation = rotation;
        o.size_m = size;
        o.scale = scale;
        o.position = centre;
        o.box = Obb{centre, rotation, half};
        layout.objects.push_back(std::move(o));
        break;
      }
    }
  }
  layout.stats.placed = static_cast<int>(layout.objects.size());
  if (layout.objects.empty()) layout.rejection = fmt::format("no object placed in {} attempts", attempts);
  return layout;
}

}  // namespace solid::render
