// Packets with lanes left out: Embree's 16-wide calls trace such lanes on CPUs without
// AVX-512 unless they are emptied first (instance_scene.h).
#include "instance_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>

namespace solid::render {
namespace {

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();

// One triangle in the plane z = 0 covering (0, 0) to (2, 2), instanced once as instance 0.
class OneTriangle : public ::testing::Test {
 protected:
  void SetUp() override {
    device_ = rtcNewDevice(nullptr);
    ASSERT_NE(device_, nullptr);
    triangle_ = rtcNewScene(device_);
    RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3));
    const float corners[9] = {-1, -1, 0, 3, -1, 0, -1, 3, 0};
    std::copy(corners, corners + 9, v);
    auto* index = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 1));
    index[0] = 0, index[1] = 1, index[2] = 2;
    rtcCommitGeometry(g);
    rtcAttachGeometry(triangle_, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(triangle_);
    const SceneInstance instance{triangle_, kIdentityAffine};
    scene_.emplace(device_, std::span<const SceneInstance>(&instance, 1));
    rtcInitIntersectContext(&context_);
  }
  void TearDown() override {
    scene_.reset();
    rtcReleaseScene(triangle_);
    rtcReleaseDevice(device_);
  }
  // Even lanes valid; every lane a ray down onto the triangle, lane 3 (not valid) no ray at all.
  void Fill(RTCRay16* rays) {
    for (int i = 0; i < 16; ++i) {
      valid_[i] = i % 2 == 0 ? -1 : 0;
      SetRayLane(rays, i, Vec3{0.5, 0.5, 5}, Vec3{0, 0, -1}, 0.0f);
    }
    rays->org_x[3] = rays->dir_z[3] = rays->tnear[3] = kNan;
  }

  RTCDevice device_ = nullptr;
  RTCScene triangle_ = nullptr;
  std::optional<ObjectScene> scene_;
  RTCIntersectContext context_;
  alignas(64) int valid_[16];
};

TEST_F(OneTriangle, Intersect16FindsTheValidLanesHitsAndLeavesTheOthersHitData) {
  alignas(64) RTCRayHit16 rays;
  Fill(&rays.ray);
  for (int i = 0; i < 16; ++i) rays.hit.geomID[i] = rays.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
  Intersect16(valid_, scene_->get(), &context_, &rays);
  for (int i = 0; i < 16; ++i) {
    SCOPED_TRACE(i);
    if (valid_[i]) {
      EXPECT_EQ(rays.hit.instID[0][i], 0u);
      EXPECT_FLOAT_EQ(rays.ray.tfar[i], 5.0f);
    } else {
      EXPECT_EQ(rays.hit.geomID[i], RTC_INVALID_GEOMETRY_ID);
      EXPECT_EQ(rays.hit.instID[0][i], RTC_INVALID_GEOMETRY_ID);
    }
  }
}

TEST_F(OneTriangle, Occluded16AnswersTheValidLanesBesideALaneWithNoRay) {
  alignas(64) RTCRay16 rays;
  Fill(&rays);
  Occluded16(valid_, scene_->get(), &context_, &rays);
  // An occluded lane's tfar is -inf.
  for (int i = 0; i < 16; i += 2) EXPECT_EQ(rays.tfar[i], -std::numeric_limits<float>::infinity()) << i;
}

}  // namespace
}  // namespace solid::render
