#include "solid/formats/image_codec.h"

#include <sys/mman.h>
#include <unistd.h>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <iterator>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

#include "png_encoder.h"

namespace solid {
namespace OIIO = OIIO_NAMESPACE;
namespace {

// Our images are small and callers parallelize across images, so OpenImageIO's own
// worker threads only cost thread start-up per call (and a great deal under ASan).
void UseCallerThreadsOnly() {
  static std::once_flag once;
  std::call_once(once, [] {
    OIIO::attribute("threads", 1);
    OIIO::attribute("exr_threads", 1);
  });
}

std::string FileNameFor(ImageFormat format) { return fmt::format("memory.{}", ImageFormatName(format)); }

Status Error(std::string_view what, const std::string& detail) {
  return Status(StatusCode::kParseError, fmt::format("{}: {}", what, detail.empty() ? "unknown error" : detail));
}

Result<std::vector<uint8_t>> Encode(const std::string& name, const OIIO::ImageSpec& spec, const void* pixels) {
  UseCallerThreadsOnly();
  std::vector<unsigned char> out;
  OIIO::Filesystem::IOVecOutput proxy(out);
  auto writer = OIIO::ImageOutput::create(name, &proxy);
  if (!writer) return InternalError(fmt::format("no OpenImageIO writer for {}: {}", name, OIIO::geterror()));
  if (!writer->open(name, spec) || !writer->write_image(spec.format, pixels) || !writer->close()) {
    return InternalError(fmt::format("encoding {}: {}", name, writer->geterror()));
  }
  return std::vector<uint8_t>(out.begin(), out.end());
}

// OpenImageIO 2.4 reads from memory only when the proxy is also named in the
// open configuration ("oiio:ioproxy"); the proxy argument alone is not enough.
Result<std::unique_ptr<OIIO::ImageInput>> OpenFromMemory(const std::string& name,
                                                         OIIO::Filesystem::IOMemReader* proxy) {
  UseCallerThreadsOnly();
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  void* proxy_pointer = proxy;
  config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy_pointer);
  auto reader = OIIO::ImageInput::open(name, &config, proxy);
  if (!reader) return Error(fmt::format("decoding {}", name), OIIO::geterror());
  return reader;
}

// Row by row rather than read_image(), which in OpenImageIO 2.4 allocates a large
// scratch buffer per call (about 50 ms per small image under ASan, against 0.2 ms).
bool ReadPixels(OIIO::ImageInput& reader, OIIO::TypeDesc type, void* data) {
  const OIIO::ImageSpec& spec = reader.spec();
  if (spec.tile_width > 0) return reader.read_image(0, 0, 0, spec.nchannels, type, data);
  const size_t row_bytes = size_t(spec.width) * size_t(spec.nchannels) * type.size();
  auto* bytes = static_cast<unsigned char*>(data);
  for (int y = 0; y < spec.height; ++y) {
    if (!reader.read_scanline(spec.y + y, spec.z, type, bytes + size_t(y) * row_bytes)) return false;
  }
  return true;
}

// OpenEXR 3.1 allocates whatever size a header attribute claims before reading it, so a
// file of a few hundred bytes can cost gigabytes (image_fuzz found two). In a well-formed
// file every attribute fits in the bytes after it, and the attributes OpenEXR parses by
// content rather than by the declared size (fixed-size types, channel lists) agree with that
// size; otherwise OpenEXR loses its place and reads data as further attributes. Walk the
// header(s) and refuse anything else before OpenEXR (or OpenImageIO probing formats) sees
// the bytes, and a data window beyond the limits too (CheckExrHeader). Bytes that do not
// start with the OpenEXR magic are left to the decoders.
// The value size of OpenEXR's fixed-size attribute types, 0 for any other type.
size_t ExrFixedSize(std::string_view type) {
  static constexpr std::pair<std::string_view, size_t> kSizes[] = {
      {"box2i", 16},    {"box2f", 16},     {"v2i", 8},        {"v2f", 8},          {"v3i", 12},
      {"v3f", 12},      {"int", 4},        {"float", 4},      {"double", 8},       {"rational", 8},
      {"compression", 1}, {"lineOrder", 1}, {"envmap", 1},    {"deepImageState", 1}, {"tiledesc", 9},
      {"timecode", 8},  {"keycode", 28},   {"chromaticities", 32}, {"m33f", 36},   {"m44f", 64},
      {"m33d", 72},     {"m44d", 128}};
  for (const auto& [name, size] : kSizes) {
    if (name == type) return size;
  }
  return 0;
}

// A channel list: entries of a NUL-terminated name and 16 bytes, then a NUL, filling the value.
bool ExrChannelListFits(std::span<const uint8_t> value) {
  size_t at = 0;
  while (at < value.size() && value[at] != 0) {
    const auto nul = std::find(value.begin() + static_cast<std::ptrdiff_t>(at), value.end(), uint8_t{0});
    if (nul == value.end()) return false;
    at = static_cast<size_t>(nul - value.begin()) + 1 + 16;
  }
  return at + 1 == value.size();
}

Status CheckExrHeader(std::span<const uint8_t> bytes, const ImageLimits& limits) {
  constexpr uint8_t kMagic[] = {0x76, 0x2f, 0x31, 0x01};
  if (bytes.size() < 8 || !std::equal(std::begin(kMagic), std::end(kMagic), bytes.begin())) return Status::Ok();
  const bool multipart = (bytes[5] & 0x10) != 0;  // version field bit 12
  auto corrupt = [](size_t offset, std::string_view what) {
    return Error("decoding EXR", fmt::format("header at byte {}: {}", offset, what));
  };
  size_t at = 8;
  // A NUL-terminated string of at most 255 bytes (OpenEXR's long-name limit) at `at`.
  auto skip_string = [&]() -> bool {
    const size_t end = std::min(bytes.size(), at + 256);
    const auto nul = std::find(bytes.begin() + static_cast<std::ptrdiff_t>(at),
                               bytes.begin() + static_cast<std::ptrdiff_t>(end), uint8_t{0});
    if (nul == bytes.begin() + static_cast<std::ptrdiff_t>(end)) return false;
    at = static_cast<size_t>(nul - bytes.begin()) + 1;
    return true;
  };
  for (;;) {  // headers: one, or for a multi-part file a list ended by an empty header
    size_t attributes = 0;
    for (;;) {  // attributes, ended by a NUL byte
      if (at >= bytes.size()) return corrupt(at, "truncated");
      if (bytes[at] == 0) {
        ++at;
        break;
      }
      const size_t start = at;
      if (!skip_string()) return corrupt(start, "truncated attribute");
      const size_t type_at = at;
      if (!skip_string() || bytes.size() - at < 4) return corrupt(start, "truncated attribute");
      const std::string_view type(reinterpret_cast<const char*>(bytes.data()) + type_at, at - type_at - 1);
      int32_t size = 0;
      std::memcpy(&size, bytes.data() + at, 4);
      at += 4;
      if (size < 0 || static_cast<uint64_t>(size) > bytes.size() - at) {
        return corrupt(start, fmt::format("an attribute claims {} bytes, {} remain", size, bytes.size() - at));
      }
      const size_t fixed = ExrFixedSize(type);
      if ((fixed != 0 && static_cast<size_t>(size) != fixed) ||
          (type == "chlist" && !ExrChannelListFits(bytes.subspan(at, static_cast<size_t>(size))))) {
        return corrupt(start, fmt::format("a {} attribute of {} bytes is malformed", type, size));
      }
      const std::string_view name(reinterpret_cast<const char*>(bytes.data()) + start, type_at - start - 1);
      if (name == "dataWindow" && type == "box2i") {
        // OpenEXR sizes its line tables from the data window while opening, before the
        // limits below can see it: a 252-byte file claiming 20 million columns took 15 s.
        int32_t box[4];
        std::memcpy(box, bytes.data() + at, sizeof(box));
        const int64_t width = int64_t{box[2]} - box[0] + 1, height = int64_t{box[3]} - box[1] + 1;
        if (width <= 0 || height <= 0) {
          return corrupt(start, fmt::format("an empty data window ({}, {}) - ({}, {})", box[0], box[1], box[2], box[3]));
        }
        if (!limits.Admit(static_cast<uint64_t>(width), static_cast<uint64_t>(height))) {
          return LimitExceededError(fmt::format("decoding EXR: header at byte {} claims a {}x{} data window, over the "
                                                "limits ({} per side, {} pixels)",
                                                start, width, height, limits.max_side, limits.max_pixels));
        }
      }
      at += static_cast<size_t>(size);
      ++attributes;
    }
    if (!multipart || attributes == 0) return Status::Ok();
  }
}

// Opens bytes for reading and checks the header against the limits.
Result<std::unique_ptr<OIIO::ImageInput>> OpenChecked(const std::string& name, OIIO::Filesystem::IOMemReader* proxy,
                                                      const ImageLimits& limits) {
  SOLID_ASSIGN_OR_RETURN(auto reader, OpenFromMemory(name, proxy));
  const OIIO::ImageSpec& spec = reader->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.depth != 1) {
    return Error(fmt::format("decoding {}", name), fmt::format("unsupported geometry {}x{}x{} channels, depth {}",
                                                               spec.width, spec.height, spec.nchannels, spec.depth));
  }
  if (!limits.Admit(static_cast<uint64_t>(spec.width), static_cast<uint64_t>(spec.height)) || spec.nchannels > 4) {
    return LimitExceededError(fmt::format("{}: header claims {}x{} with {} channels, over the limits ({} per side, "
                                          "{} pixels, 4 channels)",
                                          name, spec.width, spec.height, spec.nchannels, limits.max_side,
                                          limits.max_pixels));
  }
  return reader;
}

}  // namespace

Result<std::vector<uint8_t>> EncodeImage(const Image8& image, ImageFormat format, int quality) {
  if (image.width == 0 || image.height == 0 || image.channels == 0 || image.channels > 4 ||
      image.pixels.size() != size_t{image.width} * image.height * image.channels) {
    return InvalidArgumentError(fmt::format("EncodeImage: {}x{}x{} does not match {} bytes", image.width,
                                            image.height, image.channels, image.pixels.size()));
  }
  if (format == ImageFormat::kPng) return EncodePng(image);
  OIIO::ImageSpec spec(static_cast<int>(image.width), static_cast<int>(image.height),
                       static_cast<int>(image.channels), OIIO::TypeDesc::UINT8);
  // OpenImageIO 2.4's JPEG writer reads "Compression" ("jpeg:Q"); its WebP writer "CompressionQuality".
  spec.attribute("Compression", fmt::format("{}:{}", ImageFormatName(format), quality));
  spec.attribute("CompressionQuality", quality);
  return Encode(FileNameFor(format), spec, image.pixels.data());
}

namespace {

// libpng's default error handler, which OpenImageIO 2.4's PNG reader keeps, prints to
// stderr ("libpng error: IHDR: Read error: hit end of file") and names no file. Around a
// decode of untrusted bytes, stderr is a memory file: what the libraries printed goes into
// the error, whose caller names the image (or back to stderr when the decode succeeds).
// One at a time: stderr is the process's.
class LibraryMessages {
 public:
  LibraryMessages() : lock_(Mutex()) {
    std::fflush(stderr);
    capture_ = ::memfd_create("solid-library-messages", MFD_CLOEXEC);
    if (capture_ >= 0) saved_ = ::dup(STDERR_FILENO);
    if (saved_ >= 0) ::dup2(capture_, STDERR_FILENO);
  }
  ~LibraryMessages() { Restore(); }
  LibraryMessages(const LibraryMessages&) = delete;
  LibraryMessages& operator=(const LibraryMessages&) = delete;

  template <typename T>
  Result<T> Attach(Result<T> result) {
    std::string printed = Restore();
    while (!printed.empty() && (printed.back() == '\n' || printed.back() == ' ')) printed.pop_back();
    if (printed.empty()) return result;
    if (result.ok()) {
      printed += '\n';
      (void)!::write(STDERR_FILENO, printed.data(), printed.size());
      return result;
    }
    for (char& c : printed) {
      if (c == '\n') c = ';';
    }
    const Status& s = result.status();
    return Status(s.code(), fmt::format("{} (the decoder printed: {})", s.message(), printed));
  }

 private:
  static std::mutex& Mutex() {
    static std::mutex mutex;
    return mutex;
  }

  // Puts stderr back; what was written meanwhile.
  std::string Restore() {
    std::string printed;
    if (saved_ < 0) {
      if (capture_ >= 0) ::close(capture_);
      capture_ = -1;
      return printed;
    }
    std::fflush(stderr);
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
    saved_ = -1;
    char buffer[4096];
    for (off_t at = 0;;) {
      const ssize_t n = ::pread(capture_, buffer, sizeof buffer, at);
      if (n <= 0 || printed.size() > (64 << 10)) break;
      printed.append(buffer, static_cast<size_t>(n));
      at += n;
    }
    ::close(capture_);
    capture_ = -1;
    return printed;
  }

  std::lock_guard<std::mutex> lock_;
  int capture_ = -1, saved_ = -1;
};

Result<ImageHeader> ReadImageHeaderOf(std::span<const uint8_t> bytes, ImageFormat format, const ImageLimits& limits) {
  SOLID_RETURN_IF_ERROR(CheckExrHeader(bytes, limits));
  OIIO::Filesystem::IOMemReader proxy(bytes.data(), bytes.size());
  SOLID_ASSIGN_OR_RETURN(auto reader, OpenChecked(FileNameFor(format), &proxy, limits));
  const OIIO::ImageSpec& spec = reader->spec();
  return ImageHeader{static_cast<uint32_t>(spec.width), static_cast<uint32_t>(spec.height),
                     static_cast<uint32_t>(spec.nchannels)};
}

Result<Image8> DecodeImageOf(std::span<const uint8_t> bytes, ImageFormat format, const ImageLimits& limits) {
  SOLID_RETURN_IF_ERROR(CheckExrHeader(bytes, limits));
  OIIO::Filesystem::IOMemReader proxy(bytes.data(), bytes.size());
  std::string name = FileNameFor(format);
  SOLID_ASSIGN_OR_RETURN(auto reader, OpenChecked(name, &proxy, limits));
  const OIIO::ImageSpec& spec = reader->spec();
  Image8 image;
  image.width = static_cast<uint32_t>(spec.width);
  image.height = static_cast<uint32_t>(spec.height);
  image.channels = static_cast<uint32_t>(spec.nchannels);
  image.pixels.resize(size_t{image.width} * image.height * image.channels);
  if (!ReadPixels(*reader, OIIO::TypeDesc::UINT8, image.pixels.data())) {
    return Error(fmt::format("decoding {}", name), reader->geterror());
  }
  return image;
}

}  // namespace

Result<std::vector<uint8_t>> EncodeDepthExr(const DepthImage& depth) {
  UseCallerThreadsOnly();
  if (depth.width == 0 || depth.height == 0 || depth.values.size() != size_t{depth.width} * depth.height) {
    return InvalidArgumentError(fmt::format("EncodeDepthExr: {}x{} does not match {} values", depth.width,
                                            depth.height, depth.values.size()));
  }
  OIIO::ImageSpec spec(static_cast<int>(depth.width), static_cast<int>(depth.height), 1, OIIO::TypeDesc::HALF);
  spec.channelnames = {"Z"};
  spec.z_channel = 0;
  spec.attribute("compression", "zip");
  std::vector<unsigned char> out;
  OIIO::Filesystem::IOVecOutput proxy(out);
  auto writer = OIIO::ImageOutput::create("memory.exr", &proxy);
  if (!writer) return InternalError(fmt::format("no OpenEXR writer: {}", OIIO::geterror()));
  if (!writer->open("memory.exr", spec) || !writer->write_image(OIIO::TypeDesc::FLOAT, depth.values.data()) ||
      !writer->close()) {
    return InternalError(fmt::format("encoding depth EXR: {}", writer->geterror()));
  }
  return std::vector<uint8_t>(out.begin(), out.end());
}

Result<ImageHeader> ReadImageHeader(std::span<const uint8_t> bytes, ImageFormat format, const ImageLimits& limits) {
  LibraryMessages messages;
  return messages.Attach(ReadImageHeaderOf(bytes, format, limits));
}

Result<Image8> DecodeImage(std::span<const uint8_t> bytes, ImageFormat format, const ImageLimits& limits) {
  LibraryMessages messages;
  return messages.Attach(DecodeImageOf(bytes, format, limits));
}

Result<DepthImage> DecodeDepthExr(std::span<const uint8_t> bytes, const ImageLimits& limits) {
  SOLID_RETURN_IF_ERROR(CheckExrHeader(bytes, limits));
  OIIO::Filesystem::IOMemReader proxy(bytes.data(), bytes.size());
  SOLID_ASSIGN_OR_RETURN(auto reader, OpenFromMemory("memory.exr", &proxy));
  const OIIO::ImageSpec& spec = reader->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels != 1 || spec.depth != 1) {
    return Error("decoding depth EXR", fmt::format("expected one channel, found {}x{}x{}", spec.width, spec.height,
                                                   spec.nchannels));
  }
  const uint64_t width = static_cast<uint64_t>(spec.width), height = static_cast<uint64_t>(spec.height);
  if (!limits.Admit(width, height)) {
    return LimitExceededError(fmt::format("depth EXR header claims {}x{}, over the limits", spec.width, spec.height));
  }
  DepthImage depth;
  depth.width = static_cast<uint32_t>(spec.width);
  depth.height = static_cast<uint32_t>(spec.height);
  depth.values.resize(width * height);
  if (!ReadPixels(*reader, OIIO::TypeDesc::FLOAT, depth.values.data())) {
    return Error("decoding depth EXR", reader->geterror());
  }
  return depth;
}

}  // namespace solid
