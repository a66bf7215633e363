#include "solid/export/coco.h"

#include <fmt/format.h>

#include <chrono>
#include <map>
#include <nlohmann/json.hpp>
#include <system_error>
#include <utility>

#include "solid/formats/dataset.h"
#include "solid/formats/files.h"

namespace solid::exporters {
namespace {

namespace fs = std::filesystem;

std::string_view Extension(ImageFormat f) {
  switch (f) {
    case ImageFormat::kPng: return "png";
    case ImageFormat::kJpeg: return "jpg";
    case ImageFormat::kWebp: return "webp";
  }
  return "bin";
}

nlohmann::json BoxJson(const rle::Box& b) { return nlohmann::json::array({b.x, b.y, b.w, b.h}); }

// Removed first: the old file may be a hard link into another export.
Status WriteBytes(const fs::path& path, const std::vector<uint8_t>& bytes) {
  std::error_code ec;
  fs::remove(path, ec);
  return files::WritePlainFile(path, bytes);
}

Status LinkImage(const fs::path& from, const fs::path& to, const ImageRecord& image, const fs::path& shard) {
  std::error_code ec;
  if (fs::equivalent(from, to, ec)) return Status::Ok();
  const uintmax_t size = fs::file_size(from, ec);
  if (ec) {
    return OptionError("link_from", fmt::format("{}: {}: not an export of this dataset", from.string(), ec.message()),
                       StatusCode::kNotFound);
  }
  Result<std::vector<uint8_t>> bytes =
      size == image.image.size() ? files::ReadFile(from, size) : Result<std::vector<uint8_t>>(std::vector<uint8_t>{});
  if (!bytes.ok()) return bytes.status();
  if (*bytes != image.image) {
    return OptionError("link_from",
                       fmt::format("{}: differs from image {} of {}: not an export of this dataset", from.string(),
                                   image.image_id, shard.string()),
                       StatusCode::kCorrupt);
  }
  fs::remove(to, ec);
  fs::create_hard_link(from, to, ec);
  if (ec) return IoError(fmt::format("{}: cannot hard-link to {}: {}", to.string(), from.string(), ec.message()));
  return Status::Ok();
}

nlohmann::json Annotation(const InstanceRecord& in, int64_t id, int64_t category, const Manifest& m, CocoMasks masks) {
  const nlohmann::json size = nlohmann::json::array({m.height, m.width});
  const bool full = masks == CocoMasks::kFull;
  nlohmann::json a = {
      {"id", id},
      {"image_id", in.image_id},
      {"category_id", category},
      {"segmentation", {{"size", size}, {"counts", full ? in.full_rle : in.visible_rle}}},
      {"area", full ? in.full_area : in.visible_area},
      {"bbox", BoxJson(full ? in.full_box : in.visible_box)},
      {"iscrowd", 0},
      {"model_key", in.model_key},
      {"occlusion", in.occlusion ? nlohmann::json(*in.occlusion) : nlohmann::json()},
      {"truncation", in.truncation},
  };
  if (full) {
    a["visible_bbox"] = BoxJson(in.visible_box);
    a["visible_area"] = in.visible_area;
  } else {
    a["full_bbox"] = BoxJson(in.full_box);
    a["full_area"] = in.full_area;
  }
  if (masks == CocoMasks::kBoth) a["full_segmentation"] = {{"size", size}, {"counts", in.full_rle}};
  return a;
}

Status Stopped(const CocoExportOptions& options, int64_t images, int64_t planned) {
  return CancelledError(fmt::format("{}: stopped after {} of {} images; annotations.json not written",
                                    options.out_dir.string(), images, planned));
}

}  // namespace

nlohmann::json CocoExportReport::ToJson() const {
  return {{"annotations_file", annotations_file.string()},
          {"images", images},
          {"annotations", annotations},
          {"categories", categories},
          {"skipped_invisible", skipped_invisible},
          {"image_bytes", image_bytes},
          {"seconds", seconds}};
}

std::string CocoExportReport::ToText() const {
  return fmt::format("{}: {} images, {} annotations in {} categor{} ({} instances with an empty mask skipped), "
                     "{:.1f} MB of images, {:.2f} s\n",
                     annotations_file.string(), images, annotations, categories, categories == 1 ? "y" : "ies",
                     skipped_invisible, static_cast<double>(image_bytes) / 1e6, seconds);
}

Result<CocoExportReport> ExportCoco(const CocoExportOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (options.images == CocoImages::kLink && options.link_from.empty()) {
    return OptionError("link_from", "needed to link the images: they live inside the shards, so there is "
                                    "nothing to link to but an earlier export (or copy them)");
  }
  if (options.dataset.empty()) return OptionError("dataset", "no dataset directory given");
  if (options.out_dir.empty()) return OptionError("out_dir", "no output directory given");
  SOLID_ASSIGN_OR_RETURN(Dataset dataset, Dataset::Open(options.dataset));
  const Manifest& manifest = dataset.manifest();
  const fs::path images_dir = options.out_dir / "images";
  std::error_code ec;
  fs::create_directories(images_dir, ec);
  if (ec) return IoError(fmt::format("{}: cannot create: {}", images_dir.string(), ec.message()));
  SOLID_ASSIGN_OR_RETURN(files::AtomicFileWriter out, files::AtomicFileWriter::Create(options.out_dir / "annotations.json"));

  const nlohmann::json info = {{"description", fmt::format("solid dataset {}", options.dataset.string())},
                               {"version", manifest.generator_version},
                               {"solid_seed", manifest.seed},
                               {"solid_params_hash", fmt::format("{:016x}", manifest.ParamsHash())}};
  SOLID_RETURN_IF_ERROR(out.Write(fmt::format("{{\"info\": {},\n\"licenses\": [],\n\"images\": [", info.dump())));

  CocoExportReport report;
  report.annotations_file = options.out_dir / "annotations.json";
  // Pass 1, images: the shards are read in id order, one image at a time.
  for (const ShardFile& file : dataset.shards().targets) {
    SOLID_ASSIGN_OR_RETURN(ShardReader * shard, dataset.Shard(file.index));
    SOLID_ASSIGN_OR_RETURN(std::vector<int64_t> ids, shard->ImageIds());
    for (int64_t id : ids) {
      if (CancelRequested(options.cancel)) return Stopped(options, report.images, manifest.images);
      SOLID_ASSIGN_OR_RETURN(ImageRecord image, shard->ReadImage(id));
      // Annotations take the mask size from the manifest (pass 2 does not read images).
      if (image.width != manifest.width || image.height != manifest.height) {
        return CorruptError(fmt::format("{}: image {} is {}x{}, the manifest says {}x{}", file.path.string(), id,
                                        image.width, image.height, manifest.width, manifest.height));
      }
      const std::string name = fmt::format("{:012d}.{}", id, Extension(image.format));
      if (options.images == CocoImages::kLink) {
        SOLID_RETURN_IF_ERROR(LinkImage(options.link_from / "images" / name, images_dir / name, image, file.path));
      } else {
        SOLID_RETURN_IF_ERROR(WriteBytes(images_dir / name, image.image));
      }
      const nlohmann::json entry = {{"id", id}, {"file_name", name}, {"width", image.width}, {"height", image.height}};
      SOLID_RETURN_IF_ERROR(out.Write(fmt::format("{}\n{}", report.images == 0 ? "" : ",", entry.dump())));
      ++report.images;
      report.image_bytes += static_cast<int64_t>(image.image.size());
      if (options.progress) options.progress(report.images, manifest.images);
    }
  }

  // Pass 2, annotations: streamed without image blobs.
  SOLID_RETURN_IF_ERROR(out.Write("],\n\"annotations\": ["));
  std::map<std::string, int64_t, std::less<>> model_categories;
  for (const ShardFile& file : dataset.shards().targets) {
    SOLID_ASSIGN_OR_RETURN(ShardReader * shard, dataset.Shard(file.index));
    SOLID_RETURN_IF_ERROR(shard->ForEachInstance([&](const InstanceRecord& in) -> Status {
      if (CancelRequested(options.cancel)) return Stopped(options, report.images, manifest.images);
      const uint64_t area = options.masks == CocoMasks::kFull ? in.full_area : in.visible_area;
      if (area == 0) {
        ++report.skipped_invisible;
        return Status::Ok();
      }
      int64_t category = 1;
      if (options.categories == CocoCategories::kModel) {
        category = model_categories.try_emplace(in.model_key, model_categories.size() + 1).first->second;
      }
      ++report.annotations;
      const nlohmann::json a = Annotation(in, report.annotations, category, manifest, options.masks);
      return out.Write(fmt::format("{}\n{}", report.annotations == 1 ? "" : ",", a.dump()));
    }));
  }

  nlohmann::json categories = nlohmann::json::array();
  if (options.categories == CocoCategories::kObject) {
    categories.push_back({{"id", 1}, {"name", "object"}, {"supercategory", "object"}});
  } else {
    std::vector<const std::string*> by_id(model_categories.size());
    for (const auto& [key, id] : model_categories) by_id[id - 1] = &key;
    for (size_t i = 0; i < by_id.size(); ++i) {
      categories.push_back({{"id", i + 1}, {"name", *by_id[i]}, {"supercategory", "object"}});
    }
  }
  report.categories = static_cast<int64_t>(categories.size());
  SOLID_RETURN_IF_ERROR(out.Write(fmt::format("],\n\"categories\": {}}}\n", categories.dump())));
  SOLID_RETURN_IF_ERROR(out.Commit());
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace solid::exporters
