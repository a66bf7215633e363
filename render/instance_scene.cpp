#include "instance_scene.h"

#include <vector>

namespace solid::render {

namespace {

std::vector<SceneInstance> LayoutInstances(const Layout& layout) {
  std::vector<SceneInstance> out;
  out.reserve(layout.objects.size());
  for (const PlacedObject& o : layout.objects) {
    out.push_back({reinterpret_cast<RTCScene>(o.asset->scene()), o.WorldFromObject()});
  }
  return out;
}

}  // namespace

ObjectScene::ObjectScene(RTCDevice device, const Layout& layout)
    : ObjectScene(device, LayoutInstances(layout)) {}

ObjectScene::ObjectScene(RTCDevice device, std::span<const SceneInstance> instances) : scene_(rtcNewScene(device)) {
  for (size_t k = 0; k < instances.size(); ++k) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(g, instances[k].scene);
    float m[12];
    for (int i = 0; i < 12; ++i) m[i] = static_cast<float>(instances[k].world_from_object[i]);
    rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, m);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(scene_, g, static_cast<unsigned>(k));
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(scene_);
}

}  // namespace solid::render
