// The records a dataset stores: target images, their object instances, and
// query views. Field meanings and units are those of schemas/shard.sql and
// schemas/queries.sql, which are normative.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "solid/formats/rle.h"
#include "solid/formats/status.h"

namespace solid {

enum class ImageFormat { kPng, kJpeg, kWebp };
std::string_view ImageFormatName(ImageFormat f);  // "png", "jpeg", "webp"
Result<ImageFormat> ParseImageFormat(std::string_view name);

// COCO size classes by visible-mask area: small < 32^2 <= medium <= 96^2 < large.
enum class ScaleClass { kSmall, kMedium, kLarge };
std::string_view ScaleClassName(ScaleClass c);  // "small", "medium", "large"
Result<ScaleClass> ParseScaleClass(std::string_view name);
// `area_scale`: the area was measured at a resolution with that many times fewer pixels
// than the one the classes are counted at (scale_classes_at, solid-method.md 4.2): it is
// classed as round(visible_area * area_scale).
ScaleClass ScaleClassOfArea(uint64_t visible_area, double area_scale = 1);

// Row-major 3x4 [R | t] affine transform, metres.
using Affine3x4 = std::array<double, 12>;
inline constexpr Affine3x4 kIdentityAffine = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};

struct Camera {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pinhole intrinsics, pixels
  Affine3x4 world_from_camera = kIdentityAffine;  // camera looks along its -Z, +Y up; world Z up
};

struct ImageRecord {
  int64_t image_id = 0;  // dataset-global index
  uint64_t seed = 0;     // the image's own seed, hash(dataset seed, image_id)
  uint32_t width = 0, height = 0;
  ImageFormat format = ImageFormat::kPng;
  std::vector<uint8_t> image;  // encoded bytes
  Camera camera;
  std::optional<std::vector<uint8_t>> depth_exr;  // encoded OpenEXR depth, if rendered
  std::optional<std::string> room_key;
};

// Instances of one image: ordinals lie in [0, kMaxInstancesPerImage). Writers and
// readers of shards refuse more (kLimitExceeded), and so do layout params
// (objects.attempts, each of which places at most one object).
inline constexpr int32_t kMaxInstancesPerImage = 10000;

struct InstanceRecord {
  int64_t image_id = 0;
  int32_t ordinal = 0;  // render-id order within the image
  std::string model_key;
  std::string visible_rle, full_rle;  // COCO compressed RLE strings
  rle::Box visible_box, full_box;
  uint64_t visible_area = 0, full_area = 0;
  std::optional<double> occlusion;  // (full - visible) / full; empty when full_area == 0
  double truncation = 0;            // share of the object outside the frame, [0, 1]
  std::optional<ScaleClass> scale_class;  // empty when visible_area == 0
  Affine3x4 world_from_object = kIdentityAffine;
  double object_scale = 0;     // largest local extent, metres
  double camera_distance = 0;  // metres
  double view_azimuth = 0, view_elevation = 0;  // camera direction in the object frame, radians
};

// Fills the mask-derived fields of `instance` (strings, boxes, areas, occlusion,
// scale class) from its visible and full masks, so that they agree by
// construction. kInvalidArgument when the sizes differ or visible is not
// contained in full. `area_scale` as for ScaleClassOfArea.
Status SetInstanceMasks(const rle::Rle& visible, const rle::Rle& full, InstanceRecord* instance,
                        double area_scale = 1);

// The area-derived fields alone (areas, occlusion, scale class), for a pass that counts
// pixels without keeping masks; agrees with SetInstanceMasks on the same masks.
void SetInstanceAreas(uint64_t visible_area, uint64_t full_area, InstanceRecord* instance, double area_scale = 1);

struct QueryModelRecord {
  std::string model_key;
  int32_t view_count = 0;
  std::optional<std::string> failure;  // why views are missing, if any are
};

struct QueryViewRecord {
  std::string model_key;
  int32_t view_index = 0;
  double azimuth = 0, elevation = 0;  // radians
  uint32_t width = 0, height = 0;
  ImageFormat format = ImageFormat::kPng;
  std::vector<uint8_t> image;
  rle::Box box;  // the object's box inside the stored crop
};

}  // namespace solid
