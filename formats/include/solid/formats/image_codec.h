// Encoding and decoding of the images a dataset stores (OpenImageIO, in memory).
// Decoding treats the bytes as untrusted: the header's size is checked against
// the limits before any pixel is decoded (no decompression bombs).
// Thread-safe: every call is independent.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "solid/formats/records.h"
#include "solid/formats/status.h"

namespace solid {

struct ImageLimits {
  uint32_t max_side = 16384;
  uint64_t max_pixels = uint64_t{64} << 20;
  // For sizes of at least 1x1.
  bool Admit(uint64_t width, uint64_t height) const {
    return width <= max_side && height <= max_side && width * height <= max_pixels;
  }
};

// Textures of 3D models, checked when `solid convert` embeds them and when the renderer
// decodes them: at most 8192 per side and 2^25 pixels (128 MiB decoded as RGBA).
inline constexpr ImageLimits kTextureLimits{8192, uint64_t{1} << 25};

struct ImageHeader {
  uint32_t width = 0, height = 0, channels = 0;
};

// Reads the header of encoded bytes (no pixel is decoded) and checks it against the
// limits: kLimitExceeded naming the claimed size and the limits, kParseError when the
// bytes are not an image of `format`. Here and in DecodeImage, what libpng or OpenImageIO
// print on stderr meanwhile ("libpng error: ...") is attached to the error, not printed;
// such calls run one at a time, as stderr is the process's.
Result<ImageHeader> ReadImageHeader(std::span<const uint8_t> bytes, ImageFormat format,
                                    const ImageLimits& limits = {});

// 8-bit, row-major, interleaved channels, row 0 at the top.
struct Image8 {
  uint32_t width = 0, height = 0, channels = 0;
  std::vector<uint8_t> pixels;
};

// One float channel, row-major, row 0 at the top (depth in metres).
struct DepthImage {
  uint32_t width = 0, height = 0;
  std::vector<float> values;
};

// quality (1..100) applies to jpeg and webp; PNG is lossless.
Result<std::vector<uint8_t>> EncodeImage(const Image8& image, ImageFormat format, int quality = 90);
Result<Image8> DecodeImage(std::span<const uint8_t> bytes, ImageFormat format, const ImageLimits& limits = {});

// OpenEXR, one half-float channel "Z", ZIP compressed.
Result<std::vector<uint8_t>> EncodeDepthExr(const DepthImage& depth);
Result<DepthImage> DecodeDepthExr(std::span<const uint8_t> bytes, const ImageLimits& limits = {});

}  // namespace solid
