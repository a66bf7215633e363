// `solid export coco`: a dataset as COCO instances annotations plus image files, for
// detectors that read COCO (Detectron2's register_coco_instances, pycocotools, mmdet).
//
// OUT_DIR/annotations.json is written as a stream (one image or one annotation at a
// time, never the whole list in memory) to a temporary sibling that is renamed into
// place at the end, so a reader never sees half a file. Images are written to
// OUT_DIR/images/<12-digit image id>.<png|jpg|webp>, byte for byte the encoded image
// the shard stores.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "solid/formats/cancel.h"
#include "solid/formats/progress.h"
#include "solid/formats/status.h"

namespace solid::exporters {

// Which mask an annotation's COCO fields (segmentation, area, bbox) describe.
//   kVisible: the visible mask; the full box and area are extra fields.
//   kBoth:    as kVisible, plus the full (amodal) mask as the extra field full_segmentation.
//   kFull:    the full (amodal) mask; the visible box and area are extra fields. Objects
//             hidden entirely are kept (their amodal mask is not empty).
// With kVisible and kBoth, instances with an empty visible mask are skipped: a COCO
// annotation of area 0 breaks training (a zero-size box).
enum class CocoMasks { kVisible, kBoth, kFull };
// One category "object" (the task is label-free), or one per model (the per-model baseline).
enum class CocoCategories { kObject, kModel };
// kCopy writes the image bytes. The shards hold no image files, so kLink hard-links
// the images of an earlier export of the same dataset (link_from), after checking that
// each one has the shard's bytes: exports with other --masks share one copy of the pixels.
enum class CocoImages { kCopy, kLink };

struct CocoExportOptions {
  std::filesystem::path dataset;
  std::filesystem::path out_dir;  // created if missing; annotations.json is replaced
  CocoMasks masks = CocoMasks::kBoth;
  CocoCategories categories = CocoCategories::kObject;
  CocoImages images = CocoImages::kCopy;
  std::filesystem::path link_from;  // an earlier export's OUT_DIR, for kLink
  ProgressCallback progress;        // in images
  // Stops between images and between annotations (solid/formats/cancel.h) with
  // kCancelled: annotations.json is not written (its temporary is removed); the image
  // files written so far are complete, and a rerun writes them again.
  const CancelFlag* cancel = nullptr;
};

struct CocoExportReport {
  std::filesystem::path annotations_file;  // OUT_DIR/annotations.json
  int64_t images = 0, annotations = 0, categories = 0;
  int64_t skipped_invisible = 0;  // instances left out because their mask is empty
  int64_t image_bytes = 0;        // written or linked
  double seconds = 0;
  nlohmann::json ToJson() const;
  // "<annotations_file>: N images, M annotations in K categories (...), X MB of images, S s"
  std::string ToText() const;
};

// kInvalidArgument for `dataset` or `out_dir` when empty and for `link_from` when kLink has
// none; an image missing from link_from, or other than the shard's, is an error about
// `link_from` too (kNotFound, kCorrupt). kCancelled as `cancel` says; the dataset's errors.
Result<CocoExportReport> ExportCoco(const CocoExportOptions& options);

}  // namespace solid::exporters
