#include "solid/render/assets.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <list>
#include <mutex>
#include <unordered_map>

#include <fmt/format.h>

#include "solid/formats/catalog.h"
#include "solid/formats/checksum.h"
#include "solid/formats/files.h"
#include "solid/formats/glb.h"

namespace solid::render {

Result<std::shared_ptr<Device>> Device::Create() {
  // One thread per core is Embree's default; builds run on the calling thread's TBB arena.
  RTCDevice device = rtcNewDevice(nullptr);
  if (device == nullptr) return InternalError("Embree: rtcNewDevice failed (CPU without SSE2?)");
  return std::shared_ptr<Device>(new Device(device));
}

Device::~Device() { rtcReleaseDevice(device_); }

namespace {

Structure ParseStructure(const nlohmann::json& extras) {
  if (!extras.is_object()) return Structure::kOther;
  const auto it = extras.find("structure");
  if (it == extras.end() || !it->is_string()) return Structure::kOther;
  const std::string& s = it->get_ref<const std::string&>();
  if (s == "wall") return Structure::kWall;
  if (s == "floor") return Structure::kFloor;
  if (s == "ceiling") return Structure::kCeiling;
  return Structure::kOther;
}

}  // namespace

double LoadedAsset::largest_extent() const {
  const Vec3 e = max_ - min_;
  return std::max({e.x, e.y, e.z});
}

Result<std::shared_ptr<const LoadedAsset>> LoadedAsset::Build(std::shared_ptr<Device> device, std::string key,
                                                              const gltf::Asset& asset, bool centre) {
  std::shared_ptr<LoadedAsset> out(new LoadedAsset());
  out->device_ = std::move(device);
  out->key_ = std::move(key);
  MeshGeometry& m = out->mesh_;
  for (const gltf::Node& node : asset.nodes) {
    const Structure structure = ParseStructure(node.extras);
    for (const gltf::Primitive& p : node.primitives) {
      const size_t base = m.VertexCount();
      const size_t n = p.positions.size() / 3;
      if (base + n > UINT32_MAX / 2) return LimitExceededError(out->key_ + ": more than 2^31 vertices");
      for (size_t v = 0; v < n; ++v) {
        // glTF +Y up to our +Z up: (x, y, z) -> (x, -z, y).
        m.positions.insert(m.positions.end(), {p.positions[3 * v], -p.positions[3 * v + 2], p.positions[3 * v + 1]});
        if (p.normals.size() == p.positions.size()) {
          m.normals.insert(m.normals.end(), {p.normals[3 * v], -p.normals[3 * v + 2], p.normals[3 * v + 1]});
        } else {
          m.normals.insert(m.normals.end(), {0.0f, 0.0f, 0.0f});
        }
        if (p.uvs.size() == 2 * n) {
          m.uvs.insert(m.uvs.end(), {p.uvs[2 * v], p.uvs[2 * v + 1]});
        } else {
          m.uvs.insert(m.uvs.end(), {0.0f, 0.0f});
        }
      }
      for (size_t i = 0; i + 2 < p.indices.size(); i += 3) {
        for (int k = 0; k < 3; ++k) m.indices.push_back(static_cast<uint32_t>(base + p.indices[i + k]));
        m.triangle_material.push_back(p.material.has_value() ? *p.material : kNoMaterial);
        m.triangle_structure.push_back(structure);
      }
    }
  }
  if (m.indices.empty()) return InvalidArgumentError(out->key_ + ": the asset has no triangles");
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (size_t v = 0; v < m.VertexCount(); ++v) {
    lo = {std::min<double>(lo.x, m.positions[3 * v]), std::min<double>(lo.y, m.positions[3 * v + 1]),
          std::min<double>(lo.z, m.positions[3 * v + 2])};
    hi = {std::max<double>(hi.x, m.positions[3 * v]), std::max<double>(hi.y, m.positions[3 * v + 1]),
          std::max<double>(hi.z, m.positions[3 * v + 2])};
  }
  if (centre) {
    const Vec3 c = (lo + hi) * 0.5;
    for (size_t v = 0; v < m.VertexCount(); ++v) {
      m.positions[3 * v] = static_cast<float>(m.positions[3 * v] - c.x);
      m.positions[3 * v + 1] = static_cast<float>(m.positions[3 * v + 1] - c.y);
      m.positions[3 * v + 2] = static_cast<float>(m.positions[3 * v + 2] - c.z);
    }
    lo = lo - c;
    hi = hi - c;
  }
  out->min_ = lo;
  out->max_ = hi;
  out->materials_ = asset.materials;
  out->textures_ = asset.textures;

  RTCDevice dev = out->device_->handle();
  RTCScene scene = rtcNewScene(dev);
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geometry = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
  // Embree may read up to 16 bytes past the last vertex: pad the vertex array.
  m.positions.reserve(m.positions.size() + 4);
  rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m.positions.data(), 0,
                             3 * sizeof(float), m.VertexCount());
  rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m.indices.data(), 0,
                             3 * sizeof(uint32_t), m.TriangleCount());
  rtcCommitGeometry(geometry);
  rtcAttachGeometryByID(scene, geometry, 0);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(scene);
  if (rtcGetDeviceError(dev) != RTC_ERROR_NONE) {
    rtcReleaseScene(scene);
    return InternalError(out->key_ + ": Embree could not build the scene (out of memory?)");
  }
  out->scene_ = reinterpret_cast<RTCSceneTy*>(scene);
  uint64_t bytes = (m.positions.capacity() + m.normals.size() + m.uvs.size()) * sizeof(float) +
                   (m.indices.size() + m.triangle_material.size()) * sizeof(uint32_t) + m.triangle_structure.size();
  for (const gltf::Texture& t : out->textures_) bytes += t.bytes.size();
  // A high-quality BVH over triangles costs about 64 bytes per triangle (Embree's
  // documentation of its memory use gives 50-100).
  bytes += 64 * m.TriangleCount();
  out->memory_bytes_ = bytes;
  return std::shared_ptr<const LoadedAsset>(std::move(out));
}

LoadedAsset::~LoadedAsset() {
  if (scene_ != nullptr) rtcReleaseScene(reinterpret_cast<RTCScene>(scene_));
}

// LRU over loaded assets, charged by LoadedAsset::memory_bytes. The cache drops its
// reference on eviction; layouts that still hold an asset keep it alive.
struct AssetLibrary::Cache {
  struct Entry {
    std::shared_ptr<const LoadedAsset> asset;
    std::list<std::string>::iterator position;
  };
  std::mutex mutex;
  std::list<std::string> order;  // most recently used first
  std::unordered_map<std::string, Entry> entries;
  CacheStats stats;

  std::shared_ptr<const LoadedAsset> Find(const std::string& key) {
    std::lock_guard lock(mutex);
    const auto it = entries.find(key);
    if (it == entries.end()) {
      ++stats.misses;
      return nullptr;
    }
    ++stats.hits;
    order.splice(order.begin(), order, it->second.position);
    return it->second.asset;
  }

  std::shared_ptr<const LoadedAsset> Insert(const std::string& key, std::shared_ptr<const LoadedAsset> asset,
                                            uint64_t cap) {
    std::lock_guard lock(mutex);
    const auto it = entries.find(key);
    if (it != entries.end()) return it->second.asset;  // another thread loaded it meanwhile
    order.push_front(key);
    stats.bytes += asset->memory_bytes();
    entries.emplace(key, Entry{asset, order.begin()});
    while (stats.bytes > cap && order.size() > 1) {
      const auto victim = entries.find(order.back());
      stats.bytes -= victim->second.asset->memory_bytes();
      entries.erase(victim);
      order.pop_back();
      ++stats.evictions;
    }
    stats.entries = entries.size();
    return asset;
  }
};

AssetLibrary::~AssetLibrary() = default;

Result<std::shared_ptr<AssetLibrary>> AssetLibrary::Open(const std::filesystem::path& models_dir,
                                                         const std::filesystem::path& rooms_dir,
                                                         const AssetLibraryOptions& options) {
  std::shared_ptr<AssetLibrary> lib(new AssetLibrary());
  lib->options_ = options;
  lib->cache_ = std::make_unique<Cache>();
  SOLID_ASSIGN_OR_RETURN(lib->device_, Device::Create());
  uint64_t hashes[2] = {0, 0};
  const std::filesystem::path dirs[2] = {models_dir, rooms_dir};
  for (int d = 0; d < 2; ++d) {
    if (dirs[d].empty()) continue;
    const std::filesystem::path catalog_path = dirs[d] / "catalog.sqlite";
    if (!std::filesystem::exists(catalog_path)) {
      return NotFoundError(fmt::format("{}: no catalog.sqlite; is this an assets directory written by "
                                       "convert::Convert?",
                                       dirs[d].string()));
    }
    SOLID_ASSIGN_OR_RETURN(Catalog catalog, Catalog::OpenReadOnly(catalog_path));
    SOLID_ASSIGN_OR_RETURN(std::vector<CatalogEntry> rows, catalog.All());
    SOLID_ASSIGN_OR_RETURN(hashes[d], catalog.ContentHash());
    const std::string wanted = d == 0 ? "model" : "room";
    for (const CatalogEntry& row : rows) {
      if (row.kind != wanted || row.status == AssetStatus::kFailed || !row.file.has_value()) continue;
      // Catalog rows are untrusted: a file must stay inside its assets directory.
      Result<std::filesystem::path> file = files::ResolveInside(dirs[d], *row.file);
      if (!file.ok()) return file.status().WithContext(fmt::format("{}: row '{}'", catalog_path.string(), row.key));
      AssetEntry e{row.key, std::move(file).value(), row.output_xxh64.value_or(0), row.triangles};
      (d == 0 ? lib->models_ : lib->rooms_).push_back(std::move(e));
    }
  }
  auto by_key = [](const AssetEntry& a, const AssetEntry& b) { return a.key < b.key; };
  std::sort(lib->models_.begin(), lib->models_.end(), by_key);
  std::sort(lib->rooms_.begin(), lib->rooms_.end(), by_key);
  const std::string joined = Hex64(hashes[0]) + Hex64(hashes[1]);
  lib->catalog_hash_ = Xxh64(joined);
  return lib;
}

Result<std::shared_ptr<const LoadedAsset>> AssetLibrary::Load(const AssetEntry& entry, bool room) {
  // Model and room keys come from different catalogs and may coincide.
  const std::string cache_key = (room ? "room:" : "model:") + entry.key;
  if (auto hit = cache_->Find(cache_key)) return hit;
  SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, files::ReadFile(entry.file, options_.max_file_bytes));
  if (entry.output_xxh64 != 0 && Xxh64(bytes) != entry.output_xxh64) {
    return CorruptError(fmt::format("{}: checksum {} differs from the catalog's {}; reconvert the asset",
                                    entry.file.string(), Hex64(Xxh64(bytes)), Hex64(entry.output_xxh64)));
  }
  SOLID_ASSIGN_OR_RETURN(gltf::Asset asset, gltf::ReadGlb(bytes, entry.file.string()));
  SOLID_ASSIGN_OR_RETURN(std::shared_ptr<const LoadedAsset> loaded,
                         LoadedAsset::Build(device_, entry.key, asset, /*centre=*/!room));
  return cache_->Insert(cache_key, std::move(loaded), options_.cache_bytes);
}

Result<std::shared_ptr<const LoadedAsset>> AssetLibrary::Model(size_t index) {
  if (index >= models_.size()) return InvalidArgumentError(fmt::format("model index {} out of range", index));
  return Load(models_[index], false);
}

Result<std::shared_ptr<const LoadedAsset>> AssetLibrary::Room(size_t index) {
  if (index >= rooms_.size()) return InvalidArgumentError(fmt::format("room index {} out of range", index));
  return Load(rooms_[index], true);
}

AssetLibrary::CacheStats AssetLibrary::cache_stats() const {
  std::lock_guard lock(cache_->mutex);
  return cache_->stats;
}

}  // namespace solid::render
