#include "render/dataset_digest.h"

#include <fmt/format.h>

#include "solid/formats/checksum.h"
#include "solid/formats/dataset.h"
#include "solid/formats/shard.h"

namespace solid::render::testing {

Result<DatasetDigest> DigestDataset(const std::filesystem::path& root) {
  SOLID_ASSIGN_OR_RETURN(Dataset dataset, Dataset::Open(root));
  DatasetDigest digest;
  SOLID_RETURN_IF_ERROR(dataset.ForEachImage([&](const ImageRecord& image, const std::vector<InstanceRecord>& instances) {
    std::string text = fmt::format("{} {} {}x{} {} {} {}", image.image_id, image.seed, image.width, image.height,
                                   Xxh64(image.image), image.depth_exr ? Xxh64(*image.depth_exr) : 0,
                                   image.room_key.value_or("-"));
    for (double v : image.camera.world_from_camera) text += fmt::format(" {}", v);
    for (const InstanceRecord& i : instances) {
      text += fmt::format("|{} {} {} {} {} {}", i.ordinal, i.model_key, i.visible_rle, i.full_rle, i.truncation,
                          i.view_azimuth);
      for (double v : i.world_from_object) text += fmt::format(" {}", v);
    }
    digest.images[image.image_id] = Xxh64(text);
    return Status::Ok();
  }));
  for (const ShardFile& file : dataset.shards().queries) {
    SOLID_ASSIGN_OR_RETURN(QueryShardReader reader, QueryShardReader::Open(file.path));
    SOLID_ASSIGN_OR_RETURN(std::vector<QueryModelRecord> models, reader.Models());
    for (const QueryModelRecord& m : models) {
      SOLID_ASSIGN_OR_RETURN(std::vector<QueryViewRecord> views, dataset.QueryViews(m.model_key));
      std::string text = fmt::format("{} {}", m.view_count, m.failure.value_or("-"));
      for (const QueryViewRecord& v : views) {
        text += fmt::format("|{} {} {} {}x{} {} {} {} {} {}", v.view_index, v.azimuth, v.elevation, v.width, v.height,
                            Xxh64(v.image), v.box.x, v.box.y, v.box.w, v.box.h);
      }
      digest.query_models[m.model_key] = Xxh64(text);
    }
  }
  return digest;
}

}  // namespace solid::render::testing
