// libFuzzer target for the decoders of stored images and textures: DecodeImage (PNG, JPEG,
// WebP: shard images, query views, glb textures) and DecodeDepthExr (shard depth). The
// first byte picks the decoder, the rest is the file. OpenImageIO itself is not
// instrumented, so coverage guides the search only through our code; crashes, hangs and
// decompression bombs inside OpenImageIO still surface.
#include <cstdint>
#include <span>

#include "fuzz/fuzz_util.h"
#include "solid/formats/image_codec.h"

using solid::fuzz::Fail;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::span<const uint8_t> bytes(data + 1, size - 1);
  const solid::ImageLimits limits;
  switch (data[0] % 4) {
    case 0:
    case 1:
    case 2: {
      const auto format = static_cast<solid::ImageFormat>(data[0] % 4);
      solid::Result<solid::Image8> image = solid::DecodeImage(bytes, format, limits);
      if (!image.ok()) return 0;
      if (image->width == 0 || image->height == 0 || image->channels == 0 || image->channels > 4) {
        Fail("a decoded image has an empty or unsupported geometry");
      }
      if (!limits.Admit(image->width, image->height)) Fail("a decoded image exceeds the limits");
      if (image->pixels.size() != size_t{image->width} * image->height * image->channels) {
        Fail("a decoded image has the wrong number of bytes");
      }
      break;
    }
    default: {
      solid::Result<solid::DepthImage> depth = solid::DecodeDepthExr(bytes, limits);
      if (!depth.ok()) return 0;
      if (depth->values.size() != size_t{depth->width} * depth->height) Fail("a decoded depth has the wrong size");
      if (!limits.Admit(depth->width, depth->height)) Fail("a decoded depth exceeds the limits");
      break;
    }
  }
  return 0;
}
