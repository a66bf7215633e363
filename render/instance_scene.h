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

// Lane i of a 16-wide packet: a ray from `origin` along `direction` over [tnear, tfar].
// V: Vec3 or Vec3f. Always inlined: a copy kept out of line in the shader's AVX-512 kernels
// could be the one every caller links to (film_kernels.h).
template <class V>
[[gnu::always_inline]] inline void SetRayLane(RTCRay16* r, int i, V origin, V direction, float tnear,
                float tfar = std::numeric_limits<float>::infinity()) {
  r->org_x[i] = static_cast<float>(origin.x);
  r->org_y[i] = static_cast<float>(origin.y);
  r->org_z[i] = static_cast<float>(origin.z);
  r->dir_x[i] = static_cast<float>(direction.x);
  r->dir_y[i] = static_cast<float>(direction.y);
  r->dir_z[i] = static_cast<float>(direction.z);
  r->tnear[i] = tnear;
  r->tfar[i] = tfar;
  r->time[i] = 0;
  r->mask[i] = UINT32_MAX;
  r->id[i] = 0;
  r->flags[i] = 0;
}

// rtcIntersect16 and rtcOccluded16 on the lanes where `valid` is -1, on any CPU. Embree traces a
// 16-wide packet natively only on AVX-512; elsewhere (AVX2) its ray-stream path ignores `valid`,
// traces every lane whose tnear <= tfar, and asserts on one that holds no finite ray (Debian's
// build keeps the assertion: every cross-row fit aborted on an AVX2 EPYC). So the other lanes
// become empty intervals first; their ray and hit data are not to be read afterwards.
inline void DeactivateInvalidLanes(const int* valid, RTCRay16* r) {
  for (int i = 0; i < 16; ++i) {
    if (valid[i]) continue;
    r->tnear[i] = std::numeric_limits<float>::infinity();
    r->tfar[i] = -std::numeric_limits<float>::infinity();
  }
}
inline void Intersect16(const int* valid, RTCScene scene, RTCIntersectContext* context, RTCRayHit16* rays) {
  DeactivateInvalidLanes(valid, &rays->ray);
  rtcIntersect16(valid, scene, context, rays);
}
inline void Occluded16(const int* valid, RTCScene scene, RTCIntersectContext* context, RTCRay16* rays) {
  DeactivateInvalidLanes(valid, rays);
  rtcOccluded16(valid, scene, context, rays);
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
