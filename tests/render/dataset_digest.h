// What a rendered dataset holds, image by image, as checksums: two datasets are the
// same data exactly when their digests are equal, whatever their shard files look like.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "solid/formats/status.h"

namespace solid::render::testing {

struct DatasetDigest {
  // image id -> XXH64 over the encoded image, its depth, camera, room and every instance.
  std::map<int64_t, uint64_t> images;
  // model key -> XXH64 over its query views (images, angles, boxes).
  std::map<std::string, uint64_t> query_models;
  friend bool operator==(const DatasetDigest&, const DatasetDigest&) = default;
};

Result<DatasetDigest> DigestDataset(const std::filesystem::path& root);

}  // namespace solid::render::testing
