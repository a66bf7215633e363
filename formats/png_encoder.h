// PNG encoding with libdeflate: the container written here, the compression by libdeflate
// (docs/dependencies.md, "PNG encoder", says why not libpng through OpenImageIO).
#pragma once

#include <cstdint>
#include <vector>

#include "solid/formats/image_codec.h"

namespace solid {

// 8-bit grey, grey+alpha, RGB or RGBA (1 to 4 channels), non-interlaced, every row filtered
// with Sub, one IDAT chunk; the same bytes for the same pixels on every thread and machine.
// The caller has checked the image's size against its pixels.
Result<std::vector<uint8_t>> EncodePng(const Image8& image);

}  // namespace solid
