// The asset catalog (schemas/catalog.sql): one row per model or room of an assets
// directory, with its provenance (input hash, converter version, options hash) so
// that a rerun converts only what is missing or changed, and its status and
// diagnostics so that a failed model is a row, never a silent gap.
//
// One process writes a catalog at a time (the converter's main thread); readers
// may open it concurrently (WAL). Readers treat the file as untrusted.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/status.h"

namespace solid {

enum class AssetStatus { kOk, kOkWithWarnings, kFailed };
std::string_view AssetStatusName(AssetStatus s);  // "ok", "ok_with_warnings", "failed"

struct CatalogEntry {
  std::string key;
  std::string kind;    // "model" or "room"
  std::string source;  // "shapenet_v1", "shapenet_v2", "scenenet", "procedural", "gltf", "obj"
  std::optional<std::string> file;  // relative .glb path; empty when failed
  AssetStatus status = AssetStatus::kOk;
  nlohmann::json input_files = nlohmann::json::array();
  uint64_t input_hash = 0;
  std::string converter_version;
  uint64_t options_hash = 0;
  int64_t vertices = 0, triangles = 0, materials = 0, textures = 0;
  std::optional<std::array<double, 6>> bounds;  // min xyz, max xyz
  int64_t bytes_in = 0, bytes_out = 0;
  std::optional<uint64_t> output_xxh64;
  nlohmann::json warnings = nlohmann::json::array();  // [{"code", "message"}]
  std::optional<std::string> error_code, error;
  nlohmann::json counts = nlohmann::json::object();
  nlohmann::json extras = nlohmann::json::object();
};

class Catalog {
 public:
  // Creates the file (and its schema) if absent, whole or not at all; refuses a file of
  // another kind or version, except a version-1 catalog, which it migrates to version 2
  // (glTF and OBJ-folder sources) in place. OpenReadOnly reads both versions.
  static Result<Catalog> OpenForWriting(const std::filesystem::path& path);
  static Result<Catalog> OpenReadOnly(const std::filesystem::path& path);
  Catalog(Catalog&&) noexcept;
  Catalog& operator=(Catalog&&) noexcept;
  ~Catalog();

  // Inserts or replaces the row of entry.key, durably (committed and checkpointed into the
  // file before returning, so that the WAL never holds a row the file lacks).
  Status Put(const CatalogEntry& entry);
  Result<std::optional<CatalogEntry>> Find(std::string_view key);
  // Every row, sorted by key.
  Result<std::vector<CatalogEntry>> All();
  // XXH64 over (key, output_xxh64) of every non-failed row in key order: identifies
  // the asset set a dataset was rendered from (Manifest::catalog_hash).
  Result<uint64_t> ContentHash();
  // Checkpoints the write-ahead log into the file, syncing both, and closes: the one place
  // a writer learns that the sync failed. The catalog is unusable afterwards.
  Status Close();

 private:
  struct Impl;
  explicit Catalog(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace solid
