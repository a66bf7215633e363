#include "solid/export/zarr.h"

#include <blosc.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <system_error>
#include <utility>

#include "solid/formats/checksum.h"
#include "solid/formats/dataset.h"
#include "solid/formats/files.h"
#include "solid/formats/rle.h"
#include "solid/formats/shard.h"

namespace solid::exporters {
namespace {

namespace fs = std::filesystem;

static_assert(kBloscMaxBufferBytes == BLOSC_MAX_BUFFERSIZE);

// numcodecs' Blosc() default, which create_zarr.py leaves in place: lz4 at level 5 with
// byte shuffle, the block size Blosc picks.
constexpr int kBloscLevel = 5;
constexpr const char* kBloscCodec = "lz4";

void PutLe32(std::vector<uint8_t>& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
}
void PutLe64(std::vector<uint8_t>& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
}

// zarr.util.guess_chunks of zarr 2 for one dimension: the chunk that create_zarr.py's arrays
// without explicit chunks (valids, query_ids, scenenet_models) get.
int64_t GuessChunk(int64_t length, int64_t typesize) {
  constexpr double kBase = 256 * 1024, kMin = 128 * 1024, kMax = 64 * 1024 * 1024;
  double chunk = std::max<double>(static_cast<double>(length), 1);
  const double dataset_bytes = chunk * static_cast<double>(typesize);
  const double target = std::clamp(kBase * std::pow(2.0, std::log10(dataset_bytes / (1024.0 * 1024.0))), kMin, kMax);
  for (;;) {
    const double bytes = chunk * static_cast<double>(typesize);
    if ((bytes < target || std::fabs(bytes - target) / target < 0.5) && bytes < kMax) break;
    if (chunk == 1) break;
    chunk = std::ceil(chunk / 2.0);
  }
  return static_cast<int64_t>(chunk);
}

struct ArraySpec {
  std::string name;
  std::vector<int64_t> shape, chunks;
  std::string dtype;         // of the elements, "|O" for variable-length ones
  std::string vlen_dtype;    // of a VLenArray's items; empty for fixed-size elements
  nlohmann::json fill_value;  // null, false or 0, as zarr.empty and zarr.zeros write them
  bool compressed = true;
};

// As zarr 2.13 writes .zarray: sorted keys (nlohmann's objects are), indent 4.
std::string ZarrayText(const ArraySpec& a) {
  nlohmann::json j = {{"chunks", a.chunks},  {"dtype", a.dtype},     {"fill_value", a.fill_value},
                      {"order", "C"},        {"shape", a.shape},     {"zarr_format", 2}};
  j["compressor"] = a.compressed ? nlohmann::json{{"blocksize", 0},
                                                  {"clevel", kBloscLevel},
                                                  {"cname", kBloscCodec},
                                                  {"id", "blosc"},
                                                  {"shuffle", BLOSC_SHUFFLE}}
                                 : nlohmann::json();
  j["filters"] = a.vlen_dtype.empty() ? nlohmann::json()
                                      : nlohmann::json::array({{{"dtype", a.vlen_dtype}, {"id", "vlen-array"}}});
  return j.dump(4, ' ', true);
}

std::span<const uint8_t> Bytes(std::string_view s) { return {reinterpret_cast<const uint8_t*>(s.data()), s.size()}; }

Status ErrnoError(std::string_view what, const fs::path& path, int err) {
  return IoError(fmt::format("{}: {}: {}", path.string(), what, std::strerror(err)));
}

// One file of the temporary store, written in order and synced when closed. Messages name
// `display`, its path in the published store: the temporary is gone when they are read.
class StoreFile {
 public:
  static Result<StoreFile> Create(const fs::path& path, const fs::path& display) {
    StoreFile f;
    f.display_ = display;
    f.fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (f.fd_ < 0) return ErrnoError("create", display, errno);
    return f;
  }
  StoreFile(StoreFile&& o) noexcept
      : display_(std::move(o.display_)), fd_(std::exchange(o.fd_, -1)), buffer_(std::move(o.buffer_)),
        bytes_(o.bytes_) {}
  StoreFile& operator=(StoreFile&& o) noexcept {
    std::swap(display_, o.display_);
    std::swap(fd_, o.fd_);
    std::swap(buffer_, o.buffer_);
    std::swap(bytes_, o.bytes_);
    return *this;
  }
  ~StoreFile() {
    if (fd_ >= 0) ::close(fd_);
  }

  Status Write(std::span<const uint8_t> bytes) {
    bytes_ += static_cast<int64_t>(bytes.size());
    constexpr size_t kBuffer = 1 << 20;  // images and views are written item by item
    if (buffer_.size() + bytes.size() < kBuffer) {
      buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
      return Status::Ok();
    }
    SOLID_RETURN_IF_ERROR(Flush());
    return files::WriteAll(fd_, bytes, display_);
  }
  // A variable-length item: its u32 byte count, then its bytes.
  Status WriteItem(std::span<const uint8_t> bytes) {
    std::vector<uint8_t> header;
    PutLe32(header, static_cast<uint32_t>(bytes.size()));
    SOLID_RETURN_IF_ERROR(Write(header));
    return Write(bytes);
  }
  Status Close() {
    SOLID_RETURN_IF_ERROR(Flush());
    if (::fsync(fd_) != 0) return ErrnoError("fsync", display_, errno);
    const int fd = std::exchange(fd_, -1);
    if (::close(fd) != 0) return ErrnoError("close", display_, errno);
    return Status::Ok();
  }
  int64_t bytes() const { return bytes_; }

 private:
  StoreFile() = default;
  Status Flush() {
    Status s = files::WriteAll(fd_, buffer_, display_);
    buffer_.clear();
    return s;
  }
  fs::path display_;
  int fd_ = -1;
  std::vector<uint8_t> buffer_;
  int64_t bytes_ = 0;
};

// The temporary store beside out_dir, removed unless published.
class Store {
 public:
  Store(fs::path temp, fs::path final_dir, int64_t max_chunk_bytes)
      : temp_(std::move(temp)), final_(std::move(final_dir)), max_chunk_bytes_(max_chunk_bytes) {}
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;
  ~Store() {
    if (published_) return;
    std::error_code ec;
    fs::remove_all(temp_, ec);
  }

  Status Begin() {
    if (::mkdir(temp_.c_str(), 0755) != 0) {
      return ErrnoError(fmt::format("create the temporary store {}", temp_.string()), final_, errno);
    }
    return Status::Ok();
  }
  Status AddArray(const std::string& name) {
    if (::mkdir((temp_ / name).c_str(), 0755) != 0) return ErrnoError("create", final_ / name, errno);
    arrays_.push_back(name);
    return Status::Ok();
  }
  Result<StoreFile> Open(const fs::path& relative) { return StoreFile::Create(temp_ / relative, final_ / relative); }
  Status WriteFile(const fs::path& relative, std::span<const uint8_t> bytes) {
    SOLID_ASSIGN_OR_RETURN(StoreFile f, Open(relative));
    SOLID_RETURN_IF_ERROR(f.Write(bytes));
    SOLID_RETURN_IF_ERROR(f.Close());
    bytes_ += static_cast<int64_t>(bytes.size());
    return Status::Ok();
  }
  // A raw chunk through Blosc; `what` names its rows for a chunk over the limit.
  Status WriteCompressed(const fs::path& relative, std::span<const uint8_t> raw, size_t typesize,
                         std::string_view what) {
    SOLID_RETURN_IF_ERROR(CheckChunkSize(relative, static_cast<int64_t>(raw.size()), what));
    const size_t capacity = raw.size() + BLOSC_MAX_OVERHEAD;
    auto out = std::make_unique_for_overwrite<uint8_t[]>(capacity);
    const int n = blosc_compress_ctx(kBloscLevel, BLOSC_SHUFFLE, typesize, raw.size(), raw.data(), out.get(), capacity,
                                     kBloscCodec, 0, 1);
    // With BLOSC_MAX_OVERHEAD of room Blosc always succeeds (blosc.h): anything else is its failure.
    if (n <= 0) return InternalError(fmt::format("{}: Blosc failed ({}) on {} bytes", (final_ / relative).string(), n, raw.size()));
    return WriteFile(relative, {out.get(), static_cast<size_t>(n)});
  }
  Status CheckChunkSize(const fs::path& relative, int64_t bytes, std::string_view what) const {
    if (bytes <= max_chunk_bytes_) return Status::Ok();
    return LimitExceededError(fmt::format("{}: the raw chunk of {} would be {} bytes, over the limit of {} bytes (Blosc's "
                                          "largest buffer is {}): export with a smaller chunk",
                                          (final_ / relative).string(), what, bytes, max_chunk_bytes_,
                                          kBloscMaxBufferBytes));
  }
  void Count(int64_t bytes) { bytes_ += bytes; }
  int64_t bytes() const { return bytes_; }

  // .zgroup last, so that an unfinished store opens as no zarr group; every file was synced
  // when closed, so the directories are synced, then the whole renamed into place.
  Status Publish() {
    SOLID_RETURN_IF_ERROR(WriteFile(".zgroup", Bytes("{\n    \"zarr_format\": 2\n}")));
    for (const std::string& a : arrays_) SOLID_RETURN_IF_ERROR(SyncDirectory(a));
    SOLID_RETURN_IF_ERROR(SyncDirectory(""));
    // rename(2) replaces an empty directory and refuses one that is not (ENOTEMPTY, EEXIST).
    if (::rename(temp_.c_str(), final_.c_str()) != 0) {
      const int err = errno;
      if (err == ENOTEMPTY || err == EEXIST) {
        return AlreadyExistsError(fmt::format("{}: appeared during the export and is not empty: left as it is",
                                              final_.string()));
      }
      return ErrnoError(fmt::format("rename from {}", temp_.string()), final_, err);
    }
    published_ = true;
    return files::SyncDirectory(final_.parent_path().empty() ? "." : final_.parent_path());
  }

 private:
  Status SyncDirectory(const fs::path& relative) {
    Status s = files::SyncDirectory(temp_ / relative);
    return s.ok() ? s : IoError(fmt::format("{}: fsync: {}", (final_ / relative).string(), s.message()));
  }
  fs::path temp_, final_;
  int64_t max_chunk_bytes_;
  std::vector<std::string> arrays_;
  int64_t bytes_ = 0;
  bool published_ = false;
};

struct Model {
  std::string key;
  int64_t query_shard = 0;
  int32_t views = 0;
  std::optional<std::string> failure;
  int32_t klass = -1;  // -1: dropped
};

const Model* FindModel(const std::vector<Model>& models, std::string_view key) {
  auto it = std::lower_bound(models.begin(), models.end(), key, [](const Model& m, std::string_view k) { return m.key < k; });
  return it != models.end() && it->key == key ? &*it : nullptr;
}

// Euler XYZ (R = Rz Ry Rx) of camera^-1 * object with the scale removed, as the reference's
// get_angles: Blender's Matrix.to_euler() normalises the columns, then of the two solutions
// keeps the one with the smaller sum of magnitudes.
Result<std::array<double, 3>> CameraRelativeEuler(const Affine3x4& camera, const Affine3x4& object) {
  double m[3][3];
  // A camera pose is a rotation: its inverse is its transpose.
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      m[r][c] = camera[0 * 4 + r] * object[0 * 4 + c] + camera[1 * 4 + r] * object[1 * 4 + c] +
                camera[2 * 4 + r] * object[2 * 4 + c];
    }
  }
  for (int c = 0; c < 3; ++c) {
    const double n = std::sqrt(m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c]);
    if (!(n > 0) || !std::isfinite(n)) return CorruptError("its pose has a degenerate axis");
    for (int r = 0; r < 3; ++r) m[r][c] /= n;
  }
  const double cy = std::hypot(m[0][0], m[1][0]);
  if (cy > 16.0 * std::numeric_limits<float>::epsilon()) {
    const std::array<double, 3> a = {std::atan2(m[2][1], m[2][2]), std::atan2(-m[2][0], cy), std::atan2(m[1][0], m[0][0])};
    const std::array<double, 3> b = {std::atan2(-m[2][1], -m[2][2]), std::atan2(-m[2][0], -cy),
                                     std::atan2(-m[1][0], -m[0][0])};
    auto size = [](const std::array<double, 3>& e) { return std::fabs(e[0]) + std::fabs(e[1]) + std::fabs(e[2]); };
    return size(a) > size(b) ? b : a;
  }
  return std::array<double, 3>{std::atan2(-m[1][2], m[1][1]), std::atan2(-m[2][0], cy), 0.0};
}

void PutFloat(std::vector<uint8_t>& out, double v) { PutLe32(out, std::bit_cast<uint32_t>(static_cast<float>(v))); }

// One exported image waiting for its chunk: its image bytes are in the images chunk file
// already, the rest is made when the chunk is written.
struct Row {
  int64_t image_id = 0;
  uint32_t width = 0, height = 0;
  std::vector<InstanceRecord> instances;  // kept, in render-id order
  std::vector<int32_t> classes;
  std::vector<std::array<double, 3>> angles;
};

// A chunk of `count` variable-length items, the first `items.size()` given, the rest empty.
std::vector<uint8_t> VlenChunk(int count, const std::vector<std::vector<uint8_t>>& items) {
  size_t size = 4 + 4 * static_cast<size_t>(count);
  for (const auto& i : items) size += i.size();
  std::vector<uint8_t> out;
  out.reserve(size);
  PutLe32(out, static_cast<uint32_t>(count));
  for (int k = 0; k < count; ++k) {
    const size_t n = static_cast<size_t>(k) < items.size() ? items[k].size() : 0;
    PutLe32(out, static_cast<uint32_t>(n));
    if (n > 0) out.insert(out.end(), items[k].begin(), items[k].end());
  }
  return out;
}

class Exporter {
 public:
  Exporter(const ZarrExportOptions& options, Dataset& dataset, Store& store)
      : o_(options), dataset_(dataset), manifest_(dataset.manifest()), store_(store), chunk_(options.chunk) {}

  Status LoadModels() {
    for (const ShardFile& file : dataset_.shards().queries) {
      SOLID_ASSIGN_OR_RETURN(QueryShardReader reader, QueryShardReader::Open(file.path));
      SOLID_RETURN_IF_ERROR(CheckBelongs(reader, file));
      SOLID_ASSIGN_OR_RETURN(std::vector<QueryModelRecord> models, reader.Models());
      for (QueryModelRecord& m : models) {
        models_.push_back({std::move(m.model_key), file.index, m.view_count, std::move(m.failure)});
      }
    }
    if (models_.empty()) {
      return NotFoundError(fmt::format("{}: the dataset has no query views (no model in {}): SOLID's reader needs "
                                       "views of every class; render them first",
                                       o_.dataset.string(), DatasetPaths(o_.dataset).queries_dir().string()));
    }
    std::sort(models_.begin(), models_.end(), [](const Model& a, const Model& b) { return a.key < b.key; });
    for (size_t i = 1; i < models_.size(); ++i) {
      if (models_[i].key == models_[i - 1].key) {
        return CorruptError(fmt::format("{}: model {} is in query shards {} and {}", o_.dataset.string(), models_[i].key,
                                        models_[i - 1].query_shard, models_[i].query_shard));
      }
    }
    std::vector<const Model*> viewless;
    for (Model& m : models_) {
      if (m.views == 0) {
        viewless.push_back(&m);
        continue;
      }
      m.klass = classes_++;
      shots_ = std::max(shots_, m.views);
    }
    if (!viewless.empty() && !o_.drop_viewless_models) {
      const Model& first = *viewless.front();
      return NotFoundError(fmt::format(
          "{}: {} of {} models have no query view, and SOLID's reader crashes on a class without one: {} (in {}{}){}; "
          "render their views again, or drop these models and their instances",
          o_.dataset.string(), viewless.size(), models_.size(), first.key,
          DatasetPaths(o_.dataset).query_shard(first.query_shard).string(),
          first.failure ? ": " + *first.failure : std::string(),
          viewless.size() > 1 ? fmt::format(" and {} more", viewless.size() - 1) : std::string()));
    }
    for (const Model* m : viewless) report_.dropped_models.push_back(m->key);
    if (classes_ == 0) {
      return NotFoundError(fmt::format("{}: no model has a query view: nothing to export", o_.dataset.string()));
    }
    return Status::Ok();
  }

  // Row block b of `queries` is chunk b.f for each f of the shots' column chunks: every
  // class's views cycled into its slots, past the last class and the last shot empty.
  Status WriteQueries() {
    SOLID_RETURN_IF_ERROR(store_.AddArray("queries"));
    const int64_t column_chunks = (shots_ + chunk_ - 1) / chunk_;
    std::vector<const Model*> by_class;
    for (const Model& m : models_) {
      if (m.klass >= 0) by_class.push_back(&m);
    }
    std::optional<QueryShardReader> reader;
    int64_t reader_shard = -1;
    for (int64_t block = 0; block * chunk_ < classes_; ++block) {
      std::vector<StoreFile> files;
      for (int64_t f = 0; f < column_chunks; ++f) {
        SOLID_ASSIGN_OR_RETURN(StoreFile file, store_.Open(fs::path("queries") / fmt::format("{}.{}", block, f)));
        std::vector<uint8_t> count;
        PutLe32(count, static_cast<uint32_t>(chunk_ * chunk_));
        SOLID_RETURN_IF_ERROR(file.Write(count));
        files.push_back(std::move(file));
      }
      for (int64_t r = 0; r < chunk_; ++r) {
        const int64_t k = block * chunk_ + r;
        std::vector<QueryViewRecord> views;
        if (k < classes_) {
          if (CancelRequested(o_.cancel)) return Stopped();
          const Model& m = *by_class[static_cast<size_t>(k)];
          const fs::path path = DatasetPaths(o_.dataset).query_shard(m.query_shard);
          if (reader_shard != m.query_shard) {
            reader.reset();
            SOLID_ASSIGN_OR_RETURN(QueryShardReader opened, QueryShardReader::Open(path));
            reader.emplace(std::move(opened));
            reader_shard = m.query_shard;
          }
          SOLID_ASSIGN_OR_RETURN(views, reader->ViewsOfModel(m.key));
          if (views.size() != static_cast<size_t>(m.views)) {
            return CorruptError(fmt::format("{}: model {} has {} views, its row says {}", path.string(), m.key,
                                            views.size(), m.views));
          }
        }
        for (int64_t f = 0; f < column_chunks; ++f) {
          for (int64_t j = f * chunk_; j < (f + 1) * chunk_; ++j) {
            const bool slot = !views.empty() && j < shots_;
            SOLID_RETURN_IF_ERROR(files[f].WriteItem(
                slot ? std::span<const uint8_t>(views[static_cast<size_t>(j) % views.size()].image)
                     : std::span<const uint8_t>()));
          }
        }
      }
      for (StoreFile& f : files) {
        SOLID_RETURN_IF_ERROR(f.Close());
        store_.Count(f.bytes());
      }
    }
    return Status::Ok();
  }

  Status WriteTargets() {
    for (const char* name : {"images", "bboxes", "masks", "visibilities", "mask_bbox_ratios", "angles", "solid_image_ids"}) {
      SOLID_RETURN_IF_ERROR(store_.AddArray(name));
    }
    int64_t done = 0;
    for (const ShardFile& file : dataset_.shards().targets) {
      SOLID_ASSIGN_OR_RETURN(ShardReader shard, ShardReader::Open(file.path));
      SOLID_RETURN_IF_ERROR(CheckBelongs(shard, file));
      SOLID_ASSIGN_OR_RETURN(std::vector<int64_t> ids, shard.ImageIds());
      for (int64_t id : ids) {
        if (CancelRequested(o_.cancel)) return Stopped();
        SOLID_ASSIGN_OR_RETURN(ImageRecord image, shard.ReadImage(id));
        if (image.width != manifest_.width || image.height != manifest_.height) {
          return CorruptError(fmt::format("{}: image {} is {}x{}, the manifest says {}x{}", file.path.string(), id,
                                          image.width, image.height, manifest_.width, manifest_.height));
        }
        SOLID_ASSIGN_OR_RETURN(std::vector<InstanceRecord> instances, shard.InstancesOfImage(id));
        Row row{id, image.width, image.height, {}, {}, {}};
        for (InstanceRecord& in : instances) {
          if (in.visible_area == 0) {
            ++report_.skipped_invisible;
            continue;
          }
          const Model* model = FindModel(models_, in.model_key);
          if (model == nullptr) {
            return NotFoundError(fmt::format("{}: image {} instance {}: model {} is in no query shard of the dataset "
                                             "(its query shard is missing)",
                                             file.path.string(), id, in.ordinal, in.model_key));
          }
          if (model->klass < 0) {
            ++report_.dropped_instances;
            continue;
          }
          Result<std::array<double, 3>> angles = CameraRelativeEuler(image.camera.world_from_camera, in.world_from_object);
          if (!angles.ok()) {
            return angles.status().WithContext(fmt::format("{}: image {} instance {}", file.path.string(), id, in.ordinal));
          }
          row.classes.push_back(model->klass);
          row.angles.push_back(*angles);
          row.instances.push_back(std::move(in));
        }
        if (row.instances.empty()) {
          ++report_.skipped_images;
        } else {
          SOLID_RETURN_IF_ERROR(AddRow(std::move(row), image.image));
        }
        if (o_.progress) o_.progress(++done, manifest_.images);
      }
    }
    if (!rows_.empty()) SOLID_RETURN_IF_ERROR(WriteChunk());
    if (report_.images == 0) {
      return NotFoundError(fmt::format("{}: no image has a visible instance{}: nothing to export", o_.dataset.string(),
                                       report_.dropped_instances > 0 ? " of a model with views" : ""));
    }
    return Status::Ok();
  }

  // valids, query_ids, the metadata of every array and solid_export.json; then publication.
  Status Finish() {
    const int64_t n = report_.images;
    SOLID_RETURN_IF_ERROR(store_.AddArray("valids"));
    const int64_t valids_chunk = GuessChunk(n, 1);
    for (int64_t c = 0; c * valids_chunk < n; ++c) {
      std::vector<uint8_t> raw(static_cast<size_t>(valids_chunk), 0);
      std::fill_n(raw.begin(), std::min(valids_chunk, n - c * valids_chunk), 1);
      SOLID_RETURN_IF_ERROR(store_.WriteCompressed(fs::path("valids") / std::to_string(c), raw, 1, "valids"));
    }
    SOLID_RETURN_IF_ERROR(store_.AddArray("query_ids"));
    const int64_t ids_chunk = GuessChunk(classes_, 8);
    for (int64_t c = 0; c * ids_chunk < classes_; ++c) {
      std::vector<uint8_t> raw;
      for (int64_t k = c * ids_chunk; k < (c + 1) * ids_chunk; ++k) PutLe64(raw, k < classes_ ? static_cast<uint64_t>(k) : 0);
      SOLID_RETURN_IF_ERROR(store_.WriteCompressed(fs::path("query_ids") / std::to_string(c), raw, 8, "query_ids"));
    }
    SOLID_RETURN_IF_ERROR(store_.AddArray("scenenet_models"));

    auto vlen = [&](std::string name, std::string items, bool compressed) {
      return ArraySpec{std::move(name), {n}, {chunk_}, "|O", std::move(items), nullptr, compressed};
    };
    const std::vector<ArraySpec> arrays = {
        vlen("images", "|i1", false),
        vlen("bboxes", "<i4", true),
        vlen("masks", "|i1", true),
        vlen("visibilities", "<f4", true),
        vlen("mask_bbox_ratios", "<f4", true),
        vlen("angles", "<f4", true),
        {"queries", {classes_, shots_}, {chunk_, chunk_}, "|O", "|i1", nullptr, false},
        {"query_ids", {classes_}, {ids_chunk}, "<i8", "", 0, true},
        {"valids", {n}, {valids_chunk}, "|b1", "", false, true},
        {"scenenet_models", {n}, {GuessChunk(n, 128)}, "|S128", "", nullptr, true},
        {"solid_image_ids", {n}, {chunk_}, "<i8", "", 0, true},
    };
    for (const ArraySpec& a : arrays) SOLID_RETURN_IF_ERROR(store_.WriteFile(fs::path(a.name) / ".zarray", Bytes(ZarrayText(a))));

    nlohmann::json classes = nlohmann::json::array(), dropped = nlohmann::json::array();
    for (const Model& m : models_) {
      if (m.klass >= 0) {
        classes.push_back(m.key);
      } else {
        dropped.push_back({{"model_key", m.key}, {"failure", m.failure ? nlohmann::json(*m.failure) : nlohmann::json()}});
      }
    }
    const nlohmann::json about = {
        {"format", "solid-zarr-export"},
        {"version", 1},
        {"dataset",
         {{"generator", manifest_.generator_name + " " + manifest_.generator_version},
          {"seed", "0x" + Hex64(manifest_.seed)},
          {"params_hash", Hex64(manifest_.ParamsHash())},
          {"images", manifest_.images},
          {"width", manifest_.width},
          {"height", manifest_.height}}},
        {"chunk", chunk_},
        {"rows", n},
        {"skipped_images", report_.skipped_images},
        {"skipped_invisible_instances", report_.skipped_invisible},
        {"dropped_instances", report_.dropped_instances},
        {"classes", classes},
        {"dropped_models", dropped},
    };
    SOLID_RETURN_IF_ERROR(store_.WriteFile("solid_export.json", Bytes(about.dump(2) + "\n")));
    if (CancelRequested(o_.cancel)) return Stopped();
    SOLID_RETURN_IF_ERROR(store_.Publish());
    report_.classes = classes_;
    report_.query_shots = shots_;
    report_.store_bytes = store_.bytes();
    return Status::Ok();
  }

  ZarrExportReport& report() { return report_; }

 private:
  template <typename Reader>
  Status CheckBelongs(Reader& reader, const ShardFile& file) {
    SOLID_ASSIGN_OR_RETURN(auto meta, reader.Meta());
    SOLID_ASSIGN_OR_RETURN(ShardProvenance found, ReadProvenance(meta, file.path.string()));
    return CheckProvenance(found, manifest_, file.index, file.path.string());
  }

  Status Stopped() const {
    return CancelledError(fmt::format("{}: stopped after {} exported images; no store written", o_.out_dir.string(),
                                      report_.images));
  }

  fs::path ChunkPath(std::string_view array) const { return fs::path(array) / std::to_string(report_.chunks); }

  Status AddRow(Row row, std::span<const uint8_t> image) {
    if (rows_.empty()) {
      SOLID_ASSIGN_OR_RETURN(StoreFile f, store_.Open(ChunkPath("images")));
      std::vector<uint8_t> count;
      PutLe32(count, static_cast<uint32_t>(chunk_));
      SOLID_RETURN_IF_ERROR(f.Write(count));
      images_.emplace(std::move(f));
    }
    SOLID_RETURN_IF_ERROR(images_->WriteItem(image));
    rows_.push_back(std::move(row));
    ++report_.images;
    if (static_cast<int64_t>(rows_.size()) == chunk_) return WriteChunk();
    return Status::Ok();
  }

  // The chunk of rows_, its unused rows empty.
  Status WriteChunk() {
    for (size_t k = rows_.size(); k < static_cast<size_t>(chunk_); ++k) SOLID_RETURN_IF_ERROR(images_->WriteItem({}));
    SOLID_RETURN_IF_ERROR(images_->Close());
    store_.Count(images_->bytes());
    images_.reset();

    const std::string what = fmt::format("images {} to {}", rows_.front().image_id, rows_.back().image_id);
    std::vector<std::vector<uint8_t>> boxes, visibilities, ratios, angles;
    std::vector<uint8_t> ids;
    for (const Row& row : rows_) {
      std::vector<uint8_t>& b = boxes.emplace_back();
      std::vector<uint8_t>& v = visibilities.emplace_back();
      std::vector<uint8_t>& r = ratios.emplace_back();
      std::vector<uint8_t>& a = angles.emplace_back();
      for (size_t i = 0; i < row.instances.size(); ++i) {
        const InstanceRecord& in = row.instances[i];
        const rle::Box& box = in.visible_box;
        for (int64_t x : {box.x, box.y, box.x + box.w, box.y + box.h, int64_t{row.classes[i]}}) {
          PutLe32(b, static_cast<uint32_t>(static_cast<int32_t>(x)));
        }
        PutFloat(v, static_cast<double>(in.visible_area) / static_cast<double>(in.full_area));
        PutFloat(r, static_cast<double>(in.visible_area) / static_cast<double>(box.w * box.h));
        for (double e : row.angles[i]) PutFloat(a, e);
      }
      PutLe64(ids, static_cast<uint64_t>(row.image_id));
      report_.instances += static_cast<int64_t>(row.instances.size());
    }
    ids.resize(static_cast<size_t>(chunk_) * 8, 0);
    SOLID_RETURN_IF_ERROR(store_.WriteCompressed(ChunkPath("bboxes"), VlenChunk(chunk_, boxes), 1, what));
    SOLID_RETURN_IF_ERROR(store_.WriteCompressed(ChunkPath("visibilities"), VlenChunk(chunk_, visibilities), 1, what));
    SOLID_RETURN_IF_ERROR(store_.WriteCompressed(ChunkPath("mask_bbox_ratios"), VlenChunk(chunk_, ratios), 1, what));
    SOLID_RETURN_IF_ERROR(store_.WriteCompressed(ChunkPath("angles"), VlenChunk(chunk_, angles), 1, what));
    SOLID_RETURN_IF_ERROR(store_.WriteCompressed(ChunkPath("solid_image_ids"), ids, 8, what));
    SOLID_RETURN_IF_ERROR(WriteMasks(what));
    rows_.clear();
    ++report_.chunks;
    return Status::Ok();
  }

  // Sized before anything is decoded, so that a chunk over the limit allocates nothing.
  Status WriteMasks(std::string_view what) {
    int64_t size = 4 + 4 * int64_t{chunk_};
    for (const Row& row : rows_) size += static_cast<int64_t>(row.instances.size()) * row.width * row.height;
    SOLID_RETURN_IF_ERROR(store_.CheckChunkSize(ChunkPath("masks"), size, what));
    report_.largest_mask_chunk_bytes = std::max(report_.largest_mask_chunk_bytes, size);
    std::vector<uint8_t> raw;
    raw.reserve(static_cast<size_t>(size));
    PutLe32(raw, static_cast<uint32_t>(chunk_));
    for (const Row& row : rows_) {
      // A chunk of masks takes seconds: a stop is heeded inside it too.
      if (CancelRequested(o_.cancel)) return Stopped();
      PutLe32(raw, static_cast<uint32_t>(row.instances.size() * row.width * row.height));
      for (const InstanceRecord& in : row.instances) {
        Result<rle::Rle> mask = rle::FromString(in.visible_rle, row.height, row.width);
        if (!mask.ok()) {
          return mask.status().WithContext(fmt::format("image {} instance {}: visible_rle", row.image_id, in.ordinal));
        }
        const std::vector<uint8_t> pixels = rle::DecodeRowMajor(*mask);
        raw.insert(raw.end(), pixels.begin(), pixels.end());
      }
    }
    for (size_t k = rows_.size(); k < static_cast<size_t>(chunk_); ++k) PutLe32(raw, 0);
    return store_.WriteCompressed(ChunkPath("masks"), raw, 1, what);
  }

  const ZarrExportOptions& o_;
  Dataset& dataset_;
  const Manifest& manifest_;
  Store& store_;
  const int64_t chunk_;
  std::vector<Model> models_;  // by key
  int32_t classes_ = 0, shots_ = kZarrMinQueryShots;
  std::vector<Row> rows_;             // of the chunk being gathered
  std::optional<StoreFile> images_;   // its images chunk, written as rows come
  ZarrExportReport report_;
};

// Target shards 0 .. ShardCount()-1 must all be present: a store cannot be appended to.
Status CheckComplete(const Dataset& dataset, const fs::path& root) {
  std::vector<int64_t> missing;
  const auto& targets = dataset.shards().targets;
  size_t i = 0;
  for (int64_t k = 0; k < dataset.manifest().ShardCount(); ++k) {
    while (i < targets.size() && targets[i].index < k) ++i;
    if (i == targets.size() || targets[i].index != k) missing.push_back(k);
  }
  if (missing.empty()) return Status::Ok();
  std::string list;
  for (size_t j = 0; j < std::min<size_t>(missing.size(), 8); ++j) list += (j ? ", " : "") + std::to_string(missing[j]);
  if (missing.size() > 8) list += fmt::format(" and {} more", missing.size() - 8);
  return NotFoundError(fmt::format("{}: incomplete: {} of its {} target shards are missing ({}): finish rendering it first",
                                   root.string(), missing.size(), dataset.manifest().ShardCount(), list));
}

}  // namespace

nlohmann::json ZarrExportReport::ToJson() const {
  return {{"store", store.string()},
          {"images", images},
          {"skipped_images", skipped_images},
          {"instances", instances},
          {"skipped_invisible", skipped_invisible},
          {"classes", classes},
          {"query_shots", query_shots},
          {"chunks", chunks},
          {"dropped_models", dropped_models},
          {"dropped_instances", dropped_instances},
          {"largest_mask_chunk_bytes", largest_mask_chunk_bytes},
          {"store_bytes", store_bytes},
          {"seconds", seconds}};
}

std::string ZarrExportReport::ToText() const {
  std::string dropped;
  if (!dropped_models.empty()) {
    dropped = fmt::format(", {} viewless model{} dropped with {} instances", dropped_models.size(),
                          dropped_models.size() == 1 ? "" : "s", dropped_instances);
  }
  return fmt::format("{}: {} images ({} without a visible instance skipped), {} instances in {} classes ({} invisible "
                     "skipped{}), {} chunks, {} query slots per class, {:.1f} MB, {:.2f} s\n",
                     store.string(), images, skipped_images, instances, classes, skipped_invisible, dropped, chunks,
                     query_shots, static_cast<double>(store_bytes) / 1e6, seconds);
}

Result<ZarrExportReport> ExportZarr(const ZarrExportOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (options.dataset.empty()) return OptionError("dataset", "no dataset directory given");
  if (options.out_dir.empty()) return OptionError("out_dir", "no output directory given");
  if (options.chunk < 1 || options.chunk > kMaxZarrChunk) {
    return OptionError("chunk", fmt::format("{} rows per chunk is outside 1 to {}", options.chunk, kMaxZarrChunk));
  }
  if (options.max_chunk_bytes < 1 || options.max_chunk_bytes > kBloscMaxBufferBytes) {
    return OptionError("max_chunk_bytes",
                       fmt::format("{} is outside 1 to {} (Blosc's largest buffer)", options.max_chunk_bytes,
                                   kBloscMaxBufferBytes));
  }
  // "out/" names the directory "out", whose sibling the temporary is.
  const fs::path out = options.out_dir.filename().empty() ? options.out_dir.parent_path() : options.out_dir;
  std::error_code ec;
  if (fs::exists(fs::symlink_status(out, ec)) && (!fs::is_directory(fs::symlink_status(out, ec)) || !fs::is_empty(out, ec))) {
    return AlreadyExistsError(fmt::format("{}: exists and is not an empty directory: an export is never merged into "
                                          "another or resumed; remove it, or export elsewhere",
                                          out.string()));
  }
  SOLID_ASSIGN_OR_RETURN(Dataset dataset, Dataset::Open(options.dataset));
  SOLID_RETURN_IF_ERROR(CheckComplete(dataset, options.dataset));

  if (!out.parent_path().empty()) {
    fs::create_directories(out.parent_path(), ec);
    if (ec) return IoError(fmt::format("{}: cannot create: {}", out.parent_path().string(), ec.message()));
  }
  files::RemoveStaleTemps(out);
  Store store(files::TempPathFor(out), out, options.max_chunk_bytes);
  Exporter exporter(options, dataset, store);
  SOLID_RETURN_IF_ERROR(exporter.LoadModels());
  SOLID_RETURN_IF_ERROR(store.Begin());
  SOLID_RETURN_IF_ERROR(exporter.WriteQueries());
  SOLID_RETURN_IF_ERROR(exporter.WriteTargets());
  SOLID_RETURN_IF_ERROR(exporter.Finish());
  ZarrExportReport& report = exporter.report();
  report.store = out;
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace solid::exporters
