#include "solid/formats/glb.h"

#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/core/encoder_buffer.h>
#include <draco/mesh/mesh.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace solid::gltf {
namespace {

using nlohmann::json;

// GLB fields are little-endian; we copy integers with memcpy.
static_assert(std::endian::native == std::endian::little, "GLB I/O assumes a little-endian host");

constexpr uint32_t kGlbMagic = 0x46546C67;   // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942;   // "BIN\0"
constexpr uint64_t kGlbHeaderSize = 12, kChunkHeaderSize = 8;
constexpr int kUnsignedByte = 5121, kUnsignedShort = 5123, kUnsignedInt = 5125, kFloat = 5126;
constexpr int kTriangles = 4;
constexpr int kRepeat = 10497, kLinear = 9729, kLinearMipmapLinear = 9987;
constexpr const char* kDraco = "KHR_draco_mesh_compression";
// nlohmann's parser is iterative, but copying and comparing a json value recurse:
// an untrusted "[[[[..." must not reach them.
constexpr int kMaxJsonDepth = 64;

constexpr const char* kPosition = "POSITION";
constexpr const char* kNormal = "NORMAL";
constexpr const char* kTexcoord = "TEXCOORD_0";

bool AllFinite(const std::vector<float>& v) {
  return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
}

// glTF JSON is UTF-8 and json::dump throws on anything else; checking each name
// and extras value first lets the error say which one.
Status CheckUtf8(const json& value, std::string_view where) {
  try {
    (void)value.dump();
  } catch (const json::exception&) {
    return InvalidArgumentError(fmt::format("{}: not valid UTF-8", where));
  }
  return Status::Ok();
}

bool MagicMatches(const std::vector<uint8_t>& bytes, std::string_view mime) {
  static constexpr uint8_t kPng[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  static constexpr uint8_t kJpeg[] = {0xFF, 0xD8, 0xFF};
  auto starts = [&](std::span<const uint8_t> magic) {
    return bytes.size() >= magic.size() && std::equal(magic.begin(), magic.end(), bytes.begin());
  };
  if (mime == "image/png") return starts(kPng);
  if (mime == "image/jpeg") return starts(kJpeg);
  return false;
}

// ---------------------------------------------------------------------------
// Draco

struct DracoIds {
  std::optional<uint32_t> position, normal, texcoord;  // Draco attribute unique ids
};

// The geometry a Draco decoder produces from `bytes`; counts checked so that a
// corrupt stream cannot make us read outside Draco's own arrays.
Result<Primitive> DecodeDraco(std::span<const uint8_t> bytes, const DracoIds& ids) {
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) return CorruptError(fmt::format("Draco: {}", decoded.status().error_msg_string()));
  const draco::Mesh& mesh = *decoded.value();
  const uint32_t num_points = mesh.num_points();
  if (num_points == 0 || mesh.num_faces() == 0) return CorruptError("Draco: empty mesh");

  Primitive p;
  auto read = [&](std::optional<uint32_t> id, int components, const char* semantic, std::vector<float>& out) -> Status {
    if (!id) return Status::Ok();
    const draco::PointAttribute* a = mesh.GetAttributeByUniqueId(*id);
    if (a == nullptr) return CorruptError(fmt::format("Draco: no attribute with id {} ({})", *id, semantic));
    if (a->num_components() != components) {
      return CorruptError(
          fmt::format("Draco: {} has {} components, expected {}", semantic, a->num_components(), components));
    }
    const uint64_t needed = static_cast<uint64_t>(a->size()) * static_cast<uint64_t>(a->byte_stride());
    if (a->buffer() == nullptr || a->byte_offset() != 0 || needed > a->buffer()->data_size() ||
        (!a->is_mapping_identity() && a->indices_map_size() < num_points)) {
      return CorruptError(fmt::format("Draco: {} attribute is inconsistent", semantic));
    }
    out.resize(static_cast<size_t>(num_points) * static_cast<size_t>(components));
    for (uint32_t i = 0; i < num_points; ++i) {
      const draco::AttributeValueIndex avi = a->mapped_index(draco::PointIndex(i));
      if (avi.value() >= a->size() ||
          !a->ConvertValue<float>(avi, static_cast<int8_t>(components), &out[size_t{i} * components])) {
        return CorruptError(fmt::format("Draco: {} of point {} is unreadable", semantic, i));
      }
    }
    if (!AllFinite(out)) return CorruptError(fmt::format("Draco: non-finite {}", semantic));
    return Status::Ok();
  };
  if (!ids.position) return CorruptError("no POSITION attribute");
  SOLID_RETURN_IF_ERROR(read(ids.position, 3, kPosition, p.positions));
  SOLID_RETURN_IF_ERROR(read(ids.normal, 3, kNormal, p.normals));
  SOLID_RETURN_IF_ERROR(read(ids.texcoord, 2, kTexcoord, p.uvs));

  p.indices.reserve(static_cast<size_t>(mesh.num_faces()) * 3);
  for (draco::FaceIndex f(0); f < mesh.num_faces(); ++f) {
    for (const draco::PointIndex& v : mesh.face(f)) {
      if (v.value() >= num_points) return CorruptError(fmt::format("Draco: face {} out of range", f.value()));
      p.indices.push_back(v.value());
    }
  }
  return p;
}

struct EncodedPrimitive {
  std::vector<uint8_t> bytes;
  DracoIds ids;
  Primitive decoded;  // what every Draco decoder will produce: accessor counts and bounds
};

constexpr int kDracoDefaultSpeed = 5;

Result<EncodedPrimitive> EncodeDraco(const Primitive& p, const DracoOptions& options) {
  const auto num_points = static_cast<uint32_t>(p.positions.size() / 3);
  draco::Mesh mesh;
  mesh.set_num_points(num_points);
  auto add = [&](draco::GeometryAttribute::Type type, int components, const std::vector<float>& values) {
    draco::GeometryAttribute attribute;
    attribute.Init(type, nullptr, static_cast<uint8_t>(components), draco::DT_FLOAT32, false,
                   static_cast<int64_t>(sizeof(float)) * components, 0);
    const int id = mesh.AddAttribute(attribute, /*identity_mapping=*/true, num_points);
    SOLID_CHECK(id >= 0);
    draco::PointAttribute* a = mesh.attribute(id);
    for (uint32_t i = 0; i < num_points; ++i) {
      a->SetAttributeValue(draco::AttributeValueIndex(i), &values[size_t{i} * components]);
    }
    return a->unique_id();
  };
  EncodedPrimitive out;
  out.ids.position = add(draco::GeometryAttribute::POSITION, 3, p.positions);
  if (!p.normals.empty()) out.ids.normal = add(draco::GeometryAttribute::NORMAL, 3, p.normals);
  if (!p.uvs.empty()) out.ids.texcoord = add(draco::GeometryAttribute::TEX_COORD, 2, p.uvs);
  mesh.SetNumFaces(p.indices.size() / 3);
  for (size_t f = 0; f < p.indices.size() / 3; ++f) {
    mesh.SetFace(draco::FaceIndex(static_cast<uint32_t>(f)),
                 {draco::PointIndex(p.indices[3 * f]), draco::PointIndex(p.indices[3 * f + 1]),
                  draco::PointIndex(p.indices[3 * f + 2])});
  }
  // Our vertices are distinct (position, normal, uv) triples, so positions repeat
  // along UV and normal seams. Edgebreaker derives connectivity from position
  // *value* indices; without merging equal values every seam would cut the mesh.
  mesh.DeduplicateAttributeValues();
  mesh.DeduplicatePointIds();

  auto encode = [&](int speed) -> Result<std::vector<uint8_t>> {
    draco::Encoder encoder;
    encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, options.position_bits);
    encoder.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, options.normal_bits);
    encoder.SetAttributeQuantization(draco::GeometryAttribute::TEX_COORD, options.texcoord_bits);
    encoder.SetSpeedOptions(speed, speed);
    // Edgebreaker, not sequential: a quarter of the size on a 10k-triangle torus
    // with normals and UVs at default options (2.1 vs 8.7 bytes per triangle). It
    // reorders, merges and may split vertices, which is why the accessors are
    // filled from a decode of our own bytes rather than from the input.
    encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
    draco::EncoderBuffer buffer;
    const draco::Status status = encoder.EncodeMeshToBuffer(mesh, &buffer);
    if (!status.ok()) return InternalError(fmt::format("Draco encoder: {}", status.error_msg_string()));
    return std::vector<uint8_t>(reinterpret_cast<const uint8_t*>(buffer.data()),
                                reinterpret_cast<const uint8_t*>(buffer.data()) + buffer.size());
  };
  // Below speed 5 Draco codes connectivity by valence and predicts more: 12% smaller than
  // speed 5 on the real ShapeNet models, but 20-25% larger on meshes of many seams
  // (bench/make_obj_corpus's), and on the procedural families each wins on some primitives
  // (the smaller of the two is 3.7% below speed 3 alone). So a level above 5 also tries
  // Draco's default speed and keeps the smaller stream.
  const int speed = 10 - options.compression_level;
  SOLID_ASSIGN_OR_RETURN(out.bytes, encode(speed));
  if (speed < kDracoDefaultSpeed) {
    SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> at_default, encode(kDracoDefaultSpeed));
    if (at_default.size() < out.bytes.size()) out.bytes = std::move(at_default);
  }
  auto decoded = DecodeDraco(out.bytes, out.ids);
  if (!decoded.ok()) return InternalError(fmt::format("own Draco output: {}", decoded.status().message()));
  out.decoded = std::move(decoded).value();
  return out;
}

// ---------------------------------------------------------------------------
// Writer

Status CheckOptions(const DracoOptions& o) {
  auto in = [](int v, int lo, int hi) { return v >= lo && v <= hi; };
  // Draco's own limits: 1..30 bits, octahedral normals need at least 2.
  if (!in(o.position_bits, 1, 30)) {
    return InvalidArgumentError(fmt::format("position_bits {} not in [1, 30]", o.position_bits));
  }
  if (!in(o.normal_bits, 2, 30)) {
    return InvalidArgumentError(fmt::format("normal_bits {} not in [2, 30]", o.normal_bits));
  }
  if (!in(o.texcoord_bits, 1, 30)) {
    return InvalidArgumentError(fmt::format("texcoord_bits {} not in [1, 30]", o.texcoord_bits));
  }
  if (!in(o.compression_level, 0, 10)) {
    return InvalidArgumentError(fmt::format("compression_level {} not in [0, 10]", o.compression_level));
  }
  return Status::Ok();
}

Status CheckPrimitive(const Primitive& p, size_t num_materials) {
  if (p.positions.empty() || p.positions.size() % 3 != 0) {
    return InvalidArgumentError(fmt::format("{} position floats (need a positive multiple of 3)", p.positions.size()));
  }
  const size_t n = p.positions.size() / 3;
  // Draco indexes points with int32.
  if (n > static_cast<size_t>(std::numeric_limits<int32_t>::max())) {
    return LimitExceededError(fmt::format("{} vertices", n));
  }
  if (!p.normals.empty() && p.normals.size() != 3 * n) {
    return InvalidArgumentError(fmt::format("{} normal floats for {} vertices", p.normals.size(), n));
  }
  if (!p.uvs.empty() && p.uvs.size() != 2 * n) {
    return InvalidArgumentError(fmt::format("{} uv floats for {} vertices", p.uvs.size(), n));
  }
  if (!AllFinite(p.positions) || !AllFinite(p.normals) || !AllFinite(p.uvs)) {
    return InvalidArgumentError("non-finite vertex attribute");
  }
  if (p.indices.empty() || p.indices.size() % 3 != 0) {
    return InvalidArgumentError(fmt::format("{} indices (need a positive multiple of 3)", p.indices.size()));
  }
  for (size_t i = 0; i < p.indices.size(); ++i) {
    if (p.indices[i] >= n) {
      return InvalidArgumentError(fmt::format("index {} is {} (only {} vertices)", i, p.indices[i], n));
    }
  }
  if (p.material && *p.material >= num_materials) {
    return InvalidArgumentError(fmt::format("material {} out of range ({} materials)", *p.material, num_materials));
  }
  return Status::Ok();
}

Status CheckMaterial(const Material& m, size_t num_textures) {
  auto unit = [](float v) { return std::isfinite(v) && v >= 0.0f && v <= 1.0f; };
  // glTF's schema bounds these to [0, 1]; the validator rejects anything else.
  if (!std::all_of(m.base_color.begin(), m.base_color.end(), unit)) {
    return InvalidArgumentError("base_color component outside [0, 1]");
  }
  if (!unit(m.metallic) || !unit(m.roughness)) return InvalidArgumentError("metallic or roughness outside [0, 1]");
  if (m.base_color_texture && *m.base_color_texture >= num_textures) {
    return InvalidArgumentError(
        fmt::format("base_color_texture {} out of range ({} textures)", *m.base_color_texture, num_textures));
  }
  return CheckUtf8(m.name, "name");
}

Status CheckTexture(const Texture& t) {
  if (t.mime_type != "image/png" && t.mime_type != "image/jpeg") {
    return InvalidArgumentError(fmt::format("mime type \"{}\" is neither image/png nor image/jpeg", t.mime_type));
  }
  // The validator sniffs image bytes and fails a file whose mimeType lies.
  if (!MagicMatches(t.bytes, t.mime_type)) return InvalidArgumentError(fmt::format("bytes are not {}", t.mime_type));
  return CheckUtf8(t.name, "name");
}

// The binary chunk under construction: every view starts 4-byte aligned, as
// glTF requires for float accessors and the validator checks for all views.
class BinBuilder {
 public:
  uint32_t Add(std::span<const uint8_t> bytes) {
    bin_.resize((bin_.size() + 3) & ~size_t{3}, 0);
    views_.push_back({{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", bytes.size()}});
    bin_.insert(bin_.end(), bytes.begin(), bytes.end());
    return static_cast<uint32_t>(views_.size() - 1);
  }
  std::vector<uint8_t>& bin() { return bin_; }
  json& views() { return views_; }

 private:
  std::vector<uint8_t> bin_;
  json views_ = json::array();
};

json FloatArray(std::span<const float> v) {
  json a = json::array();
  for (float x : v) a.push_back(x);
  return a;
}

Result<json> WritePrimitive(const Primitive& p, const DracoOptions& options, BinBuilder& bin, json& accessors) {
  SOLID_ASSIGN_OR_RETURN(EncodedPrimitive encoded, EncodeDraco(p, options));
  const Primitive& d = encoded.decoded;
  const size_t n = d.positions.size() / 3;
  std::array<float, 3> min = {d.positions[0], d.positions[1], d.positions[2]}, max = min;
  for (size_t i = 0; i < n; ++i) {
    for (size_t k = 0; k < 3; ++k) {
      min[k] = std::min(min[k], d.positions[3 * i + k]);
      max[k] = std::max(max[k], d.positions[3 * i + k]);
    }
  }
  // Draco-only primitives: accessors carry counts and types but no bufferView.
  auto accessor = [&](json a) {
    accessors.push_back(std::move(a));
    return accessors.size() - 1;
  };
  json draco_attributes = json::object(), attributes = json::object();
  draco_attributes[kPosition] = *encoded.ids.position;
  attributes[kPosition] = accessor(
      {{"componentType", kFloat}, {"count", n}, {"type", "VEC3"}, {"min", FloatArray(min)}, {"max", FloatArray(max)}});
  if (encoded.ids.normal) {
    draco_attributes[kNormal] = *encoded.ids.normal;
    attributes[kNormal] = accessor({{"componentType", kFloat}, {"count", n}, {"type", "VEC3"}});
  }
  if (encoded.ids.texcoord) {
    draco_attributes[kTexcoord] = *encoded.ids.texcoord;
    attributes[kTexcoord] = accessor({{"componentType", kFloat}, {"count", n}, {"type", "VEC2"}});
  }
  // 65535 is the primitive-restart value glTF forbids as an unsigned short index.
  const int index_type = n <= 65535 ? kUnsignedShort : kUnsignedInt;
  json primitive = {
      {"attributes", std::move(attributes)},
      {"indices", accessor({{"componentType", index_type}, {"count", d.indices.size()}, {"type", "SCALAR"}})},
      {"extensions",
       {{kDraco, {{"bufferView", bin.Add(encoded.bytes)}, {"attributes", std::move(draco_attributes)}}}}}};
  if (p.material) primitive["material"] = *p.material;
  return primitive;
}

json WriteMaterial(const Material& m) {
  json pbr = {
      {"baseColorFactor", FloatArray(m.base_color)}, {"metallicFactor", m.metallic}, {"roughnessFactor", m.roughness}};
  if (m.base_color_texture) pbr["baseColorTexture"] = {{"index", *m.base_color_texture}};
  json out = {{"pbrMetallicRoughness", std::move(pbr)}};
  if (!m.name.empty()) out["name"] = m.name;
  if (m.blend) out["alphaMode"] = "BLEND";
  if (m.double_sided) out["doubleSided"] = true;
  return out;
}

void AppendU32(std::vector<uint8_t>& out, uint32_t v) {
  uint8_t b[4];
  std::memcpy(b, &v, 4);
  out.insert(out.end(), b, b + 4);
}

Result<std::vector<uint8_t>> WriteGlbImpl(const Asset& asset, const DracoOptions& options) {
  SOLID_RETURN_IF_ERROR(CheckOptions(options));
  SOLID_RETURN_IF_ERROR(CheckUtf8(asset.extras, "asset extras"));
  for (size_t i = 0; i < asset.textures.size(); ++i) {
    SOLID_RETURN_IF_ERROR(CheckTexture(asset.textures[i]).WithContext(fmt::format("textures[{}]", i)));
  }
  for (size_t i = 0; i < asset.materials.size(); ++i) {
    SOLID_RETURN_IF_ERROR(
        CheckMaterial(asset.materials[i], asset.textures.size()).WithContext(fmt::format("materials[{}]", i)));
  }

  BinBuilder bin;
  json accessors = json::array(), meshes = json::array(), nodes = json::array(), scene_nodes = json::array();
  for (size_t i = 0; i < asset.nodes.size(); ++i) {
    const Node& node = asset.nodes[i];
    SOLID_RETURN_IF_ERROR(CheckUtf8(node.name, fmt::format("nodes[{}]: name", i)));
    const std::string where = fmt::format("nodes[{}] \"{}\"", i, node.name);
    SOLID_RETURN_IF_ERROR(CheckUtf8(node.extras, where + ": extras"));
    // glTF meshes need at least one primitive; converters drop empty objects anyway.
    if (node.primitives.empty()) return InvalidArgumentError(where + ": no primitives");
    json primitives = json::array();
    for (size_t j = 0; j < node.primitives.size(); ++j) {
      const std::string pwhere = fmt::format("{}: primitives[{}]", where, j);
      SOLID_RETURN_IF_ERROR(CheckPrimitive(node.primitives[j], asset.materials.size()).WithContext(pwhere));
      auto primitive = WritePrimitive(node.primitives[j], options, bin, accessors);
      if (!primitive.ok()) return primitive.status().WithContext(pwhere);
      primitives.push_back(std::move(primitive).value());
    }
    json mesh = {{"primitives", std::move(primitives)}};
    json gnode = {{"mesh", meshes.size()}};
    if (!node.name.empty()) mesh["name"] = gnode["name"] = node.name;
    if (!node.extras.empty()) gnode["extras"] = node.extras;
    scene_nodes.push_back(nodes.size());
    meshes.push_back(std::move(mesh));
    nodes.push_back(std::move(gnode));
  }

  json images = json::array(), textures = json::array();
  for (size_t i = 0; i < asset.textures.size(); ++i) {
    const Texture& t = asset.textures[i];
    json image = {{"bufferView", bin.Add(t.bytes)}, {"mimeType", t.mime_type}};
    if (!t.name.empty()) image["name"] = t.name;
    images.push_back(std::move(image));
    textures.push_back({{"sampler", 0}, {"source", i}});
  }

  json gltf = {{"asset", {{"version", "2.0"}, {"generator", "solid " SOLID_VERSION}}}, {"scene", 0}};
  if (!asset.extras.empty()) gltf["asset"]["extras"] = asset.extras;
  json scene = json::object();
  if (!scene_nodes.empty()) scene["nodes"] = std::move(scene_nodes);
  gltf["scenes"] = json::array({std::move(scene)});
  if (!nodes.empty()) {
    gltf["nodes"] = std::move(nodes);
    gltf["meshes"] = std::move(meshes);
    gltf["accessors"] = std::move(accessors);
    gltf["extensionsUsed"] = gltf["extensionsRequired"] = json::array({kDraco});
  }
  if (!asset.materials.empty()) {
    json materials = json::array();
    for (const Material& m : asset.materials) materials.push_back(WriteMaterial(m));
    gltf["materials"] = std::move(materials);
  }
  if (!textures.empty()) {
    gltf["images"] = std::move(images);
    gltf["textures"] = std::move(textures);
    gltf["samplers"] = json::array(
        {{{"magFilter", kLinear}, {"minFilter", kLinearMipmapLinear}, {"wrapS", kRepeat}, {"wrapT", kRepeat}}});
  }
  std::vector<uint8_t>& data = bin.bin();
  data.resize((data.size() + 3) & ~size_t{3}, 0);
  if (!data.empty()) {
    gltf["bufferViews"] = std::move(bin.views());
    gltf["buffers"] = json::array({{{"byteLength", data.size()}}});
  }

  return PackGlb(gltf, data);
}

// ---------------------------------------------------------------------------
// Reader. Every member read goes through these helpers so that a wrong type, a
// missing member or an index out of range becomes a Status naming the member.

uint32_t LoadU32(std::span<const uint8_t> bytes, uint64_t offset) {
  uint32_t v;
  std::memcpy(&v, bytes.data() + offset, 4);
  return v;
}

const json* Find(const json& object, std::string_view key) {
  auto it = object.find(key);
  return it == object.end() ? nullptr : &*it;
}

Result<uint64_t> GetUint(const json& object, std::string_view key, std::optional<uint64_t> fallback = std::nullopt) {
  const json* v = Find(object, key);
  if (v == nullptr) {
    if (fallback) return *fallback;
    return ParseError(fmt::format("missing \"{}\"", key));
  }
  if (!v->is_number_unsigned()) return ParseError(fmt::format("\"{}\" is not a non-negative integer", key));
  return v->get<uint64_t>();
}

Result<uint32_t> GetIndex(const json& object, std::string_view key, size_t count, std::string_view what) {
  SOLID_ASSIGN_OR_RETURN(const uint64_t i, GetUint(object, key));
  if (i >= count) return CorruptError(fmt::format("\"{}\" {} out of range ({} {})", key, i, count, what));
  return static_cast<uint32_t>(i);
}

Result<std::string> GetString(const json& object, std::string_view key, const char* fallback) {
  const json* v = Find(object, key);
  if (v == nullptr) {
    if (fallback != nullptr) return std::string(fallback);
    return ParseError(fmt::format("missing \"{}\"", key));
  }
  if (!v->is_string()) return ParseError(fmt::format("\"{}\" is not a string", key));
  return v->get<std::string>();
}

Result<float> GetFloat(const json& object, std::string_view key, float fallback) {
  const json* v = Find(object, key);
  if (v == nullptr) return fallback;
  if (!v->is_number() || !std::isfinite(v->get<double>())) {
    return ParseError(fmt::format("\"{}\" is not a number", key));
  }
  return v->get<float>();
}

// A member that must be an object when present; nullptr when absent.
Result<const json*> GetObject(const json& object, std::string_view key) {
  const json* v = Find(object, key);
  if (v != nullptr && !v->is_object()) return ParseError(fmt::format("\"{}\" is not an object", key));
  return v;
}

// The accessors of a Draco primitive describe the decoded data (KHR_draco_mesh_compression),
// and the decoder yields float attributes and unsigned integer indices whatever they declare:
// a reader that sized its buffers by such an accessor would misread the mesh.
Status CheckDracoAttributeAccessor(const json& accessor, std::string_view semantic, std::string_view type) {
  SOLID_ASSIGN_OR_RETURN(const std::string declared, GetString(accessor, "type", nullptr));
  if (declared != type) {
    return CorruptError(fmt::format("{} accessor type {}, but Draco decodes {}", semantic, declared, type));
  }
  SOLID_ASSIGN_OR_RETURN(const uint64_t component_type, GetUint(accessor, "componentType"));
  if (component_type != kFloat) {
    return CorruptError(
        fmt::format("{} accessor componentType {}, but Draco decodes floats ({})", semantic, component_type, kFloat));
  }
  return Status::Ok();
}

Status CheckDracoIndicesAccessor(const json& accessor, std::span<const uint32_t> decoded) {
  SOLID_ASSIGN_OR_RETURN(const std::string declared, GetString(accessor, "type", nullptr));
  if (declared != "SCALAR") {
    return CorruptError(fmt::format("indices accessor type {}, but Draco decodes SCALAR", declared));
  }
  SOLID_ASSIGN_OR_RETURN(const uint64_t component_type, GetUint(accessor, "componentType"));
  // The largest value of each type is the primitive restart, which glTF forbids as an index.
  uint64_t restart = 0;
  switch (component_type) {
    case kUnsignedByte: restart = 0xFF; break;
    case kUnsignedShort: restart = 0xFFFF; break;
    case kUnsignedInt: restart = 0xFFFFFFFF; break;
    default:
      return CorruptError(fmt::format("indices accessor componentType {}, but Draco decodes unsigned integers "
                                      "({}, {} or {})",
                                      component_type, kUnsignedByte, kUnsignedShort, kUnsignedInt));
  }
  if (const auto largest = std::max_element(decoded.begin(), decoded.end());
      largest != decoded.end() && *largest >= restart) {
    return CorruptError(fmt::format("indices accessor componentType {} holds indices below {}, but Draco decoded "
                                    "index {}",
                                    component_type, restart, *largest));
  }
  return Status::Ok();
}

class GltfReader {
 public:
  GltfReader(const json& root, std::span<const uint8_t> bin, bool has_bin)
      : root_(root), bin_(bin), has_bin_(has_bin) {}

  Result<Asset> Read();

 private:
  Status Init();
  Result<std::span<const uint8_t>> BufferView(uint32_t index);
  Result<const json*> Accessor(const json& primitive_attributes, const char* semantic);
  Result<std::vector<float>> ReadFloats(uint32_t accessor, int components);
  Result<std::vector<uint32_t>> ReadIndices(uint32_t accessor, size_t num_vertices);
  Result<Primitive> ReadPrimitive(const json& primitive);
  Result<Material> ReadMaterial(const json& material);
  Result<Texture> ReadTexture(const json& texture);

  // A top-level array, empty when absent.
  Result<const json*> TopArray(const char* key) {
    const json* v = Find(root_, key);
    if (v == nullptr) return &empty_;
    if (!v->is_array()) return ParseError(fmt::format("\"{}\" is not an array", key));
    return v;
  }

  const json& root_;
  std::span<const uint8_t> bin_;
  bool has_bin_;
  uint64_t vertices_ = 0, triangles_ = 0;  // over the primitives read so far
  const json empty_ = json::array();
  const json *accessors_ = nullptr, *views_ = nullptr, *buffers_ = nullptr, *images_ = nullptr;
  size_t num_materials_ = 0, num_textures_ = 0;
};

Status GltfReader::Init() {
  SOLID_ASSIGN_OR_RETURN(const json* asset, GetObject(root_, "asset"));
  if (asset == nullptr) return ParseError("missing \"asset\"");
  SOLID_ASSIGN_OR_RETURN(const std::string version, GetString(*asset, "version", nullptr));
  if (!version.starts_with("2.")) return UnsupportedVersionError(fmt::format("glTF version \"{}\"", version));
  SOLID_ASSIGN_OR_RETURN(const json* required, TopArray("extensionsRequired"));
  for (const json& e : *required) {
    if (!e.is_string() || e.get<std::string>() != kDraco) {
      return UnsupportedVersionError(fmt::format("required extension {} is not supported", e.dump()));
    }
  }
  SOLID_ASSIGN_OR_RETURN(accessors_, TopArray("accessors"));
  SOLID_ASSIGN_OR_RETURN(views_, TopArray("bufferViews"));
  SOLID_ASSIGN_OR_RETURN(buffers_, TopArray("buffers"));
  SOLID_ASSIGN_OR_RETURN(images_, TopArray("images"));
  SOLID_ASSIGN_OR_RETURN(const json* materials, TopArray("materials"));
  SOLID_ASSIGN_OR_RETURN(const json* textures, TopArray("textures"));
  num_materials_ = materials->size();
  num_textures_ = textures->size();
  return Status::Ok();
}

Result<std::span<const uint8_t>> GltfReader::BufferView(uint32_t index) {
  const std::string where = fmt::format("bufferViews[{}]", index);
  const json& view = (*views_)[index];
  if (!view.is_object()) return ParseError(where + ": not an object");
  auto body = [&]() -> Result<std::span<const uint8_t>> {
    SOLID_ASSIGN_OR_RETURN(const uint32_t b, GetIndex(view, "buffer", buffers_->size(), "buffers"));
    const json& buffer = (*buffers_)[b];
    if (!buffer.is_object()) return ParseError(fmt::format("buffers[{}]: not an object", b));
    // Only the GLB-stored buffer: external or data-URI buffers are not ours to fetch.
    if (b != 0 || Find(buffer, "uri") != nullptr || !has_bin_) {
      return UnsupportedVersionError(fmt::format("buffers[{}] is not the GLB binary chunk", b));
    }
    SOLID_ASSIGN_OR_RETURN(const uint64_t buffer_length, GetUint(buffer, "byteLength"));
    if (buffer_length > bin_.size()) {
      return CorruptError(
          fmt::format("buffers[0].byteLength {} exceeds the BIN chunk ({} bytes)", buffer_length, bin_.size()));
    }
    SOLID_ASSIGN_OR_RETURN(const uint64_t offset, GetUint(view, "byteOffset", 0));
    SOLID_ASSIGN_OR_RETURN(const uint64_t length, GetUint(view, "byteLength"));
    if (offset > buffer_length || length > buffer_length - offset) {
      return CorruptError(fmt::format("bytes [{}, +{}) overrun buffers[0] ({} bytes)", offset, length, buffer_length));
    }
    return bin_.subspan(offset, length);
  };
  auto r = body();
  if (!r.ok()) return r.status().WithContext(where);
  return r;
}

Result<const json*> GltfReader::Accessor(const json& attributes, const char* semantic) {
  if (Find(attributes, semantic) == nullptr) return nullptr;
  SOLID_ASSIGN_OR_RETURN(const uint32_t i, GetIndex(attributes, semantic, accessors_->size(), "accessors"));
  const json& a = (*accessors_)[i];
  if (!a.is_object()) return ParseError(fmt::format("accessors[{}]: not an object", i));
  return &a;
}

Result<std::vector<float>> GltfReader::ReadFloats(uint32_t index, int components) {
  const std::string where = fmt::format("accessors[{}]", index);
  const json& a = (*accessors_)[index];
  auto body = [&]() -> Result<std::vector<float>> {
    SOLID_ASSIGN_OR_RETURN(const std::string type, GetString(a, "type", nullptr));
    if (type != (components == 3 ? "VEC3" : "VEC2")) return CorruptError(fmt::format("type {}", type));
    SOLID_ASSIGN_OR_RETURN(const uint64_t component_type, GetUint(a, "componentType"));
    const json* normalized_member = Find(a, "normalized");
    const bool normalized = normalized_member != nullptr && *normalized_member == true;
    // FLOAT everywhere, plus the normalized integer forms glTF allows for TEXCOORD.
    uint64_t size = 4;
    if (component_type == kUnsignedByte && normalized && components == 2) {
      size = 1;
    } else if (component_type == kUnsignedShort && normalized && components == 2) {
      size = 2;
    } else if (component_type != kFloat) {
      return UnsupportedVersionError(fmt::format("componentType {}", component_type));
    }
    if (Find(a, "sparse") != nullptr) return UnsupportedVersionError("sparse accessors are not supported");
    if (Find(a, "bufferView") == nullptr) return CorruptError("no bufferView and no Draco data");
    SOLID_ASSIGN_OR_RETURN(const uint32_t v, GetIndex(a, "bufferView", views_->size(), "bufferViews"));
    SOLID_ASSIGN_OR_RETURN(const std::span<const uint8_t> view, BufferView(v));
    SOLID_ASSIGN_OR_RETURN(const uint64_t count, GetUint(a, "count"));
    SOLID_ASSIGN_OR_RETURN(const uint64_t offset, GetUint(a, "byteOffset", 0));
    SOLID_ASSIGN_OR_RETURN(const uint64_t stride_member, GetUint((*views_)[v], "byteStride", 0));
    const uint64_t element = size * static_cast<uint64_t>(components);
    const uint64_t stride = stride_member == 0 ? element : stride_member;
    if (count == 0) return CorruptError("count 0");
    if (stride < element || stride > 252) return CorruptError(fmt::format("byteStride {}", stride));
    // count <= view size keeps (count - 1) * stride from overflowing.
    if (count > view.size() || offset > view.size() || (count - 1) * stride + element > view.size() - offset) {
      return CorruptError(
          fmt::format("{} elements at offset {} overrun bufferViews[{}] ({} bytes)", count, offset, v, view.size()));
    }
    std::vector<float> out(count * static_cast<uint64_t>(components));
    for (uint64_t i = 0; i < count; ++i) {
      const uint8_t* p = view.data() + offset + i * stride;
      for (int k = 0; k < components; ++k) {
        float& dst = out[i * components + k];
        if (size == 4) {
          std::memcpy(&dst, p + 4 * k, 4);
        } else if (size == 2) {
          uint16_t u;
          std::memcpy(&u, p + 2 * k, 2);
          dst = static_cast<float>(u) / 65535.0f;
        } else {
          dst = static_cast<float>(p[k]) / 255.0f;
        }
      }
    }
    if (!AllFinite(out)) return CorruptError("non-finite value");
    return out;
  };
  auto r = body();
  if (!r.ok()) return r.status().WithContext(where);
  return r;
}

Result<std::vector<uint32_t>> GltfReader::ReadIndices(uint32_t index, size_t num_vertices) {
  const std::string where = fmt::format("accessors[{}]", index);
  const json& a = (*accessors_)[index];
  auto body = [&]() -> Result<std::vector<uint32_t>> {
    SOLID_ASSIGN_OR_RETURN(const std::string type, GetString(a, "type", nullptr));
    if (type != "SCALAR") return CorruptError(fmt::format("type {}", type));
    SOLID_ASSIGN_OR_RETURN(const uint64_t component_type, GetUint(a, "componentType"));
    uint64_t size;
    switch (component_type) {
      case kUnsignedByte:
        size = 1;
        break;
      case kUnsignedShort:
        size = 2;
        break;
      case kUnsignedInt:
        size = 4;
        break;
      default:
        return CorruptError(fmt::format("componentType {}", component_type));
    }
    if (Find(a, "sparse") != nullptr) return UnsupportedVersionError("sparse accessors are not supported");
    if (Find(a, "bufferView") == nullptr) return CorruptError("no bufferView and no Draco data");
    SOLID_ASSIGN_OR_RETURN(const uint32_t v, GetIndex(a, "bufferView", views_->size(), "bufferViews"));
    SOLID_ASSIGN_OR_RETURN(const std::span<const uint8_t> view, BufferView(v));
    SOLID_ASSIGN_OR_RETURN(const uint64_t count, GetUint(a, "count"));
    SOLID_ASSIGN_OR_RETURN(const uint64_t offset, GetUint(a, "byteOffset", 0));
    if (count == 0 || count % 3 != 0) {
      return CorruptError(fmt::format("count {} is not a positive multiple of 3", count));
    }
    if (count > view.size() || offset > view.size() || count * size > view.size() - offset) {
      return CorruptError(
          fmt::format("{} indices at offset {} overrun bufferViews[{}] ({} bytes)", count, offset, v, view.size()));
    }
    std::vector<uint32_t> out(count);
    for (uint64_t i = 0; i < count; ++i) {
      uint32_t value = 0;
      std::memcpy(&value, view.data() + offset + i * size, size);
      if (value >= num_vertices) {
        return CorruptError(fmt::format("index {} is {} (only {} vertices)", i, value, num_vertices));
      }
      out[i] = value;
    }
    return out;
  };
  auto r = body();
  if (!r.ok()) return r.status().WithContext(where);
  return r;
}

Result<Primitive> GltfReader::ReadPrimitive(const json& primitive) {
  if (!primitive.is_object()) return ParseError("not an object");
  SOLID_ASSIGN_OR_RETURN(const uint64_t mode, GetUint(primitive, "mode", kTriangles));
  if (mode != kTriangles) return UnsupportedVersionError(fmt::format("mode {} (only triangles)", mode));
  SOLID_ASSIGN_OR_RETURN(const json* attributes, GetObject(primitive, "attributes"));
  if (attributes == nullptr) return ParseError("missing \"attributes\"");
  struct Semantic {
    const char* name;
    int components;
    const json* accessor;
  };
  std::array<Semantic, 3> semantics = {{{kPosition, 3, nullptr}, {kNormal, 3, nullptr}, {kTexcoord, 2, nullptr}}};
  for (Semantic& s : semantics) {
    SOLID_ASSIGN_OR_RETURN(s.accessor, Accessor(*attributes, s.name));
  }
  if (semantics[0].accessor == nullptr) return ParseError("no POSITION attribute");
  // Charged on the accessors' counts before anything is decoded (decoded data must match
  // them). A mesh that many nodes share is charged per node: each node gets a copy.
  SOLID_ASSIGN_OR_RETURN(const uint64_t claimed_vertices, GetUint(*semantics[0].accessor, "count"));
  uint64_t claimed_indices = claimed_vertices;
  if (Find(primitive, "indices") != nullptr) {
    SOLID_ASSIGN_OR_RETURN(const uint32_t i, GetIndex(primitive, "indices", accessors_->size(), "accessors"));
    if (!(*accessors_)[i].is_object()) return ParseError(fmt::format("accessors[{}]: not an object", i));
    SOLID_ASSIGN_OR_RETURN(claimed_indices, GetUint((*accessors_)[i], "count"));
  }
  if (claimed_vertices > kMaxGlbVertices - vertices_ || claimed_indices / 3 > kMaxGlbTriangles - triangles_) {
    return LimitExceededError(fmt::format("{} more vertices and {} more triangles make more than the limits of {} "
                                          "vertices and {} triangles per file",
                                          claimed_vertices, claimed_indices / 3, kMaxGlbVertices, kMaxGlbTriangles));
  }
  vertices_ += claimed_vertices;
  triangles_ += claimed_indices / 3;

  Primitive p;
  if (Find(primitive, "material") != nullptr) {
    SOLID_ASSIGN_OR_RETURN(p.material, GetIndex(primitive, "material", num_materials_, "materials"));
  }
  SOLID_ASSIGN_OR_RETURN(const json* extensions, GetObject(primitive, "extensions"));
  const json* draco = nullptr;
  if (extensions != nullptr) {
    SOLID_ASSIGN_OR_RETURN(draco, GetObject(*extensions, kDraco));
  }
  std::array<std::vector<float>*, 3> outputs = {&p.positions, &p.normals, &p.uvs};
  if (draco != nullptr) {
    SOLID_ASSIGN_OR_RETURN(const uint32_t v, GetIndex(*draco, "bufferView", views_->size(), "bufferViews"));
    SOLID_ASSIGN_OR_RETURN(const std::span<const uint8_t> bytes, BufferView(v));
    SOLID_ASSIGN_OR_RETURN(const json* draco_attributes, GetObject(*draco, "attributes"));
    if (draco_attributes == nullptr) return ParseError(fmt::format("{}: missing \"attributes\"", kDraco));
    DracoIds ids;
    std::array<std::optional<uint32_t>*, 3> id_slots = {&ids.position, &ids.normal, &ids.texcoord};
    for (size_t k = 0; k < semantics.size(); ++k) {
      if (Find(*draco_attributes, semantics[k].name) == nullptr) continue;
      SOLID_ASSIGN_OR_RETURN(const uint64_t id, GetUint(*draco_attributes, semantics[k].name));
      if (id > std::numeric_limits<uint32_t>::max() || semantics[k].accessor == nullptr) {
        return CorruptError(fmt::format("{}: bad attribute {}", kDraco, semantics[k].name));
      }
      *id_slots[k] = static_cast<uint32_t>(id);
    }
    auto decoded = DecodeDraco(bytes, ids);
    if (!decoded.ok()) return decoded.status().WithContext(fmt::format("{} (bufferViews[{}])", kDraco, v));
    p.positions = std::move(decoded->positions);
    p.normals = std::move(decoded->normals);
    p.uvs = std::move(decoded->uvs);
    p.indices = std::move(decoded->indices);
    // The accessors must describe the decoded data (extension spec); a mismatch
    // means the JSON and the Draco stream disagree on what the mesh is.
    const size_t n = p.positions.size() / 3;
    for (size_t k = 0; k < semantics.size(); ++k) {
      if (semantics[k].accessor == nullptr) continue;
      SOLID_ASSIGN_OR_RETURN(const uint64_t count, GetUint(*semantics[k].accessor, "count"));
      if (count != n) {
        return CorruptError(
            fmt::format("{} accessor count {} but Draco decoded {} points", semantics[k].name, count, n));
      }
      if (!id_slots[k]->has_value()) continue;  // read from its own accessor below
      SOLID_ASSIGN_OR_RETURN(const uint64_t i, GetUint(*attributes, semantics[k].name));
      SOLID_RETURN_IF_ERROR(CheckDracoAttributeAccessor(*semantics[k].accessor, semantics[k].name,
                                                        semantics[k].components == 3 ? "VEC3" : "VEC2")
                                .WithContext(fmt::format("accessors[{}]", i)));
    }
    if (Find(primitive, "indices") != nullptr) {
      SOLID_ASSIGN_OR_RETURN(const uint32_t i, GetIndex(primitive, "indices", accessors_->size(), "accessors"));
      if (!(*accessors_)[i].is_object()) return ParseError(fmt::format("accessors[{}]: not an object", i));
      SOLID_ASSIGN_OR_RETURN(const uint64_t count, GetUint((*accessors_)[i], "count"));
      if (count != p.indices.size()) {
        return CorruptError(fmt::format("indices accessor count {} but Draco decoded {}", count, p.indices.size()));
      }
      SOLID_RETURN_IF_ERROR(
          CheckDracoIndicesAccessor((*accessors_)[i], p.indices).WithContext(fmt::format("accessors[{}]", i)));
    }
  }
  // Attributes not in the Draco stream (or every attribute of a plain primitive)
  // come from ordinary accessors.
  for (size_t k = 0; k < semantics.size(); ++k) {
    if (semantics[k].accessor == nullptr || !outputs[k]->empty()) continue;
    SOLID_ASSIGN_OR_RETURN(const uint32_t i, GetUint(*attributes, semantics[k].name));
    SOLID_ASSIGN_OR_RETURN(*outputs[k], ReadFloats(i, semantics[k].components));
  }
  const size_t n = p.positions.size() / 3;
  if ((!p.normals.empty() && p.normals.size() != 3 * n) || (!p.uvs.empty() && p.uvs.size() != 2 * n)) {
    return CorruptError("attribute counts differ");
  }
  if (draco == nullptr) {
    if (Find(primitive, "indices") != nullptr) {
      SOLID_ASSIGN_OR_RETURN(const uint32_t i, GetIndex(primitive, "indices", accessors_->size(), "accessors"));
      if (!(*accessors_)[i].is_object()) return ParseError(fmt::format("accessors[{}]: not an object", i));
      SOLID_ASSIGN_OR_RETURN(p.indices, ReadIndices(i, n));
    } else {
      if (n % 3 != 0) return CorruptError(fmt::format("{} unindexed vertices is not a multiple of 3", n));
      p.indices.resize(n);
      for (size_t i = 0; i < n; ++i) p.indices[i] = static_cast<uint32_t>(i);
    }
  }
  return p;
}

Result<Material> GltfReader::ReadMaterial(const json& material) {
  if (!material.is_object()) return ParseError("not an object");
  Material m;
  // glTF's defaults where a member is absent: white, metallic 1, roughness 1, opaque.
  m.metallic = 1.0f;
  SOLID_ASSIGN_OR_RETURN(m.name, GetString(material, "name", ""));
  SOLID_ASSIGN_OR_RETURN(const json* pbr, GetObject(material, "pbrMetallicRoughness"));
  if (pbr != nullptr) {
    if (const json* c = Find(*pbr, "baseColorFactor"); c != nullptr) {
      if (!c->is_array() || c->size() != 4) return ParseError("\"baseColorFactor\" is not an array of 4 numbers");
      for (size_t k = 0; k < 4; ++k) {
        if (!(*c)[k].is_number() || !std::isfinite((*c)[k].get<double>())) {
          return ParseError("\"baseColorFactor\" is not an array of 4 numbers");
        }
        m.base_color[k] = (*c)[k].get<float>();
      }
    }
    SOLID_ASSIGN_OR_RETURN(m.metallic, GetFloat(*pbr, "metallicFactor", 1.0f));
    SOLID_ASSIGN_OR_RETURN(m.roughness, GetFloat(*pbr, "roughnessFactor", 1.0f));
    SOLID_ASSIGN_OR_RETURN(const json* texture, GetObject(*pbr, "baseColorTexture"));
    if (texture != nullptr) {
      SOLID_ASSIGN_OR_RETURN(m.base_color_texture, GetIndex(*texture, "index", num_textures_, "textures"));
    }
  }
  SOLID_ASSIGN_OR_RETURN(const std::string alpha_mode, GetString(material, "alphaMode", "OPAQUE"));
  m.blend = alpha_mode == "BLEND";
  if (const json* d = Find(material, "doubleSided"); d != nullptr) {
    if (!d->is_boolean()) return ParseError("\"doubleSided\" is not a boolean");
    m.double_sided = d->get<bool>();
  }
  return m;
}

Result<Texture> GltfReader::ReadTexture(const json& texture) {
  if (!texture.is_object()) return ParseError("not an object");
  SOLID_ASSIGN_OR_RETURN(const uint32_t source, GetIndex(texture, "source", images_->size(), "images"));
  const json& image = (*images_)[source];
  auto body = [&]() -> Result<Texture> {
    if (!image.is_object()) return ParseError("not an object");
    if (Find(image, "bufferView") == nullptr) return UnsupportedVersionError("only images stored in a bufferView");
    SOLID_ASSIGN_OR_RETURN(const uint32_t v, GetIndex(image, "bufferView", views_->size(), "bufferViews"));
    SOLID_ASSIGN_OR_RETURN(const std::span<const uint8_t> bytes, BufferView(v));
    Texture t;
    SOLID_ASSIGN_OR_RETURN(t.name, GetString(image, "name", ""));
    SOLID_ASSIGN_OR_RETURN(t.mime_type, GetString(image, "mimeType", nullptr));
    t.bytes.assign(bytes.begin(), bytes.end());
    return t;
  };
  auto r = body();
  if (!r.ok()) return r.status().WithContext(fmt::format("images[{}]", source));
  return r;
}

Result<Asset> GltfReader::Read() {
  SOLID_RETURN_IF_ERROR(Init());
  Asset asset;
  if (const json* extras = Find(*Find(root_, "asset"), "extras"); extras != nullptr) asset.extras = *extras;

  SOLID_ASSIGN_OR_RETURN(const json* materials, TopArray("materials"));
  for (size_t i = 0; i < materials->size(); ++i) {
    auto m = ReadMaterial((*materials)[i]);
    if (!m.ok()) return m.status().WithContext(fmt::format("materials[{}]", i));
    asset.materials.push_back(std::move(m).value());
  }
  SOLID_ASSIGN_OR_RETURN(const json* textures, TopArray("textures"));
  for (size_t i = 0; i < textures->size(); ++i) {
    auto t = ReadTexture((*textures)[i]);
    if (!t.ok()) return t.status().WithContext(fmt::format("textures[{}]", i));
    asset.textures.push_back(std::move(t).value());
  }

  SOLID_ASSIGN_OR_RETURN(const json* nodes, TopArray("nodes"));
  SOLID_ASSIGN_OR_RETURN(const json* meshes, TopArray("meshes"));
  for (size_t i = 0; i < nodes->size(); ++i) {
    const json& gnode = (*nodes)[i];
    const std::string where = fmt::format("nodes[{}]", i);
    if (!gnode.is_object()) return ParseError(where + ": not an object");
    if (Find(gnode, "mesh") == nullptr) continue;
    auto mesh_index = GetIndex(gnode, "mesh", meshes->size(), "meshes");
    if (!mesh_index.ok()) return mesh_index.status().WithContext(where);
    Node node;
    auto name = GetString(gnode, "name", "");
    if (!name.ok()) return name.status().WithContext(where);
    node.name = std::move(name).value();
    if (const json* extras = Find(gnode, "extras"); extras != nullptr) node.extras = *extras;

    const std::string mwhere = fmt::format("meshes[{}]", *mesh_index);
    const json& mesh = (*meshes)[*mesh_index];
    const json* primitives = mesh.is_object() ? Find(mesh, "primitives") : nullptr;
    if (primitives == nullptr || !primitives->is_array() || primitives->empty()) {
      return ParseError(mwhere + ": no \"primitives\" array");
    }
    for (size_t j = 0; j < primitives->size(); ++j) {
      auto p = ReadPrimitive((*primitives)[j]);
      if (!p.ok()) return p.status().WithContext(fmt::format("{}.primitives[{}]", mwhere, j));
      node.primitives.push_back(std::move(p).value());
    }
    asset.nodes.push_back(std::move(node));
  }
  return asset;
}

Result<Asset> ReadGlbImpl(std::span<const uint8_t> bytes) {
  if (bytes.size() < kGlbHeaderSize) {
    return ParseError(fmt::format("{} bytes is shorter than a GLB header", bytes.size()));
  }
  if (LoadU32(bytes, 0) != kGlbMagic) return ParseError("not a GLB file (bad magic)");
  if (const uint32_t version = LoadU32(bytes, 4); version != 2) {
    return UnsupportedVersionError(fmt::format("GLB container version {}", version));
  }
  if (const uint32_t length = LoadU32(bytes, 8); length != bytes.size()) {
    return ParseError(fmt::format("header length {} but the file has {} bytes", length, bytes.size()));
  }
  uint64_t offset = kGlbHeaderSize;
  // One chunk header and body at `offset`, bounds-checked against the file.
  auto chunk = [&](uint32_t& type) -> Result<std::span<const uint8_t>> {
    if (bytes.size() - offset < kChunkHeaderSize) {
      return ParseError(fmt::format("truncated chunk header at offset {}", offset));
    }
    const uint32_t length = LoadU32(bytes, offset);
    type = LoadU32(bytes, offset + 4);
    offset += kChunkHeaderSize;
    if (length > bytes.size() - offset) {
      return ParseError(fmt::format("chunk at offset {} claims {} bytes, {} remain", offset - kChunkHeaderSize, length,
                                    bytes.size() - offset));
    }
    auto body = bytes.subspan(offset, length);
    offset += length;
    return body;
  };
  uint32_t type = 0;
  SOLID_ASSIGN_OR_RETURN(const std::span<const uint8_t> text, chunk(type));
  if (type != kChunkJson) return ParseError("first chunk is not JSON");
  std::span<const uint8_t> bin;
  bool has_bin = false;
  if (offset < bytes.size()) {
    SOLID_ASSIGN_OR_RETURN(bin, chunk(type));
    has_bin = type == kChunkBin;  // other chunk types are for extensions; glTF says ignore them
  }

  bool too_deep = false;
  json root;
  try {
    root = json::parse(text.begin(), text.end(), [&](int depth, json::parse_event_t, json&) {
      if (depth > kMaxJsonDepth) too_deep = true;
      return !too_deep;
    });
  } catch (const json::parse_error& e) {
    return ParseError(fmt::format("JSON chunk: {}", e.what()));
  }
  if (too_deep) return LimitExceededError(fmt::format("JSON nested deeper than {}", kMaxJsonDepth));
  if (!root.is_object()) return ParseError("JSON chunk is not an object");
  GltfReader reader(root, bin, has_bin);
  return reader.Read();
}

}  // namespace

Result<std::vector<uint8_t>> PackGlb(const json& gltf, std::span<const uint8_t> data) {
  SOLID_CHECK(data.size() % 4 == 0);
  std::string text = gltf.dump();  // object keys sorted: the same document gives the same bytes
  text.resize((text.size() + 3) & ~size_t{3}, ' ');

  const uint64_t total =
      kGlbHeaderSize + kChunkHeaderSize + text.size() + (data.empty() ? 0 : kChunkHeaderSize + data.size());
  if (total > std::numeric_limits<uint32_t>::max()) {
    return LimitExceededError(fmt::format("GLB would be {} bytes (limit 4 GiB)", total));
  }
  std::vector<uint8_t> out;
  out.reserve(total);
  AppendU32(out, kGlbMagic);
  AppendU32(out, 2);
  AppendU32(out, static_cast<uint32_t>(total));
  AppendU32(out, static_cast<uint32_t>(text.size()));
  AppendU32(out, kChunkJson);
  out.insert(out.end(), text.begin(), text.end());
  if (!data.empty()) {
    AppendU32(out, static_cast<uint32_t>(data.size()));
    AppendU32(out, kChunkBin);
    out.insert(out.end(), data.begin(), data.end());
  }
  return out;
}

Result<std::vector<uint8_t>> WriteGlb(const Asset& asset, const DracoOptions& options) {
  try {
    return WriteGlbImpl(asset, options);
  } catch (const std::exception& e) {
    return InternalError(fmt::format("glTF writer: {}", e.what()));
  }
}

Result<Asset> ReadGlb(std::span<const uint8_t> bytes, std::string_view name) {
  try {
    auto asset = ReadGlbImpl(bytes);
    if (!asset.ok()) return asset.status().WithContext(name);
    return asset;
  } catch (const std::exception& e) {
    return InternalError(fmt::format("{}: {}", name, e.what()));
  }
}

}  // namespace solid::gltf
