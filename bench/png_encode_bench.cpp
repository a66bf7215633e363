// PNG encoding of rendered images: EncodeImage (libdeflate, formats/png_encoder.cpp) against
// libpng through OpenImageIO at zlib levels 1 to 9 with the Sub filter, the encoder we used
// before. Best of --repeat per image, one thread; total bytes and total ms over the inputs.
// Inputs are PNG files (e.g. images of a rendered dataset), decoded once.
//   png_encode_bench --repeat 5 /tmp/png/*.png
#include <CLI/CLI.hpp>
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "best_time.h"
#include "solid/formats/image_codec.h"

namespace {

std::vector<uint8_t> EncodeWithLibpng(const solid::Image8& image, int zlib_level) {
  namespace OIIO = OIIO_NAMESPACE;
  OIIO::ImageSpec spec(static_cast<int>(image.width), static_cast<int>(image.height),
                       static_cast<int>(image.channels), OIIO::TypeDesc::UINT8);
  spec.attribute("png:compressionLevel", zlib_level);
  spec.attribute("png:filter", 0x10);  // PNG_FILTER_SUB
  std::vector<unsigned char> out;
  OIIO::Filesystem::IOVecOutput proxy(out);
  auto writer = OIIO::ImageOutput::create("memory.png", &proxy);
  if (!writer || !writer->open("memory.png", spec) || !writer->write_image(spec.format, image.pixels.data()) ||
      !writer->close()) {
    std::fprintf(stderr, "libpng encoding failed\n");
    std::exit(1);
  }
  return {out.begin(), out.end()};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"PNG encoding: libdeflate (ours) against libpng at zlib levels 1-9"};
  std::vector<std::string> files;
  int repeat = 5;
  app.add_option("files", files, "PNG files to re-encode")->required()->check(CLI::ExistingFile);
  app.add_option("--repeat", repeat, "Timed runs per image and encoder (best kept)")->check(CLI::Range(1, 1000));
  CLI11_PARSE(app, argc, argv);
  OIIO_NAMESPACE::attribute("threads", 1);

  std::vector<solid::Image8> images;
  size_t pixels = 0;
  for (const std::string& file : files) {
    std::ifstream in(file, std::ios::binary);
    const std::vector<uint8_t> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    auto image = solid::DecodeImage(bytes, solid::ImageFormat::kPng);
    if (!image.ok()) {
      std::fprintf(stderr, "%s: %s\n", file.c_str(), image.status().ToString().c_str());
      return 1;
    }
    pixels += size_t{image->width} * image->height;
    images.push_back(std::move(image).value());
  }
  fmt::print("{} images, {:.2f} Mpixels; best of {} per image, one thread\n", images.size(), pixels / 1e6, repeat);
  fmt::print("{:<24} {:>12} {:>14} {:>10}\n", "encoder", "ms/image", "bytes/image", "ratio");

  auto report = [&](const std::string& name, auto&& encode) {
    double ms = 0;
    size_t bytes = 0;
    for (const solid::Image8& image : images) {
      std::vector<uint8_t> encoded;
      ms += solid::bench::BestMs(repeat, [&] { encoded = encode(image); });
      bytes += encoded.size();
      auto decoded = solid::DecodeImage(encoded, solid::ImageFormat::kPng);
      if (!decoded.ok() || decoded->pixels != image.pixels) {
        std::fprintf(stderr, "%s: not lossless\n", name.c_str());
        std::exit(1);
      }
    }
    const double raw = static_cast<double>(pixels) * images.front().channels;
    fmt::print("{:<24} {:>12.2f} {:>14.0f} {:>10.3f}\n", name, ms / images.size(),
               static_cast<double>(bytes) / images.size(), bytes / raw);
  };
  report("ours (libdeflate)", [](const solid::Image8& image) {
    return solid::EncodeImage(image, solid::ImageFormat::kPng).value();
  });
  for (int level = 1; level <= 9; ++level) {
    report(fmt::format("libpng zlib {}", level),
           [level](const solid::Image8& image) { return EncodeWithLibpng(image, level); });
  }
  return 0;
}
