// Assets for rendering: the models and rooms of assets directories (the glb files
// and catalog.sqlite that `solid convert` writes), decoded (Draco) into meshes and
// Embree scenes on first use and kept in a cache with a memory cap (LRU).
//
// Frames: a model's mesh-local frame is its glTF frame rotated to Z-up
// ((x, y, z)_glTF -> (x, -z, y)) and translated so that the centre of its bounding
// box is the origin, as the reference moves the mesh origin (solid-method.md 2.4).
// Rooms keep their glTF placement, rotated to Z-up; room.h rescales them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "solid/formats/asset.h"
#include "solid/formats/status.h"
#include "solid/render/geometry.h"

struct RTCDeviceTy;
struct RTCSceneTy;

namespace solid::render {

inline constexpr uint32_t kNoMaterial = UINT32_MAX;

// Room shell pieces, from node extras.structure ("wall", "floor", "ceiling").
enum class Structure : uint8_t { kOther = 0, kWall = 1, kFloor = 2, kCeiling = 3 };

// All primitives of an asset merged into one indexed triangle mesh.
struct MeshGeometry {
  std::vector<float> positions;             // xyz per vertex
  std::vector<float> normals;               // xyz per vertex (zeros where the source had none)
  std::vector<float> uvs;                   // uv per vertex (zeros where the source had none)
  std::vector<uint32_t> indices;            // three per triangle
  std::vector<uint32_t> triangle_material;  // per triangle: index into materials, or kNoMaterial
  std::vector<Structure> triangle_structure;  // per triangle
  size_t TriangleCount() const { return indices.size() / 3; }
  size_t VertexCount() const { return positions.size() / 3; }
};

// The ray-tracing device every scene of a process lives in (Embree, one per process).
class Device {
 public:
  static Result<std::shared_ptr<Device>> Create();
  ~Device();
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;
  RTCDeviceTy* handle() const { return device_; }

 private:
  explicit Device(RTCDeviceTy* device) : device_(device) {}
  RTCDeviceTy* device_;
};

// A decoded asset with its bottom-level Embree scene (one triangle geometry, id 0,
// whose primitive ids are MeshGeometry triangles). Immutable and thread-safe.
class LoadedAsset {
 public:
  // Builds from a decoded glTF asset. `centre`: translate to the bounding-box centre
  // (models) or keep the placement (rooms). kInvalidArgument for an asset without triangles.
  static Result<std::shared_ptr<const LoadedAsset>> Build(std::shared_ptr<Device> device, std::string key,
                                                          const gltf::Asset& asset, bool centre);
  ~LoadedAsset();
  LoadedAsset(const LoadedAsset&) = delete;
  LoadedAsset& operator=(const LoadedAsset&) = delete;

  const std::string& key() const { return key_; }
  const MeshGeometry& mesh() const { return mesh_; }
  const std::vector<gltf::Material>& materials() const { return materials_; }
  const std::vector<gltf::Texture>& textures() const { return textures_; }
  Vec3 bounds_min() const { return min_; }
  Vec3 bounds_max() const { return max_; }
  Vec3 half_extents() const { return (max_ - min_) * 0.5; }
  double largest_extent() const;
  uint64_t memory_bytes() const { return memory_bytes_; }  // estimate: arrays, textures, BVH
  RTCSceneTy* scene() const { return scene_; }

 private:
  LoadedAsset() = default;
  std::shared_ptr<Device> device_;
  std::string key_;
  MeshGeometry mesh_;
  std::vector<gltf::Material> materials_;
  std::vector<gltf::Texture> textures_;
  Vec3 min_, max_;
  uint64_t memory_bytes_ = 0;
  RTCSceneTy* scene_ = nullptr;
};

// One usable catalog row.
struct AssetEntry {
  std::string key;
  std::filesystem::path file;  // absolute
  uint64_t output_xxh64 = 0;
  int64_t triangles = 0;
};

struct AssetLibraryOptions {
  uint64_t cache_bytes = uint64_t{2} << 30;  // cap of the decoded-asset cache
  uint64_t max_file_bytes = uint64_t{1} << 30;
};

// The models and rooms a layout draws from. Models: catalog rows of kind "model" with
// status ok or ok_with_warnings, sorted by key; rooms: rows of kind "room" likewise.
// Files are checked against the catalog's checksum when loaded.
class AssetLibrary {
 public:
  // `models_dir` and `rooms_dir` are assets directories (they may be the same, and
  // rooms_dir may be empty when no rooms are needed).
  static Result<std::shared_ptr<AssetLibrary>> Open(const std::filesystem::path& models_dir,
                                                    const std::filesystem::path& rooms_dir,
                                                    const AssetLibraryOptions& options = {});

  const std::vector<AssetEntry>& models() const { return models_; }
  const std::vector<AssetEntry>& rooms() const { return rooms_; }
  // XXH64 over the two catalogs' content hashes: identifies the asset set.
  uint64_t catalog_hash() const { return catalog_hash_; }
  const std::shared_ptr<Device>& device() const { return device_; }

  // Loads (or finds in the cache) models()[index] / rooms()[index]. Thread-safe.
  // Errors name the file (kCorrupt for a checksum mismatch or a bad glb).
  Result<std::shared_ptr<const LoadedAsset>> Model(size_t index);
  Result<std::shared_ptr<const LoadedAsset>> Room(size_t index);

  struct CacheStats {
    uint64_t hits = 0, misses = 0, evictions = 0, bytes = 0, entries = 0;
  };
  CacheStats cache_stats() const;
  ~AssetLibrary();

 private:
  struct Cache;
  AssetLibrary() = default;
  Result<std::shared_ptr<const LoadedAsset>> Load(const AssetEntry& entry, bool room);
  std::shared_ptr<Device> device_;
  std::vector<AssetEntry> models_, rooms_;
  uint64_t catalog_hash_ = 0;
  AssetLibraryOptions options_;
  std::unique_ptr<Cache> cache_;
};

}  // namespace solid::render
