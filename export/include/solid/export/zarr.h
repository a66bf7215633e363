// `solid export zarr`: a dataset as the zarr v2 directory store that the reference SOLID
// renderer writes (solid-method.md 5.1), so that SOLID's own pretraining reader
// (detection/pretrain/dataset.py) trains on it unchanged. The rules are those of
// solid-method.md 5.3; docs/dataset-format.md ("The zarr export") says what is kept and lost.
//
// The store, one row per exported image (an image with at least one visible instance, in
// image-id order; instances in render-id order, those with an empty visible mask left out):
//
//   images            (N,)  VLenArray int8, no compressor: the image's encoded bytes as stored
//   bboxes            (N,)  VLenArray int32, Blosc: per instance [x0, y0, x1, y1, class], half-open
//   masks             (N,)  VLenArray int8, Blosc: the visible masks, raw 0/1, instances x H x W, C order
//   visibilities      (N,)  VLenArray float32, Blosc: visible_area / full_area
//   mask_bbox_ratios  (N,)  VLenArray float32, Blosc: visible_area / box area
//   angles            (N,)  VLenArray float32, Blosc: 3 per instance, Euler XYZ of camera^-1 * object
//   queries           (C, shots) VLenArray int8, no compressor: query view bytes, views cycled into
//                     every slot; shots = max(8, the largest view count)
//   query_ids         (C,)  int64, Blosc: 0 .. C-1
//   valids            (N,)  bool, Blosc: true
//   scenenet_models   (N,)  |S128: metadata only, never written (as the reference)
//   solid_image_ids   (N,)  int64, Blosc: the solid image id of each row (ours; the reader ignores it)
//   solid_export.json       ours: the class -> model key table, the models dropped, provenance
//
// Classes are the dataset's models (those of the query shards) in model-key order, as
// solid_data.Dataset.model_keys numbers them; without drop_viewless_models a model with no
// query view is refused, since the reader crashes on a class it cannot draw a view of.
//
// Per-image arrays use chunks of `chunk` rows (queries: chunk x chunk, as the reference's
// create_zarr.py), each chunk written whole: rows past N in the last chunk are empty items.
// Blosc is lz4, level 5, byte shuffle, block size automatic, as numcodecs writes it.
//
// The shards are read one at a time, image by image; memory holds one chunk of each
// compressed array (the raw mask chunk and its compressed copy: at most
// 2 * max_chunk_bytes) and one model's query views; images and views stream to their
// chunk files. Atomic: everything is written to a temporary sibling directory
// (files::TempPathFor(out_dir)) whose .zgroup is written last, then renamed to out_dir: a
// killed export leaves no store under out_dir, and its temporary opens as no zarr group.
#pragma once

#include <climits>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/cancel.h"
#include "solid/formats/progress.h"
#include "solid/formats/status.h"

namespace solid::exporters {

// Blosc 1's largest input buffer (BLOSC_MAX_BUFFERSIZE of blosc.h: INT_MAX minus its
// 16-byte header), so the largest raw chunk of a compressed array.
inline constexpr int64_t kBloscMaxBufferBytes = INT_MAX - 16;
inline constexpr int kMaxZarrChunk = 4096;  // queries' chunk has chunk^2 items
inline constexpr int kZarrMinQueryShots = 8;

struct ZarrExportOptions {
  std::filesystem::path dataset;
  // Must not exist, or be an empty directory: an export is never resumed or merged.
  std::filesystem::path out_dir;
  int chunk = 256;  // rows per chunk, 1 to kMaxZarrChunk
  // Leave out the models without query views (and their instances), renumbering the classes
  // densely; solid_export.json lists them with their failure.
  bool drop_viewless_models = false;
  // The largest raw chunk of a compressed array (in practice the masks), 1 to
  // kBloscMaxBufferBytes.
  int64_t max_chunk_bytes = kBloscMaxBufferBytes;
  ProgressCallback progress;  // in images of the manifest
  // Stops between images, between query models and between the masks of a chunk, with
  // kCancelled; the temporary store is removed.
  const CancelFlag* cancel = nullptr;
};

struct ZarrExportReport {
  std::filesystem::path store;  // out_dir
  int64_t images = 0;            // rows: exported images
  int64_t skipped_images = 0;    // images without a visible instance of a kept model
  int64_t instances = 0;         // rows of bboxes
  int64_t skipped_invisible = 0; // instances whose visible mask is empty
  int64_t classes = 0, query_shots = 0, chunks = 0;  // chunks of the per-image arrays
  std::vector<std::string> dropped_models;  // drop_viewless_models: their keys
  int64_t dropped_instances = 0;             // visible instances of dropped models
  int64_t largest_mask_chunk_bytes = 0;      // raw, before Blosc
  int64_t store_bytes = 0;                   // every file of the store
  double seconds = 0;
  nlohmann::json ToJson() const;
  // "<store>: N images (M skipped), K instances in C classes, ..., X MB, S s"
  std::string ToText() const;
};

// Errors: kInvalidArgument for an empty `dataset` or `out_dir`, for `chunk` or
// `max_chunk_bytes` out of range (about that field); kAlreadyExists when out_dir exists and
// is not an empty directory; kNotFound when target shards of the manifest are missing, when
// the dataset has no query shard or a model of the targets has no query record, when a
// model has no query view (without drop_viewless_models), when no image has a visible
// instance; kCorrupt for a shard of another dataset, an image whose size is not the
// manifest's, stored views fewer than their model's count; kLimitExceeded for a raw chunk
// over max_chunk_bytes, naming the chunk and its images; kIoError for a refused write,
// naming the file; kCancelled as `cancel` says; the shards' own errors. On any error
// nothing is left under out_dir and the temporary is removed.
Result<ZarrExportReport> ExportZarr(const ZarrExportOptions& options);

}  // namespace solid::exporters
