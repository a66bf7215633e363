// The random streams of one layout draw (style H5): each concern draws from its own
// stream of the draw's seed, so that changing how one is drawn never moves another.
// Internal to solid::render; the values are part of the data's reproducibility and
// must never be renumbered.
#pragma once

#include <cstdint>

namespace solid::render {

enum Stream : uint64_t {
  kRoomStream = 1,
  kCameraStream = 2,
  kObjectStream = 3,
  kLightStream = 4,    // shade.h: SampleLights
  kShadingStream = 5,  // per-pixel jitter and light/ambient samples, seeded per pixel
  kQueryStream = 6,    // query_views.h: the model's rotation
  kPlacementStream = 7,  // the centre proposals of one pose try, seeded per attempt and try
};

}  // namespace solid::render
