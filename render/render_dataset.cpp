#include "solid/render/render_dataset.h"

#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <mutex>
#include <numbers>
#include <set>
#include <thread>
#include <tuple>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "solid/formats/checksum.h"
#include "solid/formats/file_lock.h"
#include "solid/formats/version.h"
#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"
#include "solid/formats/index.h"
#include "solid/formats/random.h"
#include "solid/formats/shard.h"
#include "solid/formats/validate.h"
#include "solid/render/params.h"
#include "solid/render/sample.h"

#include "solid/formats/workers.h"
#include "film_kernels.h"
#include "room.h"

namespace solid::render {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

int64_t PeakRssBytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<int64_t>(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

// Everything one image contributes to its shard, or why it has none.
struct RenderedImage {
  Status error;         // a hard error: the render stops
  std::string failure;  // an unusable layout: the image is left out
  ImageRecord image;
  std::vector<InstanceRecord> instances;
  nlohmann::json lights;
  StageTimes stages;
};

RenderedImage RenderImage(const LayoutSampler& sampler, const RenderOptions& options, TextureCache& textures,
                          int64_t image_id) {
  RenderedImage out;
  Result<GeneratedLayout> generated = GenerateLayout(sampler, options.seed, image_id);
  if (!generated.ok()) {
    if (generated.status().code() == StatusCode::kLimitExceeded) {
      out.failure = generated.status().message();
    } else {
      out.error = generated.status();
    }
    return out;
  }
  out.stages.layout = generated->sample_ms;
  out.stages.mask_pass = generated->mask_ms;
  const Layout& layout = generated->layout;

  auto start = Clock::now();
  out.lights = generated->lights.ToJson();
  ShadeOptions shading = options.shading;
  shading.threads = 1;  // images run in parallel instead
  Result<ShadeResult> shaded = Shade(layout, generated->lights, shading, textures, &generated->masks);
  out.stages.shading = MillisecondsSince(start);
  if (!shaded.ok()) {
    out.error = shaded.status().WithContext(fmt::format("image {}", image_id));
    return out;
  }

  start = Clock::now();
  ImageRecord& record = out.image;
  record.image_id = image_id;
  record.seed = layout.seed;
  record.width = static_cast<uint32_t>(layout.width);
  record.height = static_cast<uint32_t>(layout.height);
  record.format = options.format;
  record.camera = layout.camera;
  record.room_key = layout.room->key();
  Result<std::vector<uint8_t>> encoded = EncodeImage(shaded->image, options.format, options.quality);
  if (!encoded.ok()) {
    out.error = encoded.status().WithContext(fmt::format("image {}", image_id));
    return out;
  }
  record.image = std::move(encoded).value();
  if (options.depth) {
    DepthImage depth{record.width, record.height, std::move(generated->masks.depth)};
    Result<std::vector<uint8_t>> exr = EncodeDepthExr(depth);
    if (!exr.ok()) {
      out.error = exr.status().WithContext(fmt::format("image {} depth", image_id));
      return out;
    }
    record.depth_exr = std::move(exr).value();
  }
  out.stages.encoding = MillisecondsSince(start);
  out.instances = std::move(generated->masks.instances);
  return out;
}

void AddStages(StageTimes* total, const StageTimes& s) {
  total->layout += s.layout;
  total->mask_pass += s.mask_pass;
  total->shading += s.shading;
  total->encoding += s.encoding;
  total->writing += s.writing;
  total->query_views += s.query_views;
}

// What a shard's images come to before the shard is published.
struct ShardContent {
  std::vector<std::string> failures;                 // of the images left out
  nlohmann::json lights = nlohmann::json::object();  // image id -> its light rig
  StageTimes stages;
  int64_t images = 0, instances = 0;
};

// Image `id` into its shard, or among the shard's failures.
Status AddToShard(ShardWriter& writer, int64_t id, RenderedImage& image, ShardContent* content,
                  std::set<std::string>* models) {
  AddStages(&content->stages, image.stages);
  if (!image.failure.empty()) {
    content->failures.push_back(image.failure);
    return Status::Ok();
  }
  const auto start = Clock::now();
  content->lights[std::to_string(id)] = std::move(image.lights);
  Status status = writer.AddImage(image.image);
  for (const InstanceRecord& instance : image.instances) {
    if (!status.ok()) break;
    status = writer.AddInstance(instance);
    models->insert(instance.model_key);
  }
  content->stages.writing += MillisecondsSince(start);
  ++content->images;
  content->instances += static_cast<int64_t>(image.instances.size());
  return status;
}

class Renderer {
 public:
  Renderer(const LayoutSampler& sampler, const RenderOptions& options, const Manifest& manifest)
      : sampler_(sampler), options_(options), manifest_(manifest), paths_(options.out), textures_(options.texture_cache_bytes) {}

  // Images [first, end) of shard `shard` into its file; workers render ahead of the
  // writer by at most a window of images, so memory does not grow with the shard.
  Status RenderShard(int64_t shard, bool replace, std::set<std::string>* models) {
    const int64_t first = shard * manifest_.shard_size;
    const int64_t end = std::min(first + manifest_.shard_size, manifest_.images);
    ShardWriteOptions write_options;
    write_options.replace_existing = replace;
    SOLID_ASSIGN_OR_RETURN(ShardWriter writer, ShardWriter::Create(paths_.shard(shard), write_options));
    SOLID_RETURN_IF_ERROR(WriteProvenance(writer, manifest_, shard));

    const int jobs = static_cast<int>(std::min<int64_t>(WorkerCount(options_.jobs), std::max<int64_t>(1, end - first)));
    const int64_t window = 2 * static_cast<int64_t>(jobs);
    std::vector<RenderedImage> slots(static_cast<size_t>(window));
    std::vector<bool> ready(static_cast<size_t>(window), false);
    std::mutex mutex;
    std::condition_variable changed;
    int64_t next = first, written = first;
    bool stop = false;
    auto worker = [&] {
      for (;;) {
        int64_t id;
        {
          std::unique_lock lock(mutex);
          changed.wait(lock, [&] { return stop || next >= end || next < written + window; });
          if (stop || next >= end) return;
          id = next++;
        }
        RenderedImage image = RenderImage(sampler_, options_, textures_, id);
        std::lock_guard lock(mutex);
        slots[static_cast<size_t>(id % window)] = std::move(image);
        ready[static_cast<size_t>(id % window)] = true;
        changed.notify_all();
      }
    };
    BackgroundWorkers pool(jobs, worker);

    Status status;
    ShardContent content;  // the report's only once the shard is published
    const auto shard_start = Clock::now();
    bool finishing = false;  // cancelled, but the rest of the shard is worth its time
    for (; written < end && status.ok(); ++written) {
      if (!finishing && CancelRequested(options_.cancel)) {
        finishing = WorthFinishing(written - first, end - written, shard_start);
        if (!finishing) {
          status = CancelledError(fmt::format("stopped after {} of its {} images", written - first, end - first));
          break;
        }
      }
      RenderedImage image;
      {
        std::unique_lock lock(mutex);
        changed.wait(lock, [&] { return ready[static_cast<size_t>(written % window)]; });
        image = std::move(slots[static_cast<size_t>(written % window)]);
        ready[static_cast<size_t>(written % window)] = false;
      }
      changed.notify_all();
      if (!image.error.ok()) {
        status = image.error;
        break;
      }
      status = AddToShard(writer, written, image, &content, models);
      Progress();
    }
    {
      std::lock_guard lock(mutex);
      stop = true;
    }
    changed.notify_all();
    pool.Join();
    SOLID_RETURN_IF_ERROR(status.WithContext(paths_.shard(shard).string()));
    return Publish(writer, content);
  }

  // Every model of catalog range Q, in catalog order, rendered in parallel.
  Status RenderQueryShard(int64_t q, bool replace) {
    const auto& models = sampler_.library()->models();
    const size_t first = static_cast<size_t>(q * options_.query_shard_models);
    const size_t end = std::min(models.size(), first + static_cast<size_t>(options_.query_shard_models));
    std::vector<ModelViews> rendered(end - first);
    std::atomic<size_t> next{first};
    std::atomic<bool> cancelled{false};
    auto worker = [&] {
      for (size_t i = next++; i < end; i = next++) {
        if (CancelRequested(options_.cancel)) {
          cancelled = true;
          return;
        }
        rendered[i - first] = RenderModelViews(i);
      }
    };
    const auto start = Clock::now();
    RunOnThreads(static_cast<int>(std::min<size_t>(WorkerCount(options_.jobs), std::max<size_t>(1, end - first))),
                 worker);
    report_.stages.query_views += MillisecondsSince(start);
    if (cancelled) return CancelledError(paths_.query_shard(q).string() + ": stopped before its views were rendered");

    ShardWriteOptions write_options;
    write_options.replace_existing = replace;
    const fs::path path = paths_.query_shard(q);
    SOLID_ASSIGN_OR_RETURN(QueryShardWriter writer, QueryShardWriter::Create(path, write_options));
    SOLID_RETURN_IF_ERROR(WriteProvenance(writer, manifest_, q));
    for (ModelViews& m : rendered) {
      SOLID_RETURN_IF_ERROR(m.error.WithContext(path.string()));
      SOLID_RETURN_IF_ERROR(writer.AddModel(m.model));
      for (const QueryViewRecord& v : m.views) SOLID_RETURN_IF_ERROR(writer.AddView(v));
      report_.query_views += static_cast<int64_t>(m.views.size());
    }
    return writer.Commit();
  }

  void SetProgressTotal(int64_t total) { progress_total_ = total; }
  RenderReport& report() { return report_; }

 private:
  struct ModelViews {
    QueryModelRecord model;
    std::vector<QueryViewRecord> views;
    Status error;
  };

  // The query views of catalog model i, encoded; a model without them records why.
  ModelViews RenderModelViews(size_t i) {
    const AssetEntry& entry = sampler_.library()->models()[i];
    ModelViews out;
    out.model.model_key = entry.key;
    Result<std::shared_ptr<const LoadedAsset>> asset = sampler_.library()->Model(i);
    if (!asset.ok()) {
      out.model.failure = asset.status().ToString();
      return out;
    }
    // The model's own stream: its views are the same whichever images use it.
    const uint64_t seed = MixSeed(options_.seed, Xxh64(entry.key));
    QueryViewOptions view_options = options_.query_views;
    view_options.threads = 1;  // models run in parallel instead
    Result<QueryViewsResult> views = RenderQueryViews(*asset, seed, view_options, textures_);
    if (!views.ok()) {
      out.model.failure = views.status().ToString();
      return out;
    }
    if (!views->failed.empty()) {
      out.model.failure = fmt::format("the model covers no pixel at azimuth(s) {} deg", fmt::join(views->failed, ", "));
    }
    for (size_t v = 0; v < views->views.size(); ++v) {
      QueryView& view = views->views[v];
      QueryViewRecord record;
      record.model_key = entry.key;
      record.view_index = static_cast<int32_t>(v);
      record.azimuth = view.azimuth_deg * std::numbers::pi / 180;
      record.elevation = view.elevation_deg * std::numbers::pi / 180;
      record.width = view.image.width;
      record.height = view.image.height;
      record.format = options_.format;
      // Views are cropped to the object: its box is the whole stored image.
      record.box = {0, 0, view.image.width, view.image.height};
      Result<std::vector<uint8_t>> encoded = EncodeImage(view.image, options_.format, options_.quality);
      if (!encoded.ok()) {
        out.error = encoded.status().WithContext(fmt::format("{} view {}", entry.key, v));
        break;
      }
      record.image = std::move(encoded).value();
      out.views.push_back(std::move(record));
    }
    out.model.view_count = static_cast<int32_t>(out.views.size());
    return out;
  }

  // Cancelled after `done` images of a shard, with `left` to go: they are worth finishing
  // when they should take at most finish_shard_seconds at the shard's rate so far.
  bool WorthFinishing(int64_t done, int64_t left, Clock::time_point shard_start) const {
    const double per_image_s = done > 0 ? MillisecondsSince(shard_start) / 1000 / done : 0;
    return done > 0 && per_image_s * left <= options_.finish_shard_seconds;
  }

  // The shard's metadata, then the shard; its content counts in the report from then on.
  Status Publish(ShardWriter& writer, ShardContent& content) {
    report_.failed_images += static_cast<int64_t>(content.failures.size());
    for (const std::string& f : content.failures) {
      if (report_.failures.size() < 5) report_.failures.push_back(f);
    }
    SOLID_RETURN_IF_ERROR(writer.SetMeta("failed_images", nlohmann::json(content.failures).dump()));
    SOLID_RETURN_IF_ERROR(writer.SetMeta("stage_ms", content.stages.ToJson().dump()));
    SOLID_RETURN_IF_ERROR(writer.SetMeta("lights", content.lights.dump()));
    const auto start = Clock::now();
    SOLID_RETURN_IF_ERROR(writer.Commit());
    content.stages.writing += MillisecondsSince(start);
    AddStages(&report_.stages, content.stages);
    report_.images += content.images;
    report_.instances += content.instances;
    return Status::Ok();
  }

  void Progress() {
    ++progress_done_;
    if (options_.progress) options_.progress(progress_done_, progress_total_);
  }

  const LayoutSampler& sampler_;
  const RenderOptions& options_;
  const Manifest& manifest_;
  DatasetPaths paths_;
  RenderReport report_;
  TextureCache textures_;
  int64_t progress_done_ = 0, progress_total_ = 0;
};

// What stands at a shard's path: nothing, a shard of this dataset, or something else.
struct Examined {
  bool present = false;
  std::string damage;  // why it is not shard k of this dataset; empty when it is
};

// A resume trusts a present shard only when it is a regular file whose provenance is this
// dataset's shard k, with its image ids in k's range; --repair validates it whole as well.
Examined Examine(const fs::path& path, const Manifest& manifest, bool query, int64_t k, bool repair) {
  Examined e;
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(path, ec);
  if (ec || !fs::exists(status)) return e;
  e.present = true;
  if (fs::is_symlink(status)) {
    const fs::path root = path.parent_path().parent_path();
    if (!files::ResolveInside(root, path.lexically_relative(root).string()).ok()) {
      e.damage = "a symbolic link that leads out of the dataset";
      return e;
    }
  }
  if (!fs::is_regular_file(path, ec)) {
    e.damage = "not a regular file";
    return e;
  }
  if (repair) {
    const ValidationReport report = ValidateShardOfDataset(path, manifest, query, k);
    if (!report.ok()) {
      const ValidationProblem& p = report.problems.front();
      e.damage = p.location.empty() ? p.message : p.location + ": " + p.message;
    }
    return e;
  }
  const Status belongs = [&]() -> Status {
    std::vector<std::pair<std::string, std::string>> meta;
    if (query) {
      SOLID_ASSIGN_OR_RETURN(QueryShardReader reader, QueryShardReader::Open(path));
      SOLID_ASSIGN_OR_RETURN(meta, reader.Meta());
    } else {
      SOLID_ASSIGN_OR_RETURN(ShardReader reader, ShardReader::Open(path));
      SOLID_ASSIGN_OR_RETURN(meta, reader.Meta());
      SOLID_ASSIGN_OR_RETURN(ShardCounts counts, reader.Counts());
      const int64_t first = k * manifest.shard_size, end = std::min(first + manifest.shard_size, manifest.images);
      if (counts.images > 0 && (counts.first_image_id < first || counts.last_image_id >= end)) {
        return CorruptError(fmt::format("{}: images: ids {}-{}, outside shard {}'s range [{}, {})", path.string(),
                                        counts.first_image_id, counts.last_image_id, k, first, end));
      }
    }
    SOLID_ASSIGN_OR_RETURN(ShardProvenance found, ReadProvenance(meta, path.string()));
    return CheckProvenance(found, manifest, k, path.string());
  }();
  if (!belongs.ok()) e.damage = belongs.message();
  return e;
}

// A damaged shard under --repair: what stands at its path goes (a symbolic link, never its
// target), so that the shard rendered anew can be renamed into place.
Status ClearForRepair(const fs::path& path) {
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(path, ec);
  if (ec || fs::is_regular_file(status) || !fs::exists(status)) return Status::Ok();
  fs::remove_all(path, ec);
  if (ec) return IoError(fmt::format("{}: cannot remove it to repair the shard: {}", path.string(), ec.message()));
  return Status::Ok();
}

Status Refuse(const fs::path& path, const std::string& damage) {
  return CorruptError(fmt::format("{}: not this dataset's shard: {}; RenderOptions::repair re-renders it",
                                  path.string(), damage));
}

// Model keys used by the instances of a present target shard.
Status ModelsOfShard(const fs::path& path, std::set<std::string>* models) {
  SOLID_ASSIGN_OR_RETURN(ShardReader reader, ShardReader::Open(path));
  return reader.ForEachInstance(
      [&](const InstanceRecord& instance) {
        models->insert(instance.model_key);
        return Status::Ok();
      },
      ChecksumPolicy::kSkip);
}

Status CheckCounts(const RenderOptions& options) {
  if (options.images < 0) return OptionError("images", "must be >= 0");
  if (options.shard_size < 1) return OptionError("shard_size", "must be >= 1");
  if (options.query_shard_models < 1) return OptionError("query_shard_models", "must be >= 1");
  return Status::Ok();
}

// Creates the dataset in options.out, or adopts the shards there (options.adopt), and checks
// that the dataset there is the one `manifest` describes; true when it adopted. Farm
// processes may race to create the dataset: identical manifests make that harmless. Shards
// without a manifest are never taken for this render's: their provenance is adopted, or the
// render refused.
Result<bool> OpenDataset(const RenderOptions& options, const Manifest& manifest) {
  bool adopted = false;
  std::error_code ec;
  if (!fs::exists(DatasetPaths(options.out).manifest(), ec)) {
    SOLID_ASSIGN_OR_RETURN(const ShardListing found, ListShards(options.out));
    const size_t held = found.targets.size() + found.queries.size() + found.unexpected.size();
    if (held == 0) {
      SOLID_RETURN_IF_ERROR(CreateDataset(options.out, manifest));
    } else if (!options.adopt) {
      return NotFoundError(fmt::format("{}: no manifest.json, but {} shard file(s): RenderOptions::adopt rebuilds "
                                       "the manifest from their provenance (when they agree), or render into a new "
                                       "directory",
                                       options.out.string(), held));
    } else {
      SOLID_ASSIGN_OR_RETURN(const AdoptReport adoption, AdoptManifest(options.out));
      if (options.on_note) options.on_note(adoption.Summary(options.out));
      adopted = true;
    }
  }
  SOLID_ASSIGN_OR_RETURN(Manifest existing, ReadManifest(options.out));
  if (const std::string why = ManifestDifference(existing, manifest); !why.empty()) {
    return AlreadyExistsError(fmt::format("{}: the dataset there was rendered with other settings ({}); render into "
                                          "a new directory, or repeat the settings it was made with",
                                          options.out.string(), why));
  }
  return adopted;
}

// Target shards first..last; none when last < first.
struct ShardRange {
  int64_t first = 0, last = -1;
};

// The target shards options.shards asks for, every shard of the dataset without it.
Result<ShardRange> RequestedShards(const RenderOptions& options, const Manifest& manifest) {
  const int64_t shard_count = manifest.ShardCount();
  if (!options.shards) return ShardRange{0, shard_count - 1};
  const auto [first, last] = *options.shards;
  if (first < 0 || last < first || last >= shard_count) {
    return OptionError("shards", fmt::format("{}-{}: the dataset has shards 0-{} ({} images of {})", first, last,
                                            shard_count - 1, manifest.images, manifest.shard_size));
  }
  return ShardRange{first, last};
}

// A target shard to render: missing, or present but damaged (rendered anew in its place).
struct ShardTask {
  int64_t shard = 0;
  bool damaged = false;
};

// What the steps of one RenderDataset call share.
struct DatasetRun {
  DatasetRun(const LayoutSampler& sampler, const RenderOptions& options, const Manifest& manifest)
      : sampler(sampler), options(options), manifest(manifest), paths(options.out),
        renderer(sampler, options, manifest) {}

  RenderReport& report() { return renderer.report(); }
  void Note(const std::string& line) const {
    if (options.on_note) options.on_note(line);
  }

  const LayoutSampler& sampler;
  const RenderOptions& options;
  const Manifest& manifest;
  const DatasetPaths paths;
  Renderer renderer;
  std::set<std::string> models;  // used by the requested target shards: their query shards are needed
  bool stopped = false;          // cancelled with something requested left undone
  bool warned_unlocked = false;
};

// A present target shard this render keeps: counted, and its models noted for the query shards.
Status KeepPresentShard(DatasetRun& run, int64_t k) {
  ++run.report().shards_present;
  if (run.options.queries) return ModelsOfShard(run.paths.shard(k), &run.models);
  return Status::Ok();
}

// The requested target shards that are missing, or damaged when repairing (a damaged one
// stops the render otherwise); their images are the progress total.
Result<std::vector<ShardTask>> ShardsToRender(DatasetRun& run, ShardRange requested) {
  std::vector<ShardTask> todo;
  int64_t images = 0;
  for (int64_t k = requested.first; k <= requested.last; ++k) {
    const Examined e = Examine(run.paths.shard(k), run.manifest, /*query=*/false, k, run.options.repair);
    if (e.present && e.damage.empty()) {
      SOLID_RETURN_IF_ERROR(KeepPresentShard(run, k));
      continue;
    }
    if (e.present && !run.options.repair) return Refuse(run.paths.shard(k), e.damage);
    if (e.present) run.Note(fmt::format("shard {}: {}: re-rendering it", k, e.damage));
    todo.push_back({k, e.present});
    images += std::min(run.manifest.shard_size, run.manifest.images - k * run.manifest.shard_size);
  }
  run.renderer.SetProgressTotal(images);
  return todo;
}

// Renders the shard under its lock; false when another process holds the lock.
Result<bool> RenderUnderLock(DatasetRun& run, ShardTask task) {
  const fs::path path = run.paths.shard(task.shard);
  SOLID_ASSIGN_OR_RETURN(files::FileLock lock, files::FileLock::TryAcquire(path));
  if (lock.state() == files::FileLock::State::kHeldByOther) return false;
  if (lock.state() == files::FileLock::State::kUnsupported && !run.warned_unlocked) {
    run.Note(fmt::format("{}; rendering without locks: two processes given one shard may both render it, and the "
                         "first to publish wins", lock.unsupported_reason()));
    run.warned_unlocked = true;
  }
  // Published by another process since the listing, or while we waited for its lock.
  std::error_code exists_ec;
  if (!task.damaged && fs::exists(path, exists_ec)) {
    SOLID_RETURN_IF_ERROR(KeepPresentShard(run, task.shard));
    return true;
  }
  if (task.damaged) SOLID_RETURN_IF_ERROR(ClearForRepair(path));
  const Status rendered = run.renderer.RenderShard(task.shard, task.damaged, &run.models);
  RenderReport& report = run.report();
  if (rendered.code() == StatusCode::kCancelled) {
    report.abandoned_shard = task.shard;  // the writer removed its temporary file
    run.stopped = true;
    return true;
  }
  if (rendered.code() == StatusCode::kAlreadyExists && !lock.held()) {
    // No locks here, and another process published it first.
    SOLID_RETURN_IF_ERROR(KeepPresentShard(run, task.shard));
    return true;
  }
  SOLID_RETURN_IF_ERROR(rendered);
  ++report.shards_rendered;
  if (task.damaged) ++report.shards_repaired;
  return true;
}

// Renders the shards of `todo` that no other process holds, and returns those that one does.
Result<std::vector<ShardTask>> RenderUnheldShards(DatasetRun& run, const std::vector<ShardTask>& todo) {
  std::vector<ShardTask> held_elsewhere;
  for (const ShardTask& task : todo) {
    if (run.stopped || CancelRequested(run.options.cancel)) {
      run.stopped = true;
      break;
    }
    SOLID_ASSIGN_OR_RETURN(const bool done, RenderUnderLock(run, task));
    if (!done) {
      run.Note(fmt::format("shard {}: another process is rendering it ({} is locked); rendering the others first",
                           task.shard, files::LockPathFor(run.paths.shard(task.shard)).string()));
      held_elsewhere.push_back(task);
    }
  }
  return held_elsewhere;
}

// What other processes hold: waits until they publish, or die and leave the shard to us.
Status AwaitShardsHeldElsewhere(DatasetRun& run, const std::vector<ShardTask>& held_elsewhere) {
  bool waiting_noted = false;
  for (size_t i = 0; i < held_elsewhere.size() && !run.stopped;) {
    if (CancelRequested(run.options.cancel)) {
      run.stopped = true;
      break;
    }
    const ShardTask task = held_elsewhere[i];
    const int64_t present_before = run.report().shards_present;
    SOLID_ASSIGN_OR_RETURN(const bool done, RenderUnderLock(run, task));
    if (done) {
      if (run.report().shards_present > present_before) {
        ++run.report().shards_by_others;
        run.Note(fmt::format("shard {}: published by the other process", task.shard));
      }
      ++i;
      continue;
    }
    if (!waiting_noted) {
      run.Note(fmt::format("waiting for {} shard(s) that other processes are rendering", held_elsewhere.size() - i));
      waiting_noted = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return Status::Ok();
}

// The query shards that hold the models of the requested target shards.
Result<std::set<int64_t>> QueryShardsOfModels(const DatasetRun& run) {
  const auto& catalog = run.sampler.library()->models();
  std::set<int64_t> query_shards;
  for (const std::string& key : run.models) {
    const auto it = std::lower_bound(catalog.begin(), catalog.end(), key,
                                     [](const AssetEntry& e, const std::string& k) { return e.key < k; });
    if (it == catalog.end() || it->key != key) {
      return CorruptError(fmt::format("{}: model {} is in the shards but not in the asset catalog",
                                      run.options.out.string(), key));
    }
    query_shards.insert(static_cast<int64_t>(it - catalog.begin()) / run.options.query_shard_models);
  }
  return query_shards;
}

// The query shards the requested target shards need that are missing (or damaged, when
// repairing); a stop leaves the rest for a rerun.
Status RenderQueryShards(DatasetRun& run) {
  SOLID_ASSIGN_OR_RETURN(const std::set<int64_t> query_shards, QueryShardsOfModels(run));
  RenderReport& report = run.report();
  for (int64_t q : query_shards) {
    const fs::path path = run.paths.query_shard(q);
    const Examined e = Examine(path, run.manifest, /*query=*/true, q, run.options.repair);
    if (e.present && e.damage.empty()) {
      ++report.query_shards_present;
      continue;
    }
    if (e.present && !run.options.repair) return Refuse(path, e.damage);
    if (CancelRequested(run.options.cancel)) {
      run.stopped = true;
      break;
    }
    if (e.present) {
      run.Note(fmt::format("query shard {}: {}: re-rendering it", q, e.damage));
      SOLID_RETURN_IF_ERROR(ClearForRepair(path));
    }
    const Status written = run.renderer.RenderQueryShard(q, e.present);
    if (written.code() == StatusCode::kCancelled) {
      run.stopped = true;
      break;
    }
    if (written.code() == StatusCode::kAlreadyExists) {
      ++report.query_shards_present;  // another process of the farm published the same bytes first
      continue;
    }
    SOLID_RETURN_IF_ERROR(written);
    ++report.query_shards_rendered;
    if (e.present) ++report.query_shards_repaired;
  }
  return Status::Ok();
}

// Stopped before the end: the requested shards that are missing. The index waits for the
// run that completes the dataset.
void ReportStop(DatasetRun& run, ShardRange requested) {
  for (int64_t k = requested.first; k <= requested.last; ++k) {
    std::error_code missing_ec;
    if (!fs::exists(run.paths.shard(k), missing_ec)) run.report().shards_missing.push_back(k);
  }
  run.report().cancelled = true;
}

// The index, once every target shard of the dataset is there (this process's or others').
Status IndexWhenComplete(DatasetRun& run) {
  SOLID_ASSIGN_OR_RETURN(const ShardListing listing, ListShards(run.options.out));
  if (static_cast<int64_t>(listing.targets.size()) != run.manifest.ShardCount()) return Status::Ok();
  SOLID_RETURN_IF_ERROR(BuildIndex(run.options.out).status());
  run.report().index_built = true;
  return Status::Ok();
}

}  // namespace

nlohmann::json StageTimes::ToJson() const {
  return {{"layout_ms", layout},     {"mask_pass_ms", mask_pass}, {"shading_ms", shading},
          {"encoding_ms", encoding}, {"writing_ms", writing},     {"query_views_ms", query_views}};
}

nlohmann::json RenderReport::ToJson() const {
  return {{"shards_requested", shards_requested},
          {"shards_rendered", shards_rendered},
          {"shards_present", shards_present},
          {"shards_repaired", shards_repaired},
          {"query_shards_repaired", query_shards_repaired},
          {"adopted", adopted},
          {"images", images},
          {"instances", instances},
          {"failed_images", failed_images},
          {"failures", failures},
          {"query_shards_rendered", query_shards_rendered},
          {"query_shards_present", query_shards_present},
          {"query_views", query_views},
          {"shards_by_others", shards_by_others},
          {"index_built", index_built},
          {"cancelled", cancelled},
          {"abandoned_shard", abandoned_shard >= 0 ? nlohmann::json(abandoned_shard) : nlohmann::json()},
          {"shards_missing", shards_missing},
          {"stages", stages.ToJson()},
          {"shading_instruction_set", shading_instruction_set},
          {"seconds", seconds},
          {"peak_rss_bytes", peak_rss_bytes}};
}

Manifest RenderManifest(const LayoutSampler& sampler, const RenderOptions& options) {
  const LayoutParams& p = sampler.params();
  Manifest m;
  m.generator_version = SOLID_VERSION;
  m.git_sha = BuildCommit();
  m.seed = options.seed;
  m.images = options.images;
  m.shard_size = options.shard_size;
  m.width = static_cast<uint32_t>(p.width);
  m.height = static_cast<uint32_t>(p.height);
  std::tie(m.scale_width, m.scale_height) = ScaleClassResolution(p);
  m.image_format = options.format;
  nlohmann::json render = {{"samples_per_pixel", options.shading.samples_per_pixel},
                           {"depth", options.depth},
                           {"query_views",
                            {{"views", options.query_views.views},
                             {"render_size", options.query_views.render_size},
                             {"long_side", options.query_views.long_side},
                             {"hfov_deg", options.query_views.hfov_deg},
                             {"light_power_w", options.query_views.light_power_w},
                             {"samples_per_pixel", options.query_views.samples_per_pixel},
                             // Traced over the model's projected extent (2026-12-03); before,
                             // a render_size render was cropped and resized.
                             {"crop", "traced"}}},
                           {"query_shard_models", options.query_shard_models}};
  if (options.format != ImageFormat::kPng) render["quality"] = options.quality;
  // Uniform sampling has no key. Adaptive sampling's value names its version, as resuming
  // a dataset of another with this one would mix two kinds of pixels: "adaptive"
  // (unfiltered, 2026-12-02), "adaptive-filtered" (3x3 edges, 2026-12-03 morning),
  // "adaptive-filtered-2" (4-neighbour edges, flat pixels on the mask pass's hits), and
  // this one (a flat pixel's footprint under half a texel takes one texture lookup).
  if (options.shading.sampling == Sampling::kAdaptive) render["sampling"] = "adaptive-filtered-3";
  // The shader's arithmetic, for every image and query view: 2 since 2026-12-03 (evening),
  // when hit points came to be interpolated between world-space corners (the values differ
  // in the last bits, some 8-bit values by one); before, no key. 3 since issue 44: the
  // specular lobe's power and the ambient rays' directions from the shader's own vector
  // math (render/lanes.h) instead of std::pow, std::cos and std::sin.
  render["shading"] = 3;
  // The layout sampler's draws, same law, other layouts: 2 since issue 41, when a pose try
  // came to count its draws that miss the camera's candidates instead of making them
  // (render/placement.h); before, no key.
  render["placement"] = 2;
  m.params = {{"layout", ParamsToJson(p)}, {"render", render}};
  m.catalog_hash = sampler.library()->catalog_hash();
  return m;
}

Result<RenderReport> RenderDataset(const LayoutSampler& sampler, const RenderOptions& options) {
  const auto start = Clock::now();
  SOLID_RETURN_IF_ERROR(CheckCounts(options));
  const Manifest manifest = RenderManifest(sampler, options);
  SOLID_ASSIGN_OR_RETURN(const bool adopted, OpenDataset(options, manifest));
  SOLID_ASSIGN_OR_RETURN(const ShardRange requested, RequestedShards(options, manifest));
  DatasetRun run(sampler, options, manifest);
  RenderReport& report = run.report();
  report.adopted = adopted;
  report.shards_requested = requested.last - requested.first + 1;
  SOLID_ASSIGN_OR_RETURN(const std::vector<ShardTask> todo, ShardsToRender(run, requested));
  SOLID_ASSIGN_OR_RETURN(const std::vector<ShardTask> held_elsewhere, RenderUnheldShards(run, todo));
  SOLID_RETURN_IF_ERROR(AwaitShardsHeldElsewhere(run, held_elsewhere));
  if (options.queries && !run.stopped) SOLID_RETURN_IF_ERROR(RenderQueryShards(run));
  // A stop that came during the last shard, which was worth finishing, starts no index either.
  if (run.stopped || CancelRequested(options.cancel)) {
    ReportStop(run, requested);
  } else {
    SOLID_RETURN_IF_ERROR(IndexWhenComplete(run));
  }
  report.shading_instruction_set = BestFilmKernels().instruction_set;
  report.seconds = MillisecondsSince(start) / 1000;
  report.peak_rss_bytes = PeakRssBytes();
  return report;
}

Result<RenderCommandReport> RenderCommand(const RenderCommandOptions& options) {
  SOLID_ASSIGN_OR_RETURN(const std::unique_ptr<LayoutSampler> sampler, OpenSampler(options.source));
  RenderOptions render = options.render;
  render.query_views.render_size = QueryRenderSize(render.query_views.long_side);
  render.query_views.samples_per_pixel = render.shading.samples_per_pixel;
  render.texture_cache_bytes = options.source.library.cache_bytes;
  SOLID_ASSIGN_OR_RETURN(RenderReport report, RenderDataset(*sampler, render));
  return RenderCommandReport{sampler->params(), std::move(report)};
}

int QueryRenderSize(int long_side) { return (long_side * 12 + 6) / 7; }

Result<std::pair<int64_t, int64_t>> ParseShardRange(std::string_view field, std::string_view text) {
  const std::string copy(text);
  long long a = -1, b = -1;
  char dash = 0, rest = 0;
  if (std::sscanf(copy.c_str(), "%lld%c%lld%c", &a, &dash, &b, &rest) != 3 || dash != '-' || a < 0 || b < a) {
    return OptionError(field, fmt::format("{}: expected FIRST-LAST, e.g. 0-15", text));
  }
  return std::pair<int64_t, int64_t>{a, b};
}

Result<std::optional<ScheduledShard>> ShardFromEnvironment() {
  for (const char* variable : {"SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"}) {
    const char* value = std::getenv(variable);
    if (value == nullptr || *value == '\0') continue;
    char* end = nullptr;
    const long long k = std::strtoll(value, &end, 10);
    if (*end != '\0' || k < 0) return InvalidArgumentError(fmt::format("{}={}: not a shard index", variable, value));
    return std::optional(ScheduledShard{k, variable});
  }
  return std::optional<ScheduledShard>();
}

}  // namespace solid::render
