#include "obj_to_asset.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <span>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "solid/formats/checksum.h"
#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"

namespace solid::convert {
// The asset model and its glb codec live in formats (render reads them too).
using namespace solid::gltf;
namespace {

namespace fs = std::filesystem;
using Vec3 = std::array<double, 3>;

Vec3 Sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

Vec3 Cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// Scaled by the largest component first, so that squaring tiny or huge components
// (ShapeNet normals of length 0.001, cross products of small triangles) neither
// underflows nor overflows.
double Length(const Vec3& v) {
  const double largest = std::max({std::abs(v[0]), std::abs(v[1]), std::abs(v[2])});
  if (largest == 0) return 0;
  double sum = 0;
  for (double c : v) sum += (c / largest) * (c / largest);
  return largest * std::sqrt(sum);
}

struct ArrayHash {
  template <size_t N>
  size_t operator()(const std::array<int64_t, N>& a) const {
    return static_cast<size_t>(Xxh64(std::span(reinterpret_cast<const uint8_t*>(a.data()), sizeof(a))));
  }
};

// Triangles equal up to cyclic rotation get the same key: the rotation that starts at the
// smallest position index, unique because a kept triangle has three distinct positions.
size_t FirstCornerOfCanonicalRotation(int64_t v0, int64_t v1, int64_t v2) {
  if (v0 < v1) return v0 < v2 ? 0 : 2;
  return v1 < v2 ? 1 : 2;
}

std::array<int64_t, 9> CanonicalCorners(const std::array<ObjCorner, 3>& c) {
  const size_t first = FirstCornerOfCanonicalRotation(c[0].v, c[1].v, c[2].v);
  std::array<int64_t, 9> key;
  for (size_t i = 0; i < 3; ++i) {
    const ObjCorner& corner = c[(first + i) % 3];
    key[3 * i] = corner.v;
    key[3 * i + 1] = corner.vt;
    key[3 * i + 2] = corner.vn;
  }
  return key;
}

std::array<int64_t, 3> CanonicalPositions(std::array<int64_t, 3> v) {
  std::rotate(v.begin(), v.begin() + static_cast<ptrdiff_t>(FirstCornerOfCanonicalRotation(v[0], v[1], v[2])), v.end());
  return v;
}

std::string AsciiLower(std::string s) {
  for (char& c : s) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return s;
}

fs::path WithoutTrailingSeparator(fs::path p) { return p.has_filename() || !p.has_relative_path() ? p : p.parent_path(); }

// "/x", "//server/x", "C:x", "C:/x" and "file:///x" (after '\' became '/').
bool IsAbsoluteOrUri(std::string_view path) {
  return path.starts_with('/') || path.substr(0, path.find('/')).find(':') != std::string_view::npos;
}

// The sole entry of `target`'s directory whose name equals its name ignoring ASCII case
// (the first in byte order if several do): ShapeNet references "texture0.jpg" beside a
// "texture0.JPG", which works on the case-insensitive file systems it was made on.
std::optional<fs::path> FindIgnoringCase(const fs::path& target) {
  const std::string wanted = AsciiLower(target.filename().string());
  if (wanted.empty()) return std::nullopt;
  std::optional<fs::path> found;
  std::error_code ec;
  for (fs::directory_iterator it(target.parent_path(), ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& candidate = it->path();
    std::error_code exists_ec;
    if (AsciiLower(candidate.filename().string()) == wanted && fs::exists(candidate, exists_ec) &&
        (!found || candidate < *found)) {
      found = candidate;
    }
  }
  return found;
}

Result<std::vector<uint8_t>> ReadFilePrefix(const fs::path& path, uint64_t max_bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return IoError(fmt::format("cannot open {}", path.string()));
  std::vector<uint8_t> bytes(max_bytes);
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(max_bytes));
  if (in.bad()) return IoError(fmt::format("cannot read {}", path.string()));
  bytes.resize(static_cast<size_t>(in.gcount()));
  return bytes;
}

constexpr size_t kMagicBytes = 8;

std::optional<std::string> ImageMimeType(std::span<const uint8_t> bytes) {
  static constexpr std::array<uint8_t, 8> kPng = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  static constexpr std::array<uint8_t, 3> kJpeg = {0xFF, 0xD8, 0xFF};
  if (bytes.size() >= kPng.size() && std::equal(kPng.begin(), kPng.end(), bytes.begin())) return "image/png";
  if (bytes.size() >= kJpeg.size() && std::equal(kJpeg.begin(), kJpeg.end(), bytes.begin())) return "image/jpeg";
  return std::nullopt;
}

// nullopt: no usemtl (and, for kSingleNode, not exactly one MTL material).
using MaterialKey = std::optional<std::string>;

struct KeptTriangle {
  const ObjTriangle* triangle;
  Vec3 geometric_normal;  // unit
};

struct PrimitiveDraft {
  MaterialKey material;
  uint32_t first_line = 0;
  std::vector<KeptTriangle> kept;
  std::unordered_set<std::array<int64_t, 9>, ArrayHash> corner_triples;   // canonical rotations
  std::unordered_set<std::array<int64_t, 3>, ArrayHash> position_triples;  // canonical rotations
};

struct NodeDraft {
  std::string name;
  std::vector<PrimitiveDraft> primitives;
  std::map<MaterialKey, size_t> primitive_of_material;
};

// Well-formed UTF-8 (RFC 3629): no overlong forms, surrogates or code points past U+10FFFF.
bool IsUtf8(std::string_view s) {
  for (size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    size_t n;
    uint32_t cp;
    if (c < 0x80) {
      ++i;
      continue;
    }
    if ((c & 0xE0) == 0xC0) {
      n = 1, cp = c & 0x1F;
    } else if ((c & 0xF0) == 0xE0) {
      n = 2, cp = c & 0x0F;
    } else if ((c & 0xF8) == 0xF0) {
      n = 3, cp = c & 0x07;
    } else {
      return false;
    }
    if (i + n >= s.size()) return false;
    for (size_t k = 1; k <= n; ++k) {
      const auto d = static_cast<unsigned char>(s[i + k]);
      if ((d & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3F);
    }
    static constexpr uint32_t kMin[4] = {0, 0x80, 0x800, 0x10000};
    if (cp < kMin[n] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    i += n + 1;
  }
  return true;
}

std::string Latin1ToUtf8(std::string_view s) {
  std::string out;
  for (char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x80) {
      out += ch;
    } else {
      out += static_cast<char>(0xC0 | (c >> 6));
      out += static_cast<char>(0x80 | (c & 0x3F));
    }
  }
  return out;
}

class Builder {
 public:
  Builder(const ObjData& obj, const MtlData* mtl, const ObjAssetOptions& options)
      : obj_(obj), mtl_(mtl), options_(options) {
    if (mtl_ != nullptr) {
      for (const MtlMaterial& m : mtl_->materials) mtl_material_of_name_.emplace(m.name, &m);
    }
  }

  Result<ObjAsset> Build() {
    // Without a root every texture path would be confined to the working directory.
    if (mtl_ != nullptr && options_.confine_root.empty()) {
      for (const MtlMaterial& m : mtl_->materials) {
        if (m.map_kd) {
          return InvalidArgumentError(fmt::format("{}:{}: material '{}' has a map_Kd but no confine_root was given",
                                                  options_.mtl_name, m.line, m.name));
        }
      }
    }
    if (mtl_ == nullptr && !obj_.mtllibs.empty()) {
      missing_mtl_ = true;
      Warn("missing_mtl", fmt::format("{}: mtllib {} not available; using default materials", options_.obj_name,
                                      fmt::join(obj_.mtllibs, ", ")));
    }
    std::vector<NodeDraft> nodes;
    const std::vector<std::optional<size_t>> node_of_block = AssignNodes(&nodes);
    for (size_t b = 0; b < obj_.blocks.size(); ++b) {
      const ObjFaceBlock& block = obj_.blocks[b];
      result_.counts.triangles_in += block.triangles.size();
      if (block.triangles.empty()) ++result_.counts.empty_blocks_dropped;
      if (!node_of_block[b] || block.triangles.empty()) continue;
      NodeDraft& node = nodes[*node_of_block[b]];
      const MaterialKey key = MaterialKeyOf(block);
      auto [it, inserted] = node.primitive_of_material.emplace(key, node.primitives.size());
      if (inserted) node.primitives.push_back({.material = key, .first_line = block.triangles.front().line});
      for (const ObjTriangle& t : block.triangles) SOLID_RETURN_IF_ERROR(Keep(t, &node.primitives[it->second]));
    }
    for (NodeDraft& draft : nodes) Emit(&draft);
    if (result_.counts.triangles_out == 0) {
      const CleanCounts& c = result_.counts;
      return CorruptError(fmt::format(
          "{}: empty_geometry: no triangle survives ({} in, {} degenerate, {} duplicate, {} in objects not kept)",
          options_.obj_name, c.triangles_in, c.degenerates_removed, c.duplicates_removed,
          c.triangles_in - c.degenerates_removed - c.duplicates_removed));
    }
    MakeNamesUtf8();
    return std::move(result_);
  }

 private:
  // glTF text is UTF-8. Names in another encoding (assimp-testmodels regr01.mtl has the
  // Latin-1 "Terraind\xe6k") are read as Latin-1, which maps every byte, rather than
  // failing the whole model at write time.
  void MakeNamesUtf8() {
    auto fix = [&](std::string* name, std::string_view what) {
      if (IsUtf8(*name)) return;
      std::string utf8 = Latin1ToUtf8(*name);
      Warn("name_not_utf8", fmt::format("{}: {} name '{}' is not UTF-8; read as Latin-1", options_.obj_name, what, utf8));
      *name = std::move(utf8);
    };
    for (Node& n : result_.asset.nodes) fix(&n.name, "object");
    for (Material& m : result_.asset.materials) fix(&m.name, "material");
    for (Texture& t : result_.asset.textures) fix(&t.name, "texture");
  }

  void Warn(std::string code, std::string message) {
    result_.warnings.push_back({.code = std::move(code), .message = std::move(message)});
  }

  // The node of each block (none: its object is not kept).
  std::vector<std::optional<size_t>> AssignNodes(std::vector<NodeDraft>* nodes) const {
    if (options_.grouping == NodeGrouping::kSingleNode) {
      nodes->push_back({.name = options_.node_name});
      return std::vector<std::optional<size_t>>(obj_.blocks.size(), size_t{0});
    }
    struct ObjectRun {
      std::string name;
      std::vector<size_t> blocks;
      bool has_triangles = false;
    };
    std::vector<ObjectRun> runs;
    for (size_t b = 0; b < obj_.blocks.size(); ++b) {
      const ObjFaceBlock& block = obj_.blocks[b];
      const std::string& name = block.object.empty() ? block.group : block.object;
      if (runs.empty() || runs.back().name != name) runs.push_back({.name = name});
      runs.back().blocks.push_back(b);
      runs.back().has_triangles |= !block.triangles.empty();
    }
    // A renamed duplicate must not take a name that a later object has verbatim.
    std::set<std::string> verbatim_names, taken_names;
    for (const ObjectRun& run : runs) {
      if (run.has_triangles) verbatim_names.insert(run.name);
    }
    std::vector<std::optional<size_t>> node_of_block(obj_.blocks.size());
    for (const ObjectRun& run : runs) {
      if (!run.has_triangles) continue;
      std::string name = run.name;
      for (int suffix = 1; taken_names.contains(name) || (name != run.name && verbatim_names.contains(name));
           ++suffix) {
        name = fmt::format("{}.{:03}", run.name, suffix);
      }
      taken_names.insert(name);
      if (options_.keep_object && !options_.keep_object(name)) continue;
      for (size_t b : run.blocks) node_of_block[b] = nodes->size();
      nodes->push_back({.name = std::move(name)});
    }
    return node_of_block;
  }

  MaterialKey MaterialKeyOf(const ObjFaceBlock& block) const {
    if (!block.material.empty()) return block.material;
    if (options_.grouping == NodeGrouping::kSingleNode && mtl_ != nullptr && mtl_->materials.size() == 1) {
      return mtl_->materials.front().name;
    }
    return std::nullopt;
  }

  Status CheckCorner(const ObjCorner& c, uint32_t line) const {
    const auto in_range = [](int64_t index, size_t size, bool optional) {
      return (optional && index == -1) || (index >= 0 && static_cast<uint64_t>(index) < size);
    };
    if (!in_range(c.v, obj_.positions.size(), false) || !in_range(c.vt, obj_.uvs.size(), true) ||
        !in_range(c.vn, obj_.normals.size(), true)) {
      return CorruptError(fmt::format("{}:{}: index_out_of_range: corner {}/{}/{} (0-based) with {} v, {} vt, {} vn",
                                      options_.obj_name, line, c.v, c.vt, c.vn, obj_.positions.size(),
                                      obj_.uvs.size(), obj_.normals.size()));
    }
    for (double x : obj_.positions[static_cast<size_t>(c.v)]) {
      if (!(std::abs(x) <= std::numeric_limits<float>::max())) {
        return CorruptError(fmt::format("{}:{}: position_out_of_range: vertex {} does not fit a float",
                                        options_.obj_name, line, c.v + 1));
      }
    }
    return Status::Ok();
  }

  // Adds `t` to `primitive` unless it is degenerate or a same-winding duplicate.
  Status Keep(const ObjTriangle& t, PrimitiveDraft* primitive) {
    const auto& c = t.corners;
    for (const ObjCorner& corner : c) SOLID_RETURN_IF_ERROR(CheckCorner(corner, t.line));
    CleanCounts& counts = result_.counts;
    if (c[0].v == c[1].v || c[1].v == c[2].v || c[2].v == c[0].v) {
      ++counts.degenerates_removed;
      return Status::Ok();
    }
    const Vec3& p0 = obj_.positions[static_cast<size_t>(c[0].v)];
    const Vec3 cross =
        Cross(Sub(obj_.positions[static_cast<size_t>(c[1].v)], p0), Sub(obj_.positions[static_cast<size_t>(c[2].v)], p0));
    if (cross == Vec3{0, 0, 0}) {
      ++counts.degenerates_removed;
      return Status::Ok();
    }
    if (!primitive->corner_triples.insert(CanonicalCorners(c)).second) {
      ++counts.duplicates_removed;
      return Status::Ok();
    }
    if (primitive->position_triples.contains(CanonicalPositions({c[0].v, c[2].v, c[1].v}))) ++counts.reversed_twins;
    primitive->position_triples.insert(CanonicalPositions({c[0].v, c[1].v, c[2].v}));
    const double length = Length(cross);
    primitive->kept.push_back({&t, {cross[0] / length, cross[1] / length, cross[2] / length}});
    return Status::Ok();
  }

  const MtlMaterial* MtlMaterialOf(const MaterialKey& key) const {
    if (!key) return nullptr;
    auto it = mtl_material_of_name_.find(*key);
    return it == mtl_material_of_name_.end() ? nullptr : it->second;
  }

  void Emit(NodeDraft* draft) {
    Node node{.name = draft->name};
    for (PrimitiveDraft& p : draft->primitives) {
      if (p.kept.empty()) continue;
      const MtlMaterial* source = MtlMaterialOf(p.material);
      Primitive primitive = Weld(p.kept, source != nullptr && source->map_kd.has_value());
      primitive.material = MaterialIndex(p.material, p.first_line);
      node.primitives.push_back(std::move(primitive));
      result_.counts.triangles_out += p.kept.size();
      p = PrimitiveDraft{};  // frees the duplicate sets before the next primitive is welded
    }
    if (!node.primitives.empty()) result_.asset.nodes.push_back(std::move(node));
  }

  Primitive Weld(const std::vector<KeptTriangle>& kept, bool textured) {
    bool has_normals = false, has_uvs = textured;
    for (const KeptTriangle& k : kept) {
      for (const ObjCorner& c : k.triangle->corners) {
        has_normals |= c.vn >= 0;
        has_uvs |= c.vt >= 0;
      }
    }
    CleanCounts& counts = result_.counts;
    Primitive out;
    // (v, vt, vn), or (v, vt, -1, bits of the normal) for a corner that takes its
    // triangle's geometric normal: triangles sharing such a corner may need different
    // normals, so they share a vertex only when those normals are equal.
    std::unordered_map<std::array<int64_t, 6>, uint32_t, ArrayHash> vertex_of;
    for (const KeptTriangle& k : kept) {
      for (const ObjCorner& c : k.triangle->corners) {
        std::array<int64_t, 6> key = {c.v, -1, -1, 0, 0, 0};
        if (has_uvs) {
          key[1] = c.vt;
          if (c.vt < 0) ++counts.uvs_filled;
        }
        std::array<float, 3> normal{};
        if (has_normals) {
          const Vec3 vn = c.vn >= 0 ? obj_.normals[static_cast<size_t>(c.vn)] : Vec3{0, 0, 0};
          const double length = Length(vn);
          if (c.vn >= 0 && length > 0) {
            if (std::abs(length - 1) > 1e-6) ++counts.normals_renormalized;
            key[2] = c.vn;
            for (size_t i = 0; i < 3; ++i) normal[i] = static_cast<float>(vn[i] / length);
          } else {
            ++(c.vn >= 0 ? counts.zero_normals : counts.normals_from_geometry);
            for (size_t i = 0; i < 3; ++i) {
              normal[i] = static_cast<float>(k.geometric_normal[i]);
              key[3 + i] = std::bit_cast<uint32_t>(normal[i]);
            }
          }
        }
        auto [it, inserted] = vertex_of.emplace(key, static_cast<uint32_t>(out.positions.size() / 3));
        out.indices.push_back(it->second);
        if (!inserted) continue;
        for (double x : obj_.positions[static_cast<size_t>(c.v)]) out.positions.push_back(static_cast<float>(x));
        if (has_normals) out.normals.insert(out.normals.end(), normal.begin(), normal.end());
        if (has_uvs) {
          // OBJ's v grows upwards, glTF's downwards; values outside [0, 1] are tiling and kept.
          const std::array<double, 2> uv = c.vt >= 0 ? obj_.uvs[static_cast<size_t>(c.vt)] : std::array<double, 2>{0, 0};
          out.uvs.push_back(static_cast<float>(uv[0]));
          out.uvs.push_back(static_cast<float>(1.0 - uv[1]));
        }
      }
    }
    return out;
  }

  std::optional<uint32_t> MaterialIndex(const MaterialKey& key, uint32_t first_line) {
    if (!key) return std::nullopt;
    if (auto it = material_index_of_name_.find(*key); it != material_index_of_name_.end()) return it->second;
    MtlMaterial source;
    if (const MtlMaterial* defined = MtlMaterialOf(key)) {
      source = *defined;
    } else {
      source.name = *key;
      if (!missing_mtl_) {
        Warn("undefined_material",
             fmt::format("{}:{}: usemtl '{}' is not defined{}; using a default material", options_.obj_name,
                         first_line, *key, mtl_ == nullptr ? " (no MTL)" : " in " + options_.mtl_name));
      }
    }
    // glTF requires factors in [0, 1]; some exporters write Kd above 1.
    const auto factor = [](double x) { return static_cast<float>(std::clamp(x, 0.0, 1.0)); };
    Material material{.name = source.name,
                      .base_color = {factor(source.kd[0]), factor(source.kd[1]), factor(source.kd[2]), factor(source.d)},
                      .blend = source.d < 1,
                      .metallic = 0.0f};
    if (source.map_kd) material.base_color_texture = ResolveTexture(source);
    if (source.map_d) {
      Warn("alpha_map_ignored", fmt::format("{}:{}: material '{}': map_d '{}' is not applied", options_.mtl_name,
                                            source.line, source.name, *source.map_d));
    }
    const auto index = static_cast<uint32_t>(result_.asset.materials.size());
    result_.asset.materials.push_back(std::move(material));
    material_index_of_name_.emplace(*key, index);
    return index;
  }

  std::optional<uint32_t> RejectTexture(const std::string& where, std::string_view code, std::string_view why) {
    Warn(std::string(code), fmt::format("{}: {}; using Kd", where, why));
    ++result_.counts.textures_rejected;
    return std::nullopt;
  }

  std::optional<uint32_t> MissingTexture(const std::string& where, std::string_view why) {
    Warn("missing_texture", fmt::format("{}: {}; using Kd", where, why));
    ++result_.counts.textures_missing;
    return std::nullopt;
  }

  // The texture index of `m.map_kd`, after the checks of input-formats section 4; none
  // when it is unusable (with a warning) or when textures are only validated.
  std::optional<uint32_t> ResolveTexture(const MtlMaterial& m) {
    const std::string where =
        fmt::format("{}:{}: material '{}': map_Kd '{}'", options_.mtl_name, m.line, m.name, *m.map_kd);
    std::string written = *m.map_kd;
    std::replace(written.begin(), written.end(), '\\', '/');
    if (IsAbsoluteOrUri(written)) return RejectTexture(where, "texture_path_rejected", "absolute path or URI");
    std::error_code ec;
    const fs::path root = WithoutTrailingSeparator(fs::absolute(options_.confine_root, ec).lexically_normal());
    fs::path target = (fs::absolute(options_.mtl_dir, ec) / written).lexically_normal();
    if (!files::IsInside(target, root)) return RejectTexture(where, "texture_path_rejected", "leaves the model folder");
    if (!fs::exists(target, ec)) {
      const std::optional<fs::path> match = FindIgnoringCase(target);
      if (!match) return MissingTexture(where, "no such file");
      Warn("texture_case_mismatch",
           fmt::format("{}: no such file; using '{}'", where, match->filename().string()));
      target = *match;
    }
    // Checked again on the real path: a symbolic link inside the folder may point anywhere.
    const fs::path real = fs::canonical(target, ec);
    if (ec || !files::IsInside(real, fs::weakly_canonical(root, ec))) {
      return RejectTexture(where, "texture_path_rejected", "leaves the model folder through a symbolic link");
    }
    const bool validate_only = options_.textures == TextureMode::kValidateOnly;
    if (fs::is_directory(real, ec)) {
      // SceneNet names a texture_library category folder; a file is picked at render time.
      if (validate_only) return std::nullopt;
      return RejectTexture(where, "texture_is_directory", "a directory");
    }
    if (!fs::is_regular_file(real, ec)) return RejectTexture(where, "unsupported_texture", "not a regular file");
    const uint64_t size = fs::file_size(real, ec);
    if (ec) return MissingTexture(where, ec.message());
    if (size > options_.max_texture_bytes) {
      return RejectTexture(where, "texture_too_large",
                           fmt::format("{} bytes, over the limit of {}", size, options_.max_texture_bytes));
    }
    Result<std::vector<uint8_t>> bytes = ReadFilePrefix(real, validate_only ? kMagicBytes : size);
    if (!bytes.ok()) return MissingTexture(where, bytes.status().message());
    const std::optional<std::string> mime_type = ImageMimeType(*bytes);
    if (!mime_type) return RejectTexture(where, "unsupported_texture", "neither PNG nor JPEG");
    if (validate_only) return std::nullopt;
    // The renderer decodes what is embedded: refuse a decompression bomb here, where
    // the warning names the file, rather than failing every image that draws the model.
    const ImageFormat format = *mime_type == "image/png" ? ImageFormat::kPng : ImageFormat::kJpeg;
    Result<ImageHeader> header = ReadImageHeader(*bytes, format, {UINT32_MAX, UINT64_MAX});
    if (!header.ok()) return RejectTexture(where, "unsupported_texture", header.status().message());
    if (!kTextureLimits.Admit(header->width, header->height)) {
      return RejectTexture(where, "texture_too_large",
                           fmt::format("{}x{} pixels, over the limits of {} per side and {} pixels", header->width,
                                       header->height, kTextureLimits.max_side, kTextureLimits.max_pixels));
    }
    auto [it, inserted] =
        texture_index_of_file_.emplace(real.string(), static_cast<uint32_t>(result_.asset.textures.size()));
    if (inserted) {
      result_.asset.textures.push_back(
          {.name = real.filename().string(), .mime_type = *mime_type, .bytes = std::move(bytes).value()});
      ++result_.counts.textures_embedded;
    }
    return it->second;
  }

  const ObjData& obj_;
  const MtlData* mtl_;
  const ObjAssetOptions& options_;
  std::unordered_map<std::string, const MtlMaterial*> mtl_material_of_name_;
  std::unordered_map<std::string, uint32_t> material_index_of_name_;
  std::unordered_map<std::string, uint32_t> texture_index_of_file_;
  bool missing_mtl_ = false;
  ObjAsset result_;
};

}  // namespace

Result<ObjAsset> BuildAssetFromObj(const ObjData& obj, const MtlData* mtl, const ObjAssetOptions& options) {
  return Builder(obj, mtl, options).Build();
}

}  // namespace solid::convert
