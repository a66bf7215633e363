// Targets from a user's own COCO instances file (`solid optimize --match-coco`): the objects
// per image and the small/medium/large shares of the user's downstream dataset, to fit
// layouts to before rendering.
//
// What is derived, per solid-method.md 1.2 with COCO annotations standing in for visible
// masks:
// - objects per image: the non-crowd annotations of each image, averaged over the images
//   (an image without any counts as 0 objects unless skip_empty_images);
// - scale shares: each non-crowd annotation's `area`, rescaled to width x height by its own
//   image's pixel-count ratio (width * height / (image.width * image.height)), rounded to
//   whole pixels as MetricsAccumulator rounds scaled areas, and classed by
//   ScaleClassOfArea (solid/formats/records.h): small below 32^2, medium up to 96^2
//   inclusive, large above.
// Annotations with `iscrowd` 1 (or true) are left out and counted. Occlusion is not in COCO
// annotations and is not derived.
//
// The file is streamed (nlohmann's SAX parser over a buffered reader), never held as a DOM:
// memory is 24 bytes per image, plus 16 bytes per annotation that comes before the `images`
// array in the file (COCO files written by pycocotools and `solid export coco` put images
// first), each in a vector that grows by doubling, plus the reader's 1 MiB buffer and one
// token. Everything but the images' `id`, `width`, `height` and the annotations'
// `image_id`, `area`, `iscrowd` (segmentations, boxes, categories, info, licenses) is read
// past without being stored.
//
// Thread safety: the functions share no state; calls may run concurrently.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/metrics.h"
#include "solid/formats/status.h"
#include "solid/optimizer/optimize.h"

namespace solid::optimizer {

struct CocoMatchOptions {
  // The resolution at which scale classes are counted (the dataset's, solid-method.md 4.2):
  // each area is rescaled to it. Both must be >= 1.
  int width = 640, height = 480;
  // Images without non-crowd annotations count as 0 objects per image, unless skipped.
  bool skip_empty_images = false;

  // Limits of the untrusted input (docs/limits.md); a library user may lower them. The two
  // counts may not be raised above 2^32 - 1.
  uint64_t max_file_bytes = uint64_t{8} << 30;
  int64_t max_images = int64_t{1} << 25;
  int64_t max_annotations = int64_t{1} << 28;  // crowd annotations included
  // Bytes between two values the parser reports (a string or number with the whitespace
  // before it), which bounds the parser's own token buffer.
  uint64_t max_token_bytes = uint64_t{16} << 20;
  // Containers nested deeper than this anywhere in the file (COCO needs 5).
  int max_depth = 64;
};

struct CocoMatch {
  // objects_per_image, small, medium, large (in this order): the estimates' means with
  // DefaultTolerance. Shares are fractions.
  std::vector<Target> targets;
  // Means with their 95% CIs as MetricsAccumulator gives them: objects_per_image over
  // images_counted images, the shares over `annotations` annotations.
  Estimate objects_per_image, small, medium, large;
  int width = 0, height = 0;   // the resolution the scale classes were counted at
  int64_t images = 0;          // in the file
  int64_t images_counted = 0;  // images - empty_images when they are skipped, else images
  int64_t empty_images = 0;    // without non-crowd annotations, skipped or not
  int64_t annotations = 0;     // non-crowd: those counted
  int64_t crowd_skipped = 0;
  // {"resolution": [width, height], "images", "images_counted", "empty_images",
  //  "annotations", "crowd_skipped", "targets": [{"metric", "value", "tolerance", "ci95",
  //  "n"}]}, n being the sample size (images_counted or annotations).
  nlohmann::json ToJson() const;
};

// The targets of the COCO instances file at `annotations` (a JSON object with `images` and
// `annotations` arrays; other top-level keys are ignored). Each error names the file, and
// for a bad value its JSON Pointer (RFC 6901), e.g.
//   "instances.json: /annotations/17/area: must be a number >= 0, not a string":
// - kNotFound: no such file;
// - kIoError: not a regular file, or a read failed;
// - kParseError: not JSON ("name:line:column: message (byte offset B)", the offset 0-based);
//   not a COCO instances file (the top level is not an object; `images` or `annotations`
//   missing or not arrays, or given twice); an image or annotation that is not an object,
//   lacks `id`, `width` or `height` (images), `image_id` or, unless crowd, `area`
//   (annotations), repeats one of them, or has one of the wrong type: ids must be
//   integers, width and height integers >= 1 (a whole number written as 640.0 counts as an
//   integer), area a number >= 0, iscrowd 0, 1 or a boolean;
// - kCorrupt: two images with one id; an annotation whose image_id names no image; no
//   annotations, or only crowd ones;
// - kLimitExceeded: over one of options' limits;
// - kInvalidArgument: options.width or options.height below 1, or a count limit above 2^32 - 1.
Result<CocoMatch> TargetsFromCoco(const std::filesystem::path& annotations, const CocoMatchOptions& options = {});

// The same from the file's bytes in memory; `name` stands for the file in messages.
Result<CocoMatch> TargetsFromCocoText(std::string_view text, std::string_view name,
                                      const CocoMatchOptions& options = {});

}  // namespace solid::optimizer
