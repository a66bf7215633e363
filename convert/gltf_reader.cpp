#include "gltf_reader.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <meshoptimizer.h>

#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"

// The one translation unit holding tinygltf's implementation. Images are kept encoded
// (the asset embeds PNG/JPEG as is), so neither stb_image nor its writer is compiled;
// the file-system callbacks are ours, confined to the model's folder.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_USE_CPP14
#include <tiny_gltf.h>

namespace solid::convert {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Thrown inside this file only, caught by ReadGltfModel: a model's first failure ends it.
struct Failed {
  GltfFailure failure;
};
[[noreturn]] void Fail(std::string code, std::string message) { throw Failed{{std::move(code), std::move(message)}}; }

// Deepest [ / { nesting of JSON text, strings skipped: nlohmann recurses per level, so a
// crafted file is refused before tinygltf parses it.
uint32_t JsonDepth(std::string_view text) {
  uint32_t depth = 0, deepest = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    else if (c == '[' || c == '{') deepest = std::max(deepest, ++depth);
    else if ((c == ']' || c == '}') && depth > 0) --depth;
  }
  return deepest;
}

// EXT_meshopt_compression's fallback buffers have no URI (they hold nothing until the
// compressed views are decoded into them); they are renamed to this so that tinygltf asks
// ReadWholeFileCb for them, which hands out zeroed memory of the declared size.
constexpr std::string_view kFallbackUri = "solid-meshopt-fallback-";

struct FsContext {
  fs::path base_dir, confine_root;
  uint64_t max_bytes = 0;
  std::map<std::string, uint64_t, std::less<>> fallback_bytes;  // sentinel URI -> byteLength
  std::string rejected;  // why the last refused path was refused
  std::string missing;
};

// Existence is decided in ReadWholeFileCb, which confines the path first: a missing file
// is reported there, with the failure code of its own.
bool FileExistsCb(const std::string&, void*) { return true; }

std::string ExpandCb(const std::string& path, void*) { return path; }

bool ReadWholeFileCb(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
  auto* ctx = static_cast<FsContext*>(user);
  // tinygltf joins base_dir and the (URL-decoded) URI: take the URI back.
  const std::string prefix = ctx->base_dir.string() + "/";
  std::string_view relative(path);
  if (relative.starts_with(prefix)) relative.remove_prefix(prefix.size());
  if (auto it = ctx->fallback_bytes.find(relative); it != ctx->fallback_bytes.end()) {
    out->assign(it->second, 0);
    return true;
  }
  Result<fs::path> resolved = files::ResolveInside(ctx->confine_root, (ctx->base_dir.lexically_relative(
                                                                          ctx->confine_root) / relative).string());
  if (relative.find("://") != std::string_view::npos || !resolved.ok()) {
    ctx->rejected = fmt::format("'{}' {}", relative, resolved.ok() ? "is a URL" : resolved.status().message());
    if (err) *err += ctx->rejected;
    return false;
  }
  std::error_code ec;
  if (!fs::is_regular_file(*resolved, ec)) {
    ctx->missing = resolved->string();
    if (err) *err += resolved->string() + ": not found";
    return false;
  }
  Result<std::vector<uint8_t>> bytes = files::ReadFile(*resolved, ctx->max_bytes);
  if (!bytes.ok()) {
    ctx->missing = bytes.status().message();
    if (err) *err += bytes.status().message();
    return false;
  }
  out->assign(bytes->begin(), bytes->end());
  return true;
}

bool WriteWholeFileCb(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "writing is disabled";
  return false;
}

bool IsPng(std::span<const uint8_t> b) {
  return b.size() >= 24 && std::memcmp(b.data(), "\x89PNG\r\n\x1a\n", 8) == 0;
}
bool IsJpeg(std::span<const uint8_t> b) { return b.size() >= 4 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF; }

// Width and height from the header, without decoding: PNG IHDR, JPEG SOFn.
std::optional<std::pair<uint32_t, uint32_t>> ImageSize(std::span<const uint8_t> b) {
  auto be32 = [&](size_t i) { return uint32_t{b[i]} << 24 | uint32_t{b[i + 1]} << 16 | uint32_t{b[i + 2]} << 8 | b[i + 3]; };
  if (IsPng(b)) return std::make_pair(be32(16), be32(20));
  if (!IsJpeg(b)) return std::nullopt;
  size_t i = 2;
  while (i + 9 < b.size()) {
    if (b[i] != 0xFF) return std::nullopt;
    const uint8_t marker = b[i + 1];
    if (marker == 0xFF) { ++i; continue; }
    const size_t length = size_t{b[i + 2]} << 8 | b[i + 3];
    if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
      return std::make_pair(uint32_t{b[i + 7]} << 8 | b[i + 8], uint32_t{b[i + 5]} << 8 | b[i + 6]);
    }
    i += 2 + length;
  }
  return std::nullopt;
}

// Images stay encoded: the asset embeds PNG and JPEG bytes as they are. tinygltf 2.7 hands
// over an image's bufferView without checking it against its buffer, so that is done here
// (`user` is the model being loaded: its buffers and views are parsed before its images).
bool KeepImageBytes(tinygltf::Image* image, const int index, std::string* err, std::string*, int, int,
                    const unsigned char* bytes, int size, void* user) {
  const auto* model = static_cast<const tinygltf::Model*>(user);
  if (image->bufferView >= 0) {
    const tinygltf::BufferView& bv = model->bufferViews[static_cast<size_t>(image->bufferView)];
    const size_t available = model->buffers[static_cast<size_t>(bv.buffer)].data.size();
    if (bv.byteOffset > available || bv.byteLength > available - bv.byteOffset || bv.byteLength > INT32_MAX) {
      if (err) *err += fmt::format("/images/{}: bufferView {} lies outside its buffer", index, image->bufferView);
      return false;
    }
  }
  image->image.assign(bytes, bytes + std::max(size, 0));
  image->as_is = true;
  return true;
}

struct Mat4 {
  std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // column-major, as glTF
  double at(int row, int col) const { return m[static_cast<size_t>(col * 4 + row)]; }
  Mat4 operator*(const Mat4& o) const {
    Mat4 r;
    for (int c = 0; c < 4; ++c) {
      for (int rr = 0; rr < 4; ++rr) {
        double s = 0;
        for (int k = 0; k < 4; ++k) s += at(rr, k) * o.at(k, c);
        r.m[static_cast<size_t>(c * 4 + rr)] = s;
      }
    }
    return r;
  }
  double Det3() const {
    return at(0, 0) * (at(1, 1) * at(2, 2) - at(1, 2) * at(2, 1)) -
           at(0, 1) * (at(1, 0) * at(2, 2) - at(1, 2) * at(2, 0)) +
           at(0, 2) * (at(1, 0) * at(2, 1) - at(1, 1) * at(2, 0));
  }
};

Mat4 NodeMatrix(const tinygltf::Node& n, const std::string& where) {
  Mat4 local;
  if (n.matrix.size() == 16) {
    std::copy(n.matrix.begin(), n.matrix.end(), local.m.begin());
  } else {
    if (!n.matrix.empty()) Fail("parse_error", where + "/matrix: not 16 numbers");
    std::array<double, 3> t{0, 0, 0}, s{1, 1, 1};
    std::array<double, 4> q{0, 0, 0, 1};
    if (n.translation.size() == 3) std::copy(n.translation.begin(), n.translation.end(), t.begin());
    if (n.scale.size() == 3) std::copy(n.scale.begin(), n.scale.end(), s.begin());
    if (n.rotation.size() == 4) std::copy(n.rotation.begin(), n.rotation.end(), q.begin());
    if ((!n.translation.empty() && n.translation.size() != 3) || (!n.scale.empty() && n.scale.size() != 3) ||
        (!n.rotation.empty() && n.rotation.size() != 4)) {
      Fail("parse_error", where + ": translation, rotation or scale of the wrong length");
    }
    double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(len > 0) || !std::isfinite(len)) Fail("corrupt", where + "/rotation: not a rotation quaternion");
    for (double& c : q) c /= len;
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    const std::array<double, 9> r{1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                                  2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                                  2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
    // local = T * R * S, column-major: column c of R scaled by s[c].
    for (int c = 0; c < 3; ++c) {
      for (int rr = 0; rr < 3; ++rr) local.m[static_cast<size_t>(c * 4 + rr)] = r[static_cast<size_t>(c * 3 + rr)] * s[static_cast<size_t>(c)];
    }
    for (int rr = 0; rr < 3; ++rr) local.m[static_cast<size_t>(12 + rr)] = t[static_cast<size_t>(rr)];
  }
  for (double v : local.m) {
    if (!std::isfinite(v)) Fail("corrupt", where + ": non-finite transform");
  }
  return local;
}

size_t ComponentBytes(int type) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
  }
}

size_t ComponentCount(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    default: return 0;
  }
}

// One component as a double: normalized integers map to [-1, 1] or [0, 1] as the glTF
// spec says; others (KHR_mesh_quantization's integer positions) keep their value.
double ReadComponent(const uint8_t* p, int type, bool normalized) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      int8_t v;
      std::memcpy(&v, p, 1);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? p[0] / 255.0 : p[0];
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      int16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? v / 65535.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      uint32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
    default: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
  }
}

class Reader {
 public:
  Reader(const tinygltf::Model& model, std::string name, const GltfReadLimits& limits)
      : model_(model), name_(std::move(name)), limits_(limits) {}

  // count x components values of accessor `index`, every byte range checked first.
  std::vector<double> Accessor(int index, size_t want_components, const std::string& where) {
    if (index < 0 || static_cast<size_t>(index) >= model_.accessors.size()) {
      Fail("corrupt", fmt::format("{}: {}: accessor {} does not exist", name_, where, index));
    }
    const tinygltf::Accessor& a = model_.accessors[static_cast<size_t>(index)];
    const std::string at = fmt::format("{}: /accessors/{}", name_, index);
    if (a.sparse.isSparse) Fail("unsupported_feature", at + "/sparse: sparse accessors are not read");
    const size_t cb = ComponentBytes(a.componentType), nc = ComponentCount(a.type);
    if (cb == 0 || nc == 0) Fail("corrupt", at + ": unknown componentType or type");
    if (want_components != 0 && nc != want_components) {
      Fail("corrupt", fmt::format("{}: {} components where {} needs {}", at, nc, where, want_components));
    }
    const size_t element = cb * nc;
    if (a.bufferView < 0) {
      // No buffer view: all zeros (glTF 3.6.2.3), still bounded.
      if (a.count > limits_.max_vertices * 3) Fail("limit_exceeded", at + ": count past the limits");
      return std::vector<double>(a.count * nc, 0.0);
    }
    const std::span<const uint8_t> view = View(a.bufferView, fmt::format("{}/bufferView", at));
    const tinygltf::BufferView& bv = model_.bufferViews[static_cast<size_t>(a.bufferView)];
    const size_t stride = bv.byteStride != 0 ? bv.byteStride : element;
    if (stride < element) Fail("corrupt", fmt::format("{}: byteStride {} below the element size {}", at, stride, element));
    if (a.count > 0 && (a.byteOffset > view.size() || (a.count - 1) > (view.size() - a.byteOffset) / stride ||
                        (a.count - 1) * stride + element > view.size() - a.byteOffset)) {
      Fail("corrupt", fmt::format("{}: {} elements from byte {} overrun bufferView {} ({} bytes)", at, a.count,
                                  a.byteOffset, a.bufferView, view.size()));
    }
    std::vector<double> out(a.count * nc);
    for (size_t i = 0; i < a.count; ++i) {
      const uint8_t* p = view.data() + a.byteOffset + i * stride;
      for (size_t c = 0; c < nc; ++c) out[i * nc + c] = ReadComponent(p + c * cb, a.componentType, a.normalized);
    }
    return out;
  }

  std::span<const uint8_t> View(int index, const std::string& where) {
    if (index < 0 || static_cast<size_t>(index) >= model_.bufferViews.size()) {
      Fail("corrupt", fmt::format("{}: bufferView {} does not exist", where, index));
    }
    const tinygltf::BufferView& bv = model_.bufferViews[static_cast<size_t>(index)];
    if (bv.buffer < 0 || static_cast<size_t>(bv.buffer) >= model_.buffers.size()) {
      Fail("corrupt", fmt::format("{}: /bufferViews/{}: buffer {} does not exist", name_, index, bv.buffer));
    }
    const std::vector<unsigned char>& data = model_.buffers[static_cast<size_t>(bv.buffer)].data;
    if (bv.byteOffset > data.size() || bv.byteLength > data.size() - bv.byteOffset) {
      Fail("corrupt", fmt::format("{}: /bufferViews/{}: bytes {}..{} outside buffer {} ({} bytes)", name_, index,
                                  bv.byteOffset, bv.byteOffset + bv.byteLength, bv.buffer, data.size()));
    }
    return {data.data() + bv.byteOffset, bv.byteLength};
  }

 private:
  const tinygltf::Model& model_;
  std::string name_;
  const GltfReadLimits& limits_;
};

// A primitive's geometry in its mesh's frame.
struct RawPrimitive {
  std::vector<double> positions, normals;
  std::vector<std::vector<double>> uvs;  // TEXCOORD_n
  std::vector<uint32_t> triangles;
};

const std::set<std::string>& DecodedExtensions() {
  static const std::set<std::string> kDecoded = {"KHR_draco_mesh_compression", "KHR_mesh_quantization",
                                                 "KHR_texture_transform", "EXT_meshopt_compression"};
  return kDecoded;
}

std::vector<uint32_t> TrianglesFromMode(const std::vector<uint32_t>& idx, int mode, const std::string& where,
                                        uint64_t* converted) {
  std::vector<uint32_t> tri;
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    if (idx.size() % 3 != 0) Fail("corrupt", fmt::format("{}: {} indices, not a multiple of 3", where, idx.size()));
    return idx;
  }
  if (idx.size() < 3) return tri;
  ++*converted;
  tri.reserve(3 * (idx.size() - 2));
  for (size_t i = 2; i < idx.size(); ++i) {
    if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      // Every other triangle of a strip is reversed to keep one winding.
      if (i % 2 == 0) tri.insert(tri.end(), {idx[i - 2], idx[i - 1], idx[i]});
      else tri.insert(tri.end(), {idx[i - 1], idx[i - 2], idx[i]});
    } else {
      tri.insert(tri.end(), {idx[0], idx[i - 1], idx[i]});
    }
  }
  return tri;
}

RawPrimitive DecodeDraco(Reader& reader, const tinygltf::Primitive& prim, const tinygltf::Value& ext,
                         const std::string& where, const GltfReadLimits& limits) {
  if (!ext.IsObject() || !ext.Has("bufferView") || !ext.Get("bufferView").IsInt() || !ext.Has("attributes") ||
      !ext.Get("attributes").IsObject()) {
    Fail("parse_error", where + "/extensions/KHR_draco_mesh_compression: bufferView or attributes missing");
  }
  const std::span<const uint8_t> bytes = reader.View(ext.Get("bufferView").GetNumberAsInt(), where);
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) Fail("corrupt", fmt::format("{}: Draco stream: {}", where, decoded.status().error_msg_string()));
  const std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
  if (mesh->num_points() > limits.max_vertices || mesh->num_faces() > limits.max_triangles) {
    Fail("limit_exceeded", where + ": Draco mesh past the vertex or triangle limit");
  }
  RawPrimitive raw;
  const tinygltf::Value& attributes = ext.Get("attributes");
  auto read = [&](const std::string& semantic, size_t n, std::vector<double>* out) {
    if (!attributes.Has(semantic)) return;
    const draco::PointAttribute* a = mesh->GetAttributeByUniqueId(
        static_cast<uint32_t>(attributes.Get(semantic).GetNumberAsInt()));
    if (a == nullptr || a->num_components() < n) Fail("corrupt", fmt::format("{}: Draco attribute {} missing", where, semantic));
    out->resize(size_t{mesh->num_points()} * n);
    std::array<float, 4> v{};
    for (uint32_t i = 0; i < mesh->num_points(); ++i) {
      if (!a->ConvertValue<float>(a->mapped_index(draco::PointIndex(i)), static_cast<int8_t>(n), v.data())) {
        Fail("corrupt", fmt::format("{}: Draco attribute {} unreadable", where, semantic));
      }
      for (size_t c = 0; c < n; ++c) (*out)[i * n + c] = v[c];
    }
  };
  read("POSITION", 3, &raw.positions);
  read("NORMAL", 3, &raw.normals);
  for (const auto& [semantic, _] : prim.attributes) {
    if (!semantic.starts_with("TEXCOORD_")) continue;
    const size_t set = static_cast<size_t>(std::atoi(semantic.c_str() + 9));
    if (set > 7) continue;
    if (raw.uvs.size() <= set) raw.uvs.resize(set + 1);
    read(semantic, 2, &raw.uvs[set]);
  }
  raw.triangles.reserve(size_t{mesh->num_faces()} * 3);
  for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) raw.triangles.push_back(mesh->face(f)[k].value());
  }
  return raw;
}

// What tinygltf (built without its own Draco and meshopt support) would refuse, rewritten
// before it parses: every EXT_meshopt_compression fallback buffer without a URI gets the
// sentinel URI, and KHR_draco_mesh_compression primitives lose their `indices` (an
// accessor without a bufferView, which tinygltf rejects; the Draco stream holds the
// triangles). Repacks the file (GLB: a new JSON chunk before the original binary chunk).
// Indices of every array are kept, so JSON pointers in messages still name the input.
std::vector<uint8_t> RewriteForTinygltf(std::span<const uint8_t> bytes, bool binary, std::string_view json_text,
                                        const std::string& name, const GltfReadLimits& limits, FsContext* ctx) {
  json j = json::parse(json_text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) return {bytes.begin(), bytes.end()};
  if (j.contains("meshes") && j["meshes"].is_array()) {
    for (json& mesh : j["meshes"]) {
      if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
      for (json& prim : mesh["primitives"]) {
        if (prim.is_object() && prim.contains("extensions") && prim["extensions"].is_object() &&
            prim["extensions"].contains("KHR_draco_mesh_compression")) {
          prim.erase("indices");
        }
      }
    }
  }
  uint64_t total = 0;
  for (size_t i = 0; j.contains("buffers") && j["buffers"].is_array() && i < j["buffers"].size(); ++i) {
    json& b = j["buffers"][i];
    if (!b.is_object() || b.contains("uri") || !b.contains("extensions") || !b["extensions"].is_object()) continue;
    const json& ext = b["extensions"].value("EXT_meshopt_compression", json());
    // Only a boolean true is a fallback: value<bool>() threw on a number (gltf_fuzz found it).
    if (!ext.is_object() || ext.value("fallback", json()) != json(true) || !b.contains("byteLength") ||
        !b["byteLength"].is_number_unsigned()) {
      continue;
    }
    total += b["byteLength"].get<uint64_t>();
    if (total > limits.max_decoded_bytes) {
      Fail("limit_exceeded", fmt::format("{}: /buffers/{}: meshopt fallback buffers past {} bytes in all", name, i,
                                         limits.max_decoded_bytes));
    }
    const std::string uri = fmt::format("{}{}", kFallbackUri, i);
    ctx->fallback_bytes[uri] = b["byteLength"].get<uint64_t>();
    b["uri"] = uri;
  }
  std::string text = j.dump();
  if (!binary) return {text.begin(), text.end()};
  while (text.size() % 4 != 0) text.push_back(' ');
  uint32_t old_chunk = 0;
  std::memcpy(&old_chunk, bytes.data() + 12, 4);
  const size_t rest = 20 + size_t{old_chunk};
  std::vector<uint8_t> out(bytes.begin(), bytes.begin() + 12);
  const uint32_t chunk = static_cast<uint32_t>(text.size()), type = 0x4E4F534Au;
  out.insert(out.end(), reinterpret_cast<const uint8_t*>(&chunk), reinterpret_cast<const uint8_t*>(&chunk) + 4);
  out.insert(out.end(), reinterpret_cast<const uint8_t*>(&type), reinterpret_cast<const uint8_t*>(&type) + 4);
  out.insert(out.end(), text.begin(), text.end());
  if (rest < bytes.size()) out.insert(out.end(), bytes.begin() + static_cast<std::ptrdiff_t>(rest), bytes.end());
  const uint32_t length = static_cast<uint32_t>(std::min<size_t>(out.size(), UINT32_MAX));
  std::memcpy(out.data() + 8, &length, 4);
  return out;
}

// Decodes every EXT_meshopt_compression bufferView into the bytes its fallback names.
void DecodeMeshopt(tinygltf::Model* model, const std::string& name) {
  for (size_t v = 0; v < model->bufferViews.size(); ++v) {
    tinygltf::BufferView& bv = model->bufferViews[v];
    auto it = bv.extensions.find("EXT_meshopt_compression");
    if (it == bv.extensions.end()) continue;
    const std::string at = fmt::format("{}: /bufferViews/{}/extensions/EXT_meshopt_compression", name, v);
    const tinygltf::Value& x = it->second;
    auto integer = [&](const char* key, bool required) -> uint64_t {
      if (!x.IsObject() || !x.Has(key)) {
        if (required) Fail("parse_error", fmt::format("{}/{}: missing", at, key));
        return 0;
      }
      const tinygltf::Value& n = x.Get(key);
      if (!n.IsNumber() || n.GetNumberAsDouble() < 0 || n.GetNumberAsDouble() > 9e15) {
        Fail("parse_error", fmt::format("{}/{}: not a non-negative integer", at, key));
      }
      return static_cast<uint64_t>(n.GetNumberAsDouble());
    };
    const uint64_t buffer = integer("buffer", true), offset = integer("byteOffset", false),
                   length = integer("byteLength", true), stride = integer("byteStride", true),
                   count = integer("count", true);
    const std::string mode = x.Has("mode") && x.Get("mode").IsString() ? x.Get("mode").Get<std::string>() : "";
    const std::string filter =
        x.Has("filter") && x.Get("filter").IsString() ? x.Get("filter").Get<std::string>() : "NONE";
    if (buffer >= model->buffers.size()) Fail("corrupt", at + "/buffer: does not exist");
    const std::vector<unsigned char>& src = model->buffers[buffer].data;
    if (offset > src.size() || length > src.size() - offset) Fail("corrupt", at + ": source bytes outside the buffer");
    if (bv.buffer < 0 || static_cast<size_t>(bv.buffer) >= model->buffers.size()) Fail("corrupt", at + ": no target buffer");
    std::vector<unsigned char>& dst = model->buffers[static_cast<size_t>(bv.buffer)].data;
    if (stride == 0 || stride > 256 || count > (uint64_t{1} << 32) || count * stride > bv.byteLength ||
        bv.byteOffset > dst.size() || bv.byteLength > dst.size() - bv.byteOffset) {
      Fail("corrupt", fmt::format("{}: {} x {} bytes do not fit the bufferView", at, count, stride));
    }
    unsigned char* target = dst.data() + bv.byteOffset;
    const unsigned char* data = src.data() + offset;
    int rc = -1;
    if (mode == "ATTRIBUTES") {
      if (stride % 4 != 0) Fail("corrupt", at + "/byteStride: not a multiple of 4");
      rc = meshopt_decodeVertexBuffer(target, count, stride, data, length);
    } else if (mode == "TRIANGLES" || mode == "INDICES") {
      if (stride != 2 && stride != 4) Fail("corrupt", at + "/byteStride: index size not 2 or 4");
      if (mode == "TRIANGLES" && count % 3 != 0) Fail("corrupt", at + "/count: not a multiple of 3");
      rc = mode == "TRIANGLES" ? meshopt_decodeIndexBuffer(target, count, stride, data, length)
                               : meshopt_decodeIndexSequence(target, count, stride, data, length);
    } else {
      Fail("corrupt", fmt::format("{}/mode: '{}' is not ATTRIBUTES, TRIANGLES or INDICES", at, mode));
    }
    if (rc != 0) Fail("corrupt", fmt::format("{}: meshopt stream does not decode ({})", at, rc));
    if (filter == "OCTAHEDRAL") {
      if (stride != 4 && stride != 8) Fail("corrupt", at + "/filter: OCTAHEDRAL needs a stride of 4 or 8");
      meshopt_decodeFilterOct(target, count, stride);
    } else if (filter == "QUATERNION") {
      if (stride != 8) Fail("corrupt", at + "/filter: QUATERNION needs a stride of 8");
      meshopt_decodeFilterQuat(target, count, stride);
    } else if (filter == "EXPONENTIAL") {
      meshopt_decodeFilterExp(target, count, stride);
    } else if (filter != "NONE") {
      Fail("corrupt", fmt::format("{}/filter: unknown filter '{}'", at, filter));
    }
  }
}

struct Output {
  gltf::Primitive prim;
  bool has_normals = true;
  bool any_part = false;
};

}  // namespace

std::array<double, 3> NormalizeAsShapeNetV2(gltf::Asset* asset) {
  double lo[3] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                  std::numeric_limits<double>::infinity()};
  double hi[3] = {-lo[0], -lo[0], -lo[0]};
  double sum[3] = {0, 0, 0};
  size_t count = 0;
  for (const gltf::Node& n : asset->nodes) {
    for (const gltf::Primitive& p : n.primitives) {
      for (size_t i = 0; i + 2 < p.positions.size(); i += 3) {
        for (size_t k = 0; k < 3; ++k) {
          lo[k] = std::min(lo[k], double{p.positions[i + k]});
          hi[k] = std::max(hi[k], double{p.positions[i + k]});
          sum[k] += p.positions[i + k];
        }
        ++count;
      }
    }
  }
  if (count == 0) return {0, 0, 0};
  const std::array<double, 3> extent{hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  const double diagonal = std::sqrt(extent[0] * extent[0] + extent[1] * extent[1] + extent[2] * extent[2]);
  const double scale = diagonal > 0 ? 1 / diagonal : 1;
  for (gltf::Node& n : asset->nodes) {
    for (gltf::Primitive& p : n.primitives) {
      for (size_t i = 0; i + 2 < p.positions.size(); i += 3) {
        for (size_t k = 0; k < 3; ++k) {
          p.positions[i + k] = static_cast<float>((p.positions[i + k] - sum[k] / static_cast<double>(count)) * scale);
        }
      }
    }
  }
  return extent;
}

GltfReadResult ReadGltfModel(std::span<const uint8_t> bytes, const fs::path& path, const fs::path& confine_root,
                             const std::string& node_name, const GltfReadLimits& limits) {
  GltfReadResult result;
  const std::string name = path.string();
  try {
    if (bytes.size() > limits.max_file_bytes) {
      Fail("limit_exceeded", fmt::format("{}: {} bytes, over the {} byte limit", name, bytes.size(), limits.max_file_bytes));
    }
    const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    std::string_view json_text;
    if (binary) {
      if (bytes.size() < 20) Fail("parse_error", name + ": byte 0: truncated GLB header");
      uint32_t length = 0, chunk = 0, type = 0;
      std::memcpy(&length, bytes.data() + 8, 4);
      std::memcpy(&chunk, bytes.data() + 12, 4);
      std::memcpy(&type, bytes.data() + 16, 4);
      if (type != 0x4E4F534Au || length > bytes.size() || chunk > bytes.size() - 20) {
        Fail("parse_error", name + ": byte 12: the first GLB chunk is not JSON within the file");
      }
      json_text = std::string_view(reinterpret_cast<const char*>(bytes.data()) + 20, chunk);
    } else {
      json_text = std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    }
    if (JsonDepth(json_text) > limits.max_json_depth) {
      Fail("limit_exceeded", fmt::format("{}: JSON nested deeper than {}", name, limits.max_json_depth));
    }

    FsContext fs_ctx{path.parent_path(), confine_root, limits.max_file_bytes, {}, {}, {}};
    if (fs_ctx.base_dir.empty()) fs_ctx.base_dir = ".";
    std::vector<uint8_t> repacked;
    if (json_text.find("EXT_meshopt_compression") != std::string_view::npos ||
        json_text.find("KHR_draco_mesh_compression") != std::string_view::npos) {
      repacked = RewriteForTinygltf(bytes, binary, json_text, name, limits, &fs_ctx);
      bytes = repacked;
      // LoadASCIIFromString reads json_text; a GLB is read from bytes.
      if (!binary) json_text = std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    }
    tinygltf::TinyGLTF loader;
    loader.SetFsCallbacks({&FileExistsCb, &ExpandCb, &ReadWholeFileCb, &WriteWholeFileCb, &fs_ctx});
    tinygltf::Model model;
    loader.SetImageLoader(&KeepImageBytes, &model);
    loader.SetStoreOriginalJSONForExtrasAndExtensions(false);
    std::string err, warn;
    bool loaded = false;
    try {
      loaded = binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(),
                                                    static_cast<unsigned>(bytes.size()), fs_ctx.base_dir.string())
                      : loader.LoadASCIIFromString(&model, &err, &warn, json_text.data(),
                                                   static_cast<unsigned>(json_text.size()), fs_ctx.base_dir.string());
    } catch (const std::out_of_range& e) {
      // tinygltf 2.7 indexes an empty vector for a GLB buffer of byteLength 0 (gltf_fuzz found it).
      Fail("parse_error", fmt::format("{}: tinygltf: {}", name, e.what()));
    }
    if (!fs_ctx.rejected.empty()) Fail("external_path_rejected", fmt::format("{}: {}", name, fs_ctx.rejected));
    if (!fs_ctx.missing.empty()) Fail("missing_file", fmt::format("{}: {}", name, fs_ctx.missing));
    if (!loaded) {
      while (!err.empty() && err.back() == '\n') err.pop_back();
      Fail("parse_error", fmt::format("{}: {}", name, err.substr(0, 400)));
    }
    for (const std::string& e : model.extensionsRequired) {
      if (!DecodedExtensions().count(e)) {
        Fail("unsupported_extension", fmt::format("{}: /extensionsRequired: {} is not supported", name, e));
      }
    }
    DecodeMeshopt(&model, name);
    GltfModel& out = result.model;
    for (const std::string& e : model.extensionsUsed) {
      if (!DecodedExtensions().count(e) &&
          std::find(model.extensionsRequired.begin(), model.extensionsRequired.end(), e) == model.extensionsRequired.end()) {
        out.warnings.push_back({"unsupported_optional_extension", fmt::format("{}: /extensionsUsed: {} ignored", name, e)});
      }
    }
    Reader reader(model, name, limits);

    // Materials and their textures, converted on first use.
    std::map<int, uint32_t> material_of;
    std::map<int, std::optional<uint32_t>> texture_of;
    struct UvTransform {
      int tex_coord = 0;
      std::array<double, 6> m{1, 0, 0, 0, 1, 0};  // u' = m0 u + m1 v + m2; v' = m3 u + m4 v + m5
      bool textured = false;
    };
    std::map<int, UvTransform> uv_of;
    auto texture = [&](int index) -> std::optional<uint32_t> {
      if (auto it = texture_of.find(index); it != texture_of.end()) return it->second;
      std::optional<uint32_t>& slot = texture_of[index];
      const std::string at = fmt::format("{}: /textures/{}", name, index);
      if (index < 0 || static_cast<size_t>(index) >= model.textures.size()) Fail("corrupt", at + ": does not exist");
      const tinygltf::Texture& t = model.textures[static_cast<size_t>(index)];
      if (t.source < 0 || static_cast<size_t>(t.source) >= model.images.size()) {
        out.warnings.push_back({"unsupported_texture", at + ": no PNG or JPEG source image; texture dropped"});
        return slot;
      }
      const tinygltf::Image& image = model.images[static_cast<size_t>(t.source)];
      const std::span<const uint8_t> b(image.image.data(), image.image.size());
      const std::string image_at = fmt::format("{}: /images/{}", name, t.source);
      if (!IsPng(b) && !IsJpeg(b)) {
        out.warnings.push_back({"unsupported_texture", image_at + ": not PNG or JPEG; texture dropped"});
        return slot;
      }
      std::optional<std::pair<uint32_t, uint32_t>> size = ImageSize(b);
      if (!size || size->first == 0 || size->second == 0) Fail("corrupt", image_at + ": no readable image header");
      // As for MTL textures: one the renderer would refuse is dropped, the material keeps its colour.
      if (!kTextureLimits.Admit(size->first, size->second) || b.size() > limits.max_image_bytes) {
        out.warnings.push_back({"texture_too_large", fmt::format("{}: {}x{} pixels, {} bytes: over the texture limits; "
                                                                 "texture dropped", image_at, size->first, size->second,
                                                                 b.size())});
        return slot;
      }
      gltf::Texture tex;
      tex.name = !image.uri.empty() && image.uri.rfind("data:", 0) != 0 ? image.uri
                                                                         : fmt::format("image{}", t.source);
      tex.mime_type = IsPng(b) ? "image/png" : "image/jpeg";
      tex.bytes.assign(b.begin(), b.end());
      slot = static_cast<uint32_t>(out.asset.textures.size());
      out.asset.textures.push_back(std::move(tex));
      return slot;
    };
    auto material = [&](int index) -> uint32_t {
      if (auto it = material_of.find(index); it != material_of.end()) return it->second;
      const std::string at = fmt::format("{}: /materials/{}", name, index);
      if (index < 0 || static_cast<size_t>(index) >= model.materials.size()) Fail("corrupt", at + ": does not exist");
      const tinygltf::Material& m = model.materials[static_cast<size_t>(index)];
      gltf::Material mat;
      mat.name = m.name.empty() ? fmt::format("material{}", index) : m.name;
      const std::vector<double>& f = m.pbrMetallicRoughness.baseColorFactor;
      for (size_t k = 0; k < 4 && k < f.size(); ++k) {
        mat.base_color[k] = std::isfinite(f[k]) ? static_cast<float>(std::clamp(f[k], 0.0, 1.0)) : 1.0f;
      }
      auto unit = [](double v, float fallback) { return std::isfinite(v) ? static_cast<float>(std::clamp(v, 0.0, 1.0)) : fallback; };
      mat.metallic = unit(m.pbrMetallicRoughness.metallicFactor, 1.0f);
      mat.roughness = unit(m.pbrMetallicRoughness.roughnessFactor, 1.0f);
      mat.blend = m.alphaMode == "BLEND";
      mat.double_sided = m.doubleSided;
      UvTransform uv;
      const tinygltf::TextureInfo& info = m.pbrMetallicRoughness.baseColorTexture;
      if (info.index >= 0) {
        mat.base_color_texture = texture(info.index);
        uv.textured = mat.base_color_texture.has_value();
        uv.tex_coord = info.texCoord;
        if (auto it = info.extensions.find("KHR_texture_transform"); it != info.extensions.end() && it->second.IsObject()) {
          const tinygltf::Value& x = it->second;
          auto number = [&](const tinygltf::Value& v, double fallback) {
            return v.IsNumber() ? v.GetNumberAsDouble() : fallback;
          };
          double ox = 0, oy = 0, sx = 1, sy = 1, r = 0;
          if (x.Has("offset") && x.Get("offset").IsArray() && x.Get("offset").ArrayLen() == 2) {
            ox = number(x.Get("offset").Get(0), 0);
            oy = number(x.Get("offset").Get(1), 0);
          }
          if (x.Has("scale") && x.Get("scale").IsArray() && x.Get("scale").ArrayLen() == 2) {
            sx = number(x.Get("scale").Get(0), 1);
            sy = number(x.Get("scale").Get(1), 1);
          }
          if (x.Has("rotation")) r = number(x.Get("rotation"), 0);
          if (x.Has("texCoord") && x.Get("texCoord").IsInt()) uv.tex_coord = x.Get("texCoord").GetNumberAsInt();
          // T * R * S of the extension's specification.
          const double c = std::cos(r), s = std::sin(r);
          uv.m = {c * sx, s * sy, ox, -s * sx, c * sy, oy};
        }
      }
      const uint32_t slot = static_cast<uint32_t>(out.asset.materials.size());
      out.asset.materials.push_back(std::move(mat));
      material_of[index] = slot;
      uv_of[index] = uv;
      return slot;
    };

    // Output primitives, one per glTF material (-1: none) in first-use order.
    std::vector<Output> outputs;
    std::map<int, size_t> output_of;
    uint64_t vertices = 0, triangles = 0, instances = 0, primitive_instances = 0;
    uint64_t strips_fans = 0, dropped_points_lines = 0, mirrored = 0, draco = 0;

    auto emit = [&](const tinygltf::Mesh& mesh, int mesh_index, const Mat4& world) {
      const bool flip = world.Det3() < 0;
      if (flip) ++mirrored;
      // Normals take the inverse transpose of the upper 3x3: its cofactor matrix, which
      // differs only by the determinant's scale (renormalised anyway) and sign (fixed here).
      std::array<double, 9> nm{};
      {
        auto a = [&](int r, int c) { return world.at(r, c); };
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 3; ++c) {
            const int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
            nm[static_cast<size_t>(r * 3 + c)] = (a(r1, c1) * a(r2, c2) - a(r1, c2) * a(r2, c1)) * (flip ? -1 : 1);
          }
        }
      }
      for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
        const tinygltf::Primitive& prim = mesh.primitives[pi];
        const std::string where = fmt::format("{}: /meshes/{}/primitives/{}", name, mesh_index, pi);
        if (++primitive_instances > limits.max_primitives) Fail("limit_exceeded", where + ": past the primitive limit");
        if (prim.mode == TINYGLTF_MODE_POINTS || prim.mode == TINYGLTF_MODE_LINE || prim.mode == TINYGLTF_MODE_LINE_LOOP ||
            prim.mode == TINYGLTF_MODE_LINE_STRIP) {
          ++dropped_points_lines;
          continue;
        }
        if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
            prim.mode != TINYGLTF_MODE_TRIANGLE_FAN) {
          Fail("corrupt", fmt::format("{}/mode: unknown mode {}", where, prim.mode));
        }
        RawPrimitive raw;
        if (auto it = prim.extensions.find("KHR_draco_mesh_compression"); it != prim.extensions.end()) {
          raw = DecodeDraco(reader, prim, it->second, where, limits);
          raw.triangles = TrianglesFromMode(raw.triangles, prim.mode, where, &strips_fans);
          ++draco;
        } else {
          auto pos = prim.attributes.find("POSITION");
          if (pos == prim.attributes.end()) Fail("corrupt", where + "/attributes: no POSITION");
          raw.positions = reader.Accessor(pos->second, 3, where + "/attributes/POSITION");
          if (raw.positions.size() / 3 > limits.max_vertices) Fail("limit_exceeded", where + ": past the vertex limit");
          if (auto n = prim.attributes.find("NORMAL"); n != prim.attributes.end()) {
            raw.normals = reader.Accessor(n->second, 3, where + "/attributes/NORMAL");
          }
          for (const auto& [semantic, accessor] : prim.attributes) {
            if (!semantic.starts_with("TEXCOORD_")) continue;
            const size_t set = static_cast<size_t>(std::atoi(semantic.c_str() + 9));
            if (set > 7) continue;
            if (raw.uvs.size() <= set) raw.uvs.resize(set + 1);
            raw.uvs[set] = reader.Accessor(accessor, 2, where + "/attributes/" + semantic);
          }
          std::vector<uint32_t> idx;
          if (prim.indices >= 0) {
            const tinygltf::Accessor& ia = model.accessors.at(static_cast<size_t>(
                prim.indices < static_cast<int>(model.accessors.size()) ? prim.indices : 0));
            if (prim.indices >= static_cast<int>(model.accessors.size()) ||
                (ia.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
                 ia.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
                 ia.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) ||
                ia.normalized) {
              Fail("corrupt", where + "/indices: not an unsigned integer accessor");
            }
            std::vector<double> v = reader.Accessor(prim.indices, 1, where + "/indices");
            idx.assign(v.begin(), v.end());
          } else {
            idx.resize(raw.positions.size() / 3);
            for (size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<uint32_t>(i);
          }
          if (prim.mode != TINYGLTF_MODE_TRIANGLES && idx.size() > 3 * limits.max_triangles) {
            Fail("limit_exceeded", where + ": past the triangle limit");
          }
          raw.triangles = TrianglesFromMode(idx, prim.mode, where, &strips_fans);
        }
        const size_t nv = raw.positions.size() / 3;
        if (!raw.normals.empty() && raw.normals.size() != raw.positions.size()) {
          Fail("corrupt", where + "/attributes/NORMAL: count differs from POSITION");
        }
        for (const std::vector<double>& uv : raw.uvs) {
          if (!uv.empty() && uv.size() != 2 * nv) Fail("corrupt", where + "/attributes: TEXCOORD count differs from POSITION");
        }
        for (uint32_t i : raw.triangles) {
          if (i >= nv) Fail("corrupt", fmt::format("{}/indices: index {} past {} vertices", where, i, nv));
        }
        vertices += nv;
        triangles += raw.triangles.size() / 3;
        if (vertices > limits.max_vertices || triangles > limits.max_triangles) {
          Fail("limit_exceeded", where + ": past the vertex or triangle limit");
        }
        if (raw.triangles.empty()) continue;

        auto [slot_it, added] = output_of.emplace(prim.material, outputs.size());
        if (added) {
          outputs.emplace_back();
          if (prim.material >= 0) outputs.back().prim.material = material(prim.material);
        }
        Output& o = outputs[slot_it->second];
        const UvTransform uvt = prim.material >= 0 ? uv_of[prim.material] : UvTransform{};
        const uint32_t base = static_cast<uint32_t>(o.prim.positions.size() / 3);
        const bool had_normals_before = o.has_normals;
        o.has_normals = o.has_normals && !raw.normals.empty();
        if (had_normals_before && !o.has_normals) o.prim.normals.clear();
        for (size_t v = 0; v < nv; ++v) {
          const double* p = &raw.positions[3 * v];
          for (int r = 0; r < 3; ++r) {
            const double w = world.at(r, 0) * p[0] + world.at(r, 1) * p[1] + world.at(r, 2) * p[2] + world.at(r, 3);
            if (!std::isfinite(w) || std::fabs(w) > 3e38) Fail("corrupt", where + "/attributes/POSITION: non-finite after the node transforms");
            o.prim.positions.push_back(static_cast<float>(w));
          }
          if (o.has_normals) {
            const double* n = &raw.normals[3 * v];
            std::array<double, 3> t{};
            for (size_t r = 0; r < 3; ++r) t[r] = nm[r * 3] * n[0] + nm[r * 3 + 1] * n[1] + nm[r * 3 + 2] * n[2];
            const double len = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
            for (double c : t) o.prim.normals.push_back(len > 0 && std::isfinite(len) ? static_cast<float>(c / len) : 0.0f);
            if (!(len > 0) || !std::isfinite(len)) {
              // A zero normal cannot be written; +Y beats a NaN, as for procedural shapes.
              o.prim.normals[o.prim.normals.size() - 2] = 1.0f;
            }
          }
          if (uvt.textured) {
            const size_t set = static_cast<size_t>(std::max(uvt.tex_coord, 0));
            double u = 0, w = 0;
            if (set < raw.uvs.size() && !raw.uvs[set].empty()) {
              u = raw.uvs[set][2 * v];
              w = raw.uvs[set][2 * v + 1];
            }
            const double tu = uvt.m[0] * u + uvt.m[1] * w + uvt.m[2], tv = uvt.m[3] * u + uvt.m[4] * w + uvt.m[5];
            o.prim.uvs.push_back(std::isfinite(tu) ? static_cast<float>(tu) : 0.0f);
            o.prim.uvs.push_back(std::isfinite(tv) ? static_cast<float>(tv) : 0.0f);
          }
        }
        for (size_t t = 0; t + 2 < raw.triangles.size(); t += 3) {
          o.prim.indices.push_back(base + raw.triangles[t]);
          o.prim.indices.push_back(base + raw.triangles[flip ? t + 2 : t + 1]);
          o.prim.indices.push_back(base + raw.triangles[flip ? t + 1 : t + 2]);
        }
      }
    };

    // The default scene (else the first; with none, every root node), depth first.
    std::vector<int> roots;
    if (!model.scenes.empty()) {
      const size_t s = model.defaultScene >= 0 && static_cast<size_t>(model.defaultScene) < model.scenes.size()
                           ? static_cast<size_t>(model.defaultScene)
                           : 0;
      roots = model.scenes[s].nodes;
    } else {
      std::vector<bool> child(model.nodes.size(), false);
      for (const tinygltf::Node& n : model.nodes) {
        for (int c : n.children) {
          if (c >= 0 && static_cast<size_t>(c) < child.size()) child[static_cast<size_t>(c)] = true;
        }
      }
      for (size_t i = 0; i < model.nodes.size(); ++i) {
        if (!child[i]) roots.push_back(static_cast<int>(i));
      }
    }
    std::vector<bool> on_path(model.nodes.size(), false);
    std::function<void(int, const Mat4&, uint32_t)> visit = [&](int index, const Mat4& parent, uint32_t depth) {
      const std::string at = fmt::format("{}: /nodes/{}", name, index);
      if (index < 0 || static_cast<size_t>(index) >= model.nodes.size()) Fail("corrupt", at + ": does not exist");
      if (depth > limits.max_node_depth) Fail("limit_exceeded", fmt::format("{}: deeper than {} nodes", at, limits.max_node_depth));
      if (on_path[static_cast<size_t>(index)]) Fail("node_cycle", at + ": is its own ancestor");
      if (++instances > limits.max_node_instances) Fail("limit_exceeded", at + ": past the node instance limit");
      const tinygltf::Node& node = model.nodes[static_cast<size_t>(index)];
      const Mat4 world = parent * NodeMatrix(node, at);
      if (node.mesh >= 0) {
        if (static_cast<size_t>(node.mesh) >= model.meshes.size()) Fail("corrupt", at + "/mesh: does not exist");
        emit(model.meshes[static_cast<size_t>(node.mesh)], node.mesh, world);
      }
      on_path[static_cast<size_t>(index)] = true;
      for (int c : node.children) visit(c, world, depth + 1);
      on_path[static_cast<size_t>(index)] = false;
    };
    for (int r : roots) visit(r, Mat4{}, 0);

    gltf::Node node;
    node.name = node_name;
    for (Output& o : outputs) {
      if (!o.has_normals) o.prim.normals.clear();
      node.primitives.push_back(std::move(o.prim));
    }
    if (node.primitives.empty()) Fail("empty_geometry", name + ": the default scene has no triangle");
    // Materials no kept primitive uses are left out by construction (converted on first use).
    out.asset.nodes.push_back(std::move(node));
    if (dropped_points_lines > 0) {
      out.warnings.push_back({"points_lines_dropped",
                              fmt::format("{}: {} point or line primitives dropped", name, dropped_points_lines)});
    }
    out.counts = {{"node_instances", instances},      {"primitive_instances", primitive_instances},
                  {"triangles_in", triangles},        {"vertices_in", vertices},
                  {"strips_fans_converted", strips_fans}, {"points_lines_dropped", dropped_points_lines},
                  {"mirrored_instances", mirrored},   {"draco_primitives", draco},
                  {"textures_embedded", out.asset.textures.size()}};
    result.ok = true;
  } catch (const Failed& f) {
    result.ok = false;
    result.failure = f.failure;
    result.model = {};
  } catch (const std::bad_alloc&) {
    result.ok = false;
    result.failure = {"limit_exceeded", name + ": out of memory"};
    result.model = {};
  } catch (const json::exception& e) {
    // A JSON value of a type the reader did not foresee is bad input, not a crash.
    result.ok = false;
    result.failure = {"parse_error", fmt::format("{}: {}", name, e.what())};
    result.model = {};
  }
  return result;
}

}  // namespace solid::convert
