// `solid render`: target images with their masks, and query views of every model they
// use, into a sharded dataset (formats/dataset.h) that is deterministic, resumable and
// farmable.
//
// Image i is generated from (params, seed, i) alone: its layout and mask pass
// (GenerateLayout), its shading, its encoding. Shard K holds images
// [K * shard_size, (K + 1) * shard_size); a shard is published whole or not at all, so a
// rerun renders the shards that are missing and a farm runs one process per shard.
//
// Query views: query shard Q holds the views of the catalog's models
// [Q * query_shard_models, (Q + 1) * query_shard_models), every one of them, so that its
// content depends on the catalog alone and any process that needs one of its models can
// write it: concurrent writers produce the same bytes, and the first to publish wins.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/cancel.h"
#include "solid/formats/dataset.h"
#include "solid/formats/progress.h"
#include "solid/render/layout.h"
#include "solid/render/params.h"
#include "solid/render/query_views.h"
#include "solid/render/sample.h"
#include "solid/render/shade.h"

namespace solid::render {

struct RenderOptions {
  std::filesystem::path out;
  uint64_t seed = 1;
  int64_t images = 1000;
  int64_t shard_size = 256;
  // Inclusive range of target shards to render; empty: every shard of the dataset.
  std::optional<std::pair<int64_t, int64_t>> shards;
  int jobs = 0;  // images in parallel; 0: all cores
  ImageFormat format = ImageFormat::kPng;
  int quality = 90;    // jpeg and webp
  bool depth = false;  // store depth as OpenEXR (half float, ZIP)
  // Adaptive by default: at 4 spp it shades faster than uniform, at a higher PSNR (shade.h).
  ShadeOptions shading{.samples_per_pixel = 4, .threads = 1, .sampling = Sampling::kAdaptive};
  QueryViewOptions query_views;
  int64_t query_shard_models = 64;
  bool queries = true;  // render the query shards the rendered targets need
  // A present shard is skipped when its provenance is this dataset's shard (and its image
  // ids lie in its range); one that is not (another dataset's, another shard's, not a
  // regular file, unreadable) stops the render with kCorrupt naming it and the field. With
  // repair, every present target and query shard is validated (ValidateShardOfDataset) and
  // those that fail are rendered anew in place; the others keep their bytes.
  bool repair = false;
  // When options.out holds shards but no manifest.json: rebuild the manifest from their
  // provenance (formats/dataset.h AdoptManifest; on_note says what was found), then go on
  // as for a dataset with that manifest. Without it such a directory is refused (kNotFound).
  bool adopt = false;
  uint64_t texture_cache_bytes = uint64_t{1} << 30;  // cap of decoded textures (shade.h TextureCache)
  ProgressCallback progress;  // in images
  // Stops the render (solid/formats/cancel.h). The shard being written is finished when its
  // remaining images should take at most finish_shard_seconds at the rate it has had so far
  // (schedulers give SIGTERM 30 s before SIGKILL), and abandoned otherwise: its temporary
  // file is removed and nothing is published. No new shard or query shard is started.
  const CancelFlag* cancel = nullptr;
  double finish_shard_seconds = 10;
  // Lines for the user as they happen, from the calling thread: shards that another
  // process holds the lock of, and waits for them.
  std::function<void(const std::string&)> on_note;
};

// Wall time spent in each stage, summed over worker threads, milliseconds.
struct StageTimes {
  double layout = 0, mask_pass = 0, shading = 0, encoding = 0, writing = 0, query_views = 0;
  nlohmann::json ToJson() const;
};

struct RenderReport {
  int64_t shards_requested = 0, shards_rendered = 0, shards_present = 0, shards_repaired = 0;
  int64_t query_shards_repaired = 0;
  bool adopted = false;  // manifest.json was rebuilt from the shards' provenance
  int64_t images = 0, instances = 0;
  // Images whose every restart was unusable (GenerateLayout): absent from their shard.
  int64_t failed_images = 0;
  std::vector<std::string> failures;  // the first few reasons
  int64_t query_shards_rendered = 0, query_shards_present = 0, query_views = 0;
  // Requested shards that another process was rendering (their lock was held) and that it
  // published while this one waited; counted in shards_present too.
  int64_t shards_by_others = 0;
  bool index_built = false;  // every target shard is present, and the index was rebuilt
  // Stopped through options.cancel before everything requested was done.
  bool cancelled = false;
  int64_t abandoned_shard = -1;  // the shard given up when cancelled, -1 if none
  std::vector<int64_t> shards_missing;  // requested shards absent at the end (when cancelled)
  StageTimes stages;
  // The instruction set of the shader's inner loops on this CPU (x86-64, x86-64-v3 or
  // x86-64-v4; "generic" where only one is built): every one gives the same bytes.
  std::string shading_instruction_set;
  double seconds = 0;
  int64_t peak_rss_bytes = 0;
  nlohmann::json ToJson() const;
};

// The manifest a render with these params and options writes (and that an existing
// dataset must equal).
Manifest RenderManifest(const LayoutSampler& sampler, const RenderOptions& options);

// Creates the dataset or checks that the one in options.out was made with the same
// manifest (kAlreadyExists naming the difference otherwise), renders the requested
// target shards that are missing (or damaged, with repair), the query shards they need,
// and the index when every target shard is present.
//
// A target shard is rendered only under its lock (files::FileLock on the shard path), so
// two processes given the same shard never both render it: one that finds the lock held
// renders its other shards first, then waits for the holder to publish (or to die, and
// renders the shard itself). Every requested shard is present when it returns, unless
// cancelled (report.cancelled; a rerun resumes).
// OptionError "images", "shard_size", "query_shard_models" (out of range) or "shards" (not
// shards of the dataset).
Result<RenderReport> RenderDataset(const LayoutSampler& sampler, const RenderOptions& options);

// `solid render` as one call: the sampler opened (OpenSampler) and RenderDataset run.
struct RenderCommandOptions {
  SamplerSource source;
  // As given, but for three fields RenderCommand derives: query_views.render_size from
  // query_views.long_side (QueryRenderSize), query_views.samples_per_pixel from
  // shading.samples_per_pixel (views are shaded like images), and texture_cache_bytes from
  // source.library.cache_bytes (decoded textures are a second cache of the asset cache's
  // size: the glb bytes count in the first).
  RenderOptions render;
};

struct RenderCommandReport {
  LayoutParams params;  // as resolved
  RenderReport render;
  nlohmann::json ToJson() const { return render.ToJson(); }
};

Result<RenderCommandReport> RenderCommand(const RenderCommandOptions& options);

// The square render size of query views stored with long side `long_side`: 384 for 224
// (solid-method 2.8: the object spans about 80% of the frame before the crop), the same
// ratio for other sizes.
int QueryRenderSize(int long_side);

// "FIRST-LAST" (e.g. "0-15") as an inclusive shard range; OptionError `field` otherwise.
Result<std::pair<int64_t, int64_t>> ParseShardRange(std::string_view field, std::string_view text);

// The shard a scheduler gives this process as the index of its array task
// (SLURM_ARRAY_TASK_ID, else JOB_COMPLETION_INDEX), or none when neither is set. A
// function the caller asks, not something RenderDataset reads itself, so that a library
// user's environment never changes what a call renders; kInvalidArgument naming the
// variable when it is not an index.
struct ScheduledShard {
  int64_t shard = 0;
  std::string variable;  // the environment variable it came from
};
Result<std::optional<ScheduledShard>> ShardFromEnvironment();

}  // namespace solid::render
