// Top-level Embree scenes of instances, shared by the mask pass and the shading
// passes (internal to solid::render).
#pragma once

#include <embree3/rtcore.h>

#include <limits>
#include <span>

#include "solid/render/layout.h"

namespace solid::render {

// A ray from `origin` along `direction` over [tnear, +inf), with no hit yet.
inline RTCRayHit MakeRay(Vec3 origin, Vec3 direction, float tnear) {
  RTCRayHit r{};
  r.ray.org_x = static_cast<float>(origin.x);
  r.ray.org_y = static_cast<float>(origin.y);
  r.ray.org_z = static_cast<float>(origin.z);
  r.ray.dir_x = static_cast<float>(direction.x);
  r.ray.dir_y = static_cast<float>(direction.y);
  r.ray.dir_z = static_cast<float>(direction.z);
  r.ray.tnear = tnear;
  r.ray.tfar = std::numeric_limits<float>::infinity();
  r.ray.mask = UINT32_MAX;
  r.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  r.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  return r;
}

// One instance of a bottom-level scene.
struct SceneInstance {
  RTCScene scene = nullptr;
  Affine3x4 world_from_object = kIdentityAffine;
};

// A committed top-level scene whose instance id k is instances[k].
class ObjectScene {
 public:
  // The layout's objects, instance id = placement index.
  ObjectScene(RTCDevice device, const Layout& layout);
  ObjectScene(RTCDevice device, std::span<const SceneInstance> instances);
  ~ObjectScene() { rtcReleaseScene(scene_); }
  ObjectScene(const ObjectScene&) = delete;
  ObjectScene& operator=(const ObjectScene&) = delete;
  RTCScene get() const { return scene_; }

 private:
  RTCScene scene_;
};

}  // namespace solid::render
