#include "solid/formats/records.h"

#include <fmt/format.h>

#include <cmath>

namespace solid {

std::string_view ImageFormatName(ImageFormat f) {
  switch (f) {
    case ImageFormat::kPng: return "png";
    case ImageFormat::kJpeg: return "jpeg";
    case ImageFormat::kWebp: return "webp";
  }
  return "png";
}

Result<ImageFormat> ParseImageFormat(std::string_view name) {
  if (name == "png") return ImageFormat::kPng;
  if (name == "jpeg" || name == "jpg") return ImageFormat::kJpeg;
  if (name == "webp") return ImageFormat::kWebp;
  return InvalidArgumentError(fmt::format("unknown image format '{}' (png, jpeg, webp)", name));
}

std::string_view ScaleClassName(ScaleClass c) {
  switch (c) {
    case ScaleClass::kSmall: return "small";
    case ScaleClass::kMedium: return "medium";
    case ScaleClass::kLarge: return "large";
  }
  return "small";
}

Result<ScaleClass> ParseScaleClass(std::string_view name) {
  if (name == "small") return ScaleClass::kSmall;
  if (name == "medium") return ScaleClass::kMedium;
  if (name == "large") return ScaleClass::kLarge;
  return InvalidArgumentError(fmt::format("unknown scale class '{}'", name));
}

ScaleClass ScaleClassOfArea(uint64_t visible_area, double area_scale) {
  const uint64_t area =
      area_scale == 1 ? visible_area : static_cast<uint64_t>(std::llround(static_cast<double>(visible_area) * area_scale));
  if (area < 32 * 32) return ScaleClass::kSmall;
  if (area <= 96 * 96) return ScaleClass::kMedium;
  return ScaleClass::kLarge;
}

Status SetInstanceMasks(const rle::Rle& visible, const rle::Rle& full, InstanceRecord* instance,
                        double area_scale) {
  if (visible.height != full.height || visible.width != full.width) {
    return InvalidArgumentError(fmt::format("visible mask is {}x{}, full mask {}x{}", visible.width,
                                            visible.height, full.width, full.height));
  }
  if (!rle::Contains(full, visible)) {
    return InvalidArgumentError("the full mask does not contain the visible mask");
  }
  instance->visible_rle = rle::ToString(visible);
  instance->full_rle = rle::ToString(full);
  instance->visible_box = rle::ToBbox(visible);
  instance->full_box = rle::ToBbox(full);
  SetInstanceAreas(rle::Area(visible), rle::Area(full), instance, area_scale);
  return Status::Ok();
}

void SetInstanceAreas(uint64_t visible_area, uint64_t full_area, InstanceRecord* instance, double area_scale) {
  instance->visible_area = visible_area;
  instance->full_area = full_area;
  instance->occlusion.reset();
  if (full_area > 0) {
    instance->occlusion = static_cast<double>(full_area - visible_area) / static_cast<double>(full_area);
  }
  instance->scale_class.reset();
  if (visible_area > 0) instance->scale_class = ScaleClassOfArea(visible_area, area_scale);
}

}  // namespace solid
