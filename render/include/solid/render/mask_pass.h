// The mask pass: one ray-cast pass over a layout's image that gives, for every placed
// object, its visible mask, its full mask (the object with everything else hidden,
// room included: solid-method.md 1.2), boxes, areas, occlusion, truncation, scale
// class and viewpoint, plus the visible-id image and depth. No extra render per object.
//
// Per pixel centre, two rays leave the camera: one against the room shell and one
// against a top-level scene of the placed objects (Embree instances of each model's
// cached scene), nearest hit each; the nearest object, when nearer than the room, is the
// visible one. The full mask of an object is where the same pixel-centre rays hit that
// object alone (any hit), cast over the pixels its box projects to, and where it is
// visible. One sample per pixel, no anti-aliasing, as the reference's ID passes.
//
// Truncation (the share of an object outside the frame) needs the object beyond the
// image: for an object whose box does not project entirely inside the image, rays are
// cast against that object alone on a regular grid over its projected box (or a
// 3x3-image window when the box straddles the camera plane), at most about 4096 of
// them, and truncation = samples outside the image / all samples that hit. Objects
// whose box projects inside the image have truncation 0 exactly.
#pragma once

#include <cstdint>
#include <vector>

#include "solid/formats/records.h"
#include "solid/render/layout.h"

namespace solid::render {

struct MaskPassOptions {
  int threads = 1;  // rows are split over this many threads
  // Scale classes as at a resolution with this many times more pixels than the layout's
  // (ScaleClassAreaScale; GenerateLayout sets it from the params).
  double area_scale = 1;
  // Only what the proxy metrics need (the optimizer's evaluations): each instance's
  // visible and full areas, occlusion, scale class, pose and viewpoint, counted by the
  // same rays as a full pass, so equal to its; no masks, boxes, depth, id image or
  // truncation (0). The full masks are counted instead of painted into an objects x
  // pixels block and encoded, and only for objects with min_visible_pixels visible
  // pixels or more: the others count for no metric, and their full area is left at
  // their visible area.
  bool metrics_only = false;
};

struct MaskPassResult {
  int width = 0, height = 0;
  // Row-major, 0 where the room (or nothing) is nearest, k + 1 where object k is. Empty,
  // as depth, after a metrics_only pass.
  std::vector<uint32_t> ids;
  // Row-major distance along the camera's -Z axis to the nearest surface, metres;
  // +infinity where the ray leaves the scene.
  std::vector<float> depth;
  // Row-major: what each pixel's centre ray hit (the ray of `ids` and `depth`), so that a
  // shader lighting that hit need not trace the ray again. Empty after a metrics_only pass.
  struct CentreHit {
    static constexpr uint32_t kNothing = UINT32_MAX;
    uint32_t surface = kNothing;  // k: object k; the object count: the room; kNothing: no hit
    uint32_t triangle = 0;        // of that surface's mesh
    float u = 0, v = 0;           // the hit's barycentric coordinates (Embree's)
    float distance = 0;           // along the unit ray
    friend bool operator==(const CentreHit&, const CentreHit&) = default;
  };
  std::vector<CentreHit> centre_hits;
  // One per placed object, in placement order (ordinal = render id = k): mask fields
  // through SetInstanceMasks, pose, size, distance, viewpoint and truncation.
  // image_id = layout index.
  std::vector<InstanceRecord> instances;
  // Objects with at least params.min_visible_pixels visible pixels.
  int visible_objects = 0;
};

Result<MaskPassResult> RunMaskPass(const Layout& layout, int min_visible_pixels, const MaskPassOptions& options = {});

}  // namespace solid::render
