#include "solid/convert/convert.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <set>
#include <tuple>
#include <utility>

#include "obj.h"
#include "obj_to_asset.h"
#include "scenenet.h"
#include "solid/convert/procedural.h"
#include "gltf_reader.h"
#include "solid/formats/catalog.h"
#include "solid/formats/checksum.h"
#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"
#include "solid/formats/json_schema.h"
#include "solid/formats/workers.h"

namespace solid::convert {
// The asset model and its glb codec live in formats (render reads them too).
using namespace solid::gltf;
namespace fs = std::filesystem;
using nlohmann::json;

std::string_view ConverterVersion() { return "solid-convert " SOLID_VERSION; }

namespace {

constexpr uint64_t kMaxInputFileBytes = uint64_t{1} << 30;

// A failure of one asset: the catalog's error_code and a message naming where.
struct AssetFailure {
  std::string code;
  std::string message;
};

// What converting one asset produced, before it is written.
struct Converted {
  Asset asset;
  std::vector<ConvertWarning> warnings;
  json counts = json::object();
  json extras = json::object();
};

using ConvertFn = std::function<std::variant<Converted, AssetFailure>()>;

struct Job {
  std::string key, kind, source;
  fs::path output;                 // relative to the assets directory
  fs::path input_root;             // inputs are recorded relative to it
  std::vector<fs::path> inputs;    // absolute; hashed for resume
  std::string generator_identity;  // procedural assets: what determines them, in place of input files
  std::vector<ConvertWarning> discovery_warnings;
  std::optional<AssetFailure> discovery_failure;
  ConvertFn convert;
};

AssetFailure FailureFromStatus(const Status& s, std::string_view default_code) {
  for (std::string_view code : {"index_out_of_range", "empty_geometry", "missing_obj", "suspect_units",
                                "no_structure"}) {
    if (s.message().find(code) != std::string::npos) return {std::string(code), s.message()};
  }
  if (s.code() == StatusCode::kLimitExceeded) return {"limit_exceeded", s.message()};
  if (s.code() == StatusCode::kParseError) return {"parse_error", s.message()};
  if (s.code() == StatusCode::kIoError) return {"read_error", s.message()};
  return {std::string(default_code), s.message()};
}

std::vector<fs::path> SortedEntries(const fs::path& dir, bool directories) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    bool is_dir = it->is_directory(ec);
    if (is_dir == directories) out.push_back(it->path());
  }
  // Byte-wise order, whatever the locale.
  std::sort(out.begin(), out.end(), [](const fs::path& a, const fs::path& b) { return a.native() < b.native(); });
  return out;
}

// Every regular file below dir, except what never affects conversion.
std::vector<fs::path> ModelInputFiles(const fs::path& dir) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_directory(ec) && it->path().filename() == "screenshots") {
      it.disable_recursion_pending();
      continue;
    }
    if (!it->is_regular_file(ec)) continue;
    std::string name = it->path().filename().string();
    if (name.ends_with(".binvox")) continue;
    out.push_back(it->path());
  }
  std::sort(out.begin(), out.end(), [](const fs::path& a, const fs::path& b) { return a.native() < b.native(); });
  return out;
}

// XXH64 over (relative name, size, content hash) of every input; bytes_in is their total size.
Result<std::pair<uint64_t, int64_t>> HashInputs(const Job& job) {
  std::string text = job.generator_identity;
  int64_t bytes = 0;
  for (const fs::path& p : job.inputs) {
    SOLID_ASSIGN_OR_RETURN(files::FileDigest d, files::DigestFile(p));
    text += fmt::format("{}\t{}\t{}\n", fs::relative(p, job.input_root).generic_string(), d.bytes, Hex64(d.xxh64));
    bytes += static_cast<int64_t>(d.bytes);
  }
  return std::make_pair(Xxh64(text), bytes);
}

Result<ObjData> ReadObjFile(const fs::path& path) {
  SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, files::ReadFile(path, kMaxInputFileBytes));
  return ReadObj(bytes, path.string());
}

// The MTL named by the OBJ (first that exists), else one with the OBJ's stem.
Result<std::optional<MtlData>> ReadMtlFor(const fs::path& obj_path, const ObjData& obj, fs::path* mtl_path,
                                          std::vector<ConvertWarning>* warnings) {
  std::vector<fs::path> candidates;
  for (const std::string& name : obj.mtllibs) candidates.push_back(obj_path.parent_path() / name);
  if (obj.mtllibs.empty()) candidates.push_back(fs::path(obj_path).replace_extension(".mtl"));
  std::error_code ec;
  for (const fs::path& c : candidates) {
    if (!fs::is_regular_file(c, ec)) continue;
    SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, files::ReadFile(c, kMaxInputFileBytes));
    SOLID_ASSIGN_OR_RETURN(MtlData mtl, ReadMtl(bytes, c.string()));
    *mtl_path = c;
    return std::optional<MtlData>(std::move(mtl));
  }
  if (!obj.mtllibs.empty()) {
    warnings->push_back({"missing_mtl", fmt::format("{}: mtllib {} not found", obj_path.string(), obj.mtllibs[0])});
  }
  return std::optional<MtlData>();
}

// An OBJ with the MTL it names, and the builder options every source shares.
struct LoadedObj {
  ObjData obj;
  std::optional<MtlData> mtl;
  ObjAssetOptions options;
};

std::variant<LoadedObj, AssetFailure> LoadObj(const fs::path& obj_path, std::vector<ConvertWarning>* warnings) {
  Result<ObjData> obj = ReadObjFile(obj_path);
  if (!obj.ok()) return FailureFromStatus(obj.status(), "parse_error");
  LoadedObj loaded;
  loaded.obj = std::move(obj).value();
  fs::path mtl_path;
  Result<std::optional<MtlData>> mtl = ReadMtlFor(obj_path, loaded.obj, &mtl_path, warnings);
  if (!mtl.ok()) return FailureFromStatus(mtl.status(), "parse_error");
  loaded.mtl = std::move(mtl).value();
  loaded.options.mtl_dir = mtl_path.empty() ? obj_path.parent_path() : mtl_path.parent_path();
  loaded.options.mtl_name = mtl_path.empty() ? std::string() : mtl_path.string();
  loaded.options.obj_name = obj_path.string();
  return loaded;
}

json CountsJson(const CleanCounts& c, const ObjData& obj) {
  return {{"triangles_in", c.triangles_in},
          {"triangles_out", c.triangles_out},
          {"reversed_twins", c.reversed_twins},
          {"duplicates_removed", c.duplicates_removed},
          {"degenerates_removed", c.degenerates_removed},
          {"empty_blocks_dropped", c.empty_blocks_dropped},
          {"normals_renormalized", c.normals_renormalized},
          {"zero_normals", c.zero_normals},
          {"normals_from_geometry", c.normals_from_geometry},
          {"uvs_filled", c.uvs_filled},
          {"textures_embedded", c.textures_embedded},
          {"textures_missing", c.textures_missing},
          {"textures_rejected", c.textures_rejected},
          {"lines_ignored", obj.counts.line_records},
          {"points_ignored", obj.counts.point_records},
          {"polygons_triangulated", obj.counts.polygons_triangulated},
          {"short_faces_dropped", obj.counts.short_faces_dropped},
          {"unknown_records", obj.counts.unknown_records}};
}

// Applies `turn` (a rotation, so winding and normals stay valid) to every position and
// normal of `asset`, each as its x, y, z.
template <typename Turn>
void RotateAsset(Asset* asset, Turn turn) {
  for (Node& node : asset->nodes) {
    for (Primitive& p : node.primitives) {
      for (std::vector<float>* v : {&p.positions, &p.normals}) {
        for (size_t i = 0; i + 2 < v->size(); i += 3) turn((*v)[i], (*v)[i + 1], (*v)[i + 2]);
      }
    }
  }
}

// ShapeNet v1 frame (up +Y, front +X) to v2's (up +Y, front -Z): x' = z, z' = -x.
void RotateV1ToV2(Asset* asset) {
  RotateAsset(asset, [](float& x, float&, float& z) { std::tie(x, z) = std::pair{z, -x}; });
}

std::variant<Converted, AssetFailure> ConvertShapeNetModel(const fs::path& model_dir, const fs::path& obj_path,
                                                           const std::string& key, int version,
                                                           const json& synset_info) {
  std::error_code ec;
  if (!fs::is_regular_file(obj_path, ec)) {
    return AssetFailure{"missing_obj", fmt::format("{}: no {}", model_dir.string(),
                                                   fs::relative(obj_path, model_dir).generic_string())};
  }
  Converted c;
  std::variant<LoadedObj, AssetFailure> loaded_or = LoadObj(obj_path, &c.warnings);
  if (auto* failure = std::get_if<AssetFailure>(&loaded_or)) return *failure;
  LoadedObj& loaded = std::get<LoadedObj>(loaded_or);
  const ObjData* obj = &loaded.obj;
  ObjAssetOptions& options = loaded.options;
  options.grouping = NodeGrouping::kSingleNode;
  options.node_name = key;
  options.textures = TextureMode::kEmbed;
  options.confine_root = model_dir;
  Result<ObjAsset> built = BuildAssetFromObj(*obj, loaded.mtl ? &*loaded.mtl : nullptr, options);
  if (!built.ok()) return FailureFromStatus(built.status(), "empty_geometry");
  c.asset = std::move(built->asset);
  c.warnings.insert(c.warnings.end(), built->warnings.begin(), built->warnings.end());
  c.counts = CountsJson(built->counts, *obj);
  c.extras = synset_info;
  if (version == 1) {
    RotateV1ToV2(&c.asset);
    c.asset.extras["source_frame"] = "shapenet_v1: up +Y, front +X; rotated by x' = z, z' = -x";
  } else {
    fs::path json_path = obj_path.parent_path() / "model_normalized.json";
    Result<std::vector<uint8_t>> bytes = files::ReadFile(json_path, 1 << 20);
    if (bytes.ok()) {
      json j = json::parse(bytes->begin(), bytes->end(), nullptr, false);
      if (j.is_object() && j.contains("numVertices") && j["numVertices"].is_number_integer() &&
          j["numVertices"].get<int64_t>() != static_cast<int64_t>(obj->positions.size())) {
        c.warnings.push_back({"json_mismatch", fmt::format("{}: numVertices {} but the OBJ has {} v records",
                                                           json_path.string(), j["numVertices"].get<int64_t>(),
                                                           obj->positions.size())});
      }
      if (j.is_object() && j.contains("centroid") && j.contains("min") && j.contains("max") &&
          j["min"].is_array() && j["max"].is_array() && j["min"].size() == 3 && j["max"].size() == 3) {
        double d2 = 0;
        for (size_t k = 0; k < 3; ++k) {
          if (!j["min"][k].is_number() || !j["max"][k].is_number()) continue;
          double d = j["max"][k].get<double>() - j["min"][k].get<double>();
          d2 += d * d;
        }
        // v_obj = (v_src - centroid) / diagonal: enough to recover source coordinates.
        c.asset.extras["source_centroid"] = j["centroid"];
        c.asset.extras["source_diagonal"] = std::sqrt(d2);
      }
    }
  }
  return c;
}

// taxonomy.json in either shape: flat [{synsetId, name, children}] or a jstree of
// {metadata: {name, label}, children}. Returns synset id -> name.
std::map<std::string, std::string> ReadTaxonomy(const fs::path& root, bool* found) {
  std::map<std::string, std::string> names;
  Result<std::vector<uint8_t>> bytes = files::ReadFile(root / "taxonomy.json", 64 << 20);
  *found = bytes.ok();
  if (!bytes.ok()) return names;
  json j = json::parse(bytes->begin(), bytes->end(), nullptr, false);
  std::function<void(const json&, int)> walk = [&](const json& node, int depth) {
    if (depth > 64) return;
    if (node.is_array()) {
      for (const json& n : node) walk(n, depth + 1);
      return;
    }
    if (!node.is_object()) return;
    if (node.contains("synsetId") && node["synsetId"].is_string() && node.contains("name") && node["name"].is_string()) {
      names[node["synsetId"].get<std::string>()] = node["name"].get<std::string>();
    }
    if (node.contains("metadata") && node["metadata"].is_object()) {
      const json& m = node["metadata"];
      if (m.contains("name") && m["name"].is_string() && m.contains("label") && m["label"].is_string()) {
        names[m["name"].get<std::string>()] = m["label"].get<std::string>();
      }
    }
    if (node.contains("children") && node["children"].is_array()) {
      for (const json& c : node["children"]) {
        if (c.is_object() || c.is_array()) walk(c, depth + 1);
      }
    }
  };
  walk(j, 0);
  return names;
}

bool SafePathComponent(const std::string& name) {
  return !name.empty() && name[0] != '.' && name.find('/') == std::string::npos &&
         name.find('\\') == std::string::npos;
}

bool ObjZUp(const ConvertOptions& o) {
  if (o.obj_up != UpAxis::kLayoutDefault) return o.obj_up == UpAxis::kZ;
  return o.obj_layout != ObjLayout::kFlat;
}

json OptionsIdentity(const ConvertOptions& o) {
  json identity = {{"position_bits", o.draco.position_bits},
                   {"normal_bits", o.draco.normal_bits},
                   {"texcoord_bits", o.draco.texcoord_bits},
                   {"compression_level", o.draco.compression_level},
                   {"keep_all_room_objects", o.keep_all_room_objects},
                   {"texture_library", o.texture_library}};
  // Only where it turns the model, so that no catalog written before the axis was an
  // option converts again.
  if (o.source == Source::kObj && ObjZUp(o)) identity["obj_up"] = "z";
  return identity;
}

// Temporaries that killed writers left in the assets directory (a killed convert leaves
// "<asset>.glb.tmp-<host>-<pid>-<n>"), in one pass over the tree rather than one per asset.
void RemoveStaleTempsUnder(const fs::path& out) {
  std::error_code ec;
  std::vector<fs::path> finals;
  for (fs::recursive_directory_iterator it(out, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (files::IsTempPath(it->path())) finals.push_back(it->path().parent_path() / name.substr(0, name.find(".tmp-")));
  }
  std::sort(finals.begin(), finals.end());
  finals.erase(std::unique(finals.begin(), finals.end()), finals.end());
  for (const fs::path& f : finals) files::RemoveStaleTemps(f);
}

// The catalog's rows by key.
Result<std::map<std::string, CatalogEntry>> RowsByKey(Catalog& catalog) {
  SOLID_ASSIGN_OR_RETURN(std::vector<CatalogEntry> rows, catalog.All());
  std::map<std::string, CatalogEntry> by_key;
  for (CatalogEntry& e : rows) by_key.emplace(e.key, std::move(e));
  return by_key;
}

// What every job of one run is converted with and compared against.
struct JobContext {
  fs::path out;
  const ConvertOptions& options;
  std::map<std::string, CatalogEntry> existing;  // the catalog's rows before the run
  uint64_t options_hash = 0;                     // of OptionsIdentity
  std::string version;                           // ConverterVersion()
};

// What converting one job came to.
struct Finished {
  std::optional<CatalogEntry> entry;  // empty when up to date
  ItemOutcome outcome;
  // The output directory refused a write: no fault of the asset, so no catalog row (a
  // "failed" row would keep a rerun from converting it); the batch stops.
  Status output_error;
};

// The job's catalog row as far as the job itself says: what it is, and what converts it.
CatalogEntry RowOfJob(const Job& job, const JobContext& context) {
  CatalogEntry e;
  e.key = job.key;
  e.kind = job.kind;
  e.source = job.source;
  e.converter_version = context.version;
  e.options_hash = context.options_hash;
  for (const fs::path& p : job.inputs) e.input_files.push_back(fs::relative(p, job.input_root).generic_string());
  return e;
}

// The earlier run's row of this asset stands: the same inputs (row.input_hash), converter and
// options, and either its GLB intact or a failure that is not to be retried.
bool UpToDate(const CatalogEntry& row, const JobContext& context) {
  const auto it = context.existing.find(row.key);
  if (it == context.existing.end()) return false;
  const CatalogEntry& old = it->second;
  const bool same = old.input_hash == row.input_hash && old.converter_version == context.version &&
                    old.options_hash == context.options_hash;
  bool output_intact = false;
  if (same && old.status != AssetStatus::kFailed && old.file && old.output_xxh64) {
    Result<files::FileDigest> d = files::DigestFile(context.out / *old.file);
    output_intact = d.ok() && d->xxh64 == *old.output_xxh64;
  }
  return same && (output_intact || (old.status == AssetStatus::kFailed && !context.options.retry_failed));
}

// Writes the GLB at `target`, atomically, into a directory created for it if need be.
Status WriteOutput(const fs::path& target, const std::vector<uint8_t>& glb) {
  std::error_code dir_ec;
  fs::create_directories(target.parent_path(), dir_ec);
  if (dir_ec) {
    return IoError(fmt::format("{}: cannot create the directory: {}", target.parent_path().string(),
                               dir_ec.message()));
  }
  return files::WriteFileAtomically(target, glb);
}

// The row's description of the written asset, and its status.
void DescribeOutput(const Job& job, Converted& c, const std::vector<uint8_t>& glb, CatalogEntry* e) {
  e->file = job.output.generic_string();
  e->output_xxh64 = Xxh64(glb);
  e->bytes_out = static_cast<int64_t>(glb.size());
  e->vertices = static_cast<int64_t>(VertexCount(c.asset));
  e->triangles = static_cast<int64_t>(TriangleCount(c.asset));
  e->materials = static_cast<int64_t>(c.asset.materials.size());
  e->textures = static_cast<int64_t>(c.asset.textures.size());
  Bounds b = ComputeBounds(c.asset);
  if (!b.empty) e->bounds = std::array<double, 6>{b.min[0], b.min[1], b.min[2], b.max[0], b.max[1], b.max[2]};
  e->counts = std::move(c.counts);
  e->extras = std::move(c.extras);
  e->status = e->warnings.empty() ? AssetStatus::kOk : AssetStatus::kOkWithWarnings;
}

// Converts one job, unless its row is up to date, and writes its GLB.
Finished ConvertJob(const Job& job, const JobContext& context) {
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  };
  Finished f;
  f.outcome.key = job.key;
  CatalogEntry e = RowOfJob(job, context);
  auto fail = [&](const AssetFailure& failure) {
    e.status = AssetStatus::kFailed;
    e.error_code = failure.code;
    e.error = failure.message;
    f.outcome.status = "failed";
    f.outcome.error_code = failure.code;
    f.outcome.message = failure.message;
    f.outcome.milliseconds = elapsed();
    f.entry = std::move(e);
    return std::move(f);
  };
  Result<std::pair<uint64_t, int64_t>> hashed = HashInputs(job);
  if (!hashed.ok()) return fail(FailureFromStatus(hashed.status(), "read_error"));
  e.input_hash = hashed->first;
  e.bytes_in = hashed->second;
  if (UpToDate(e, context)) {
    f.outcome.status = "up_to_date";
    f.outcome.milliseconds = elapsed();
    return f;
  }
  e.warnings = json::array();
  for (const ConvertWarning& w : job.discovery_warnings) {
    e.warnings.push_back({{"code", w.code}, {"message", w.message}});
  }
  if (job.discovery_failure) return fail(*job.discovery_failure);
  std::variant<Converted, AssetFailure> result = job.convert();
  if (auto* failure = std::get_if<AssetFailure>(&result)) return fail(*failure);
  Converted& c = std::get<Converted>(result);
  for (const ConvertWarning& w : c.warnings) e.warnings.push_back({{"code", w.code}, {"message", w.message}});
  const fs::path target = context.out / job.output;
  Result<std::vector<uint8_t>> glb = WriteGlb(c.asset, context.options.draco);
  if (!glb.ok()) return fail({"write_error", fmt::format("{}: {}", target.string(), glb.status().message())});
  if (Status written = WriteOutput(target, *glb); !written.ok()) {
    f.output_error = std::move(written);
    return f;
  }
  DescribeOutput(job, c, *glb, &e);
  f.outcome.status = std::string(AssetStatusName(e.status));
  f.outcome.milliseconds = elapsed();
  f.entry = std::move(e);
  return f;
}

// Converts the jobs on options.jobs worker threads and hands each result to `record` on the
// calling thread, in the order they finish. Once `record` returns false, or options.cancel
// is set, the workers finish the assets in flight (their files and rows stay consistent) and
// start no new one.
void ConvertOnWorkers(const std::vector<Job>& jobs, const JobContext& context,
                      const std::function<bool(Finished)>& record) {
  std::mutex mu;
  std::condition_variable cv;
  std::deque<Finished> finished;
  std::atomic<size_t> next{0};
  std::atomic<bool> stop{false};
  const int threads =
      std::min<int>(WorkerCount(context.options.jobs), static_cast<int>(std::max<size_t>(1, jobs.size())));
  int workers_left = threads;
  BackgroundWorkers pool(threads, [&] {
    for (size_t i = next++; i < jobs.size() && !stop && !CancelRequested(context.options.cancel); i = next++) {
      Finished f = ConvertJob(jobs[i], context);
      std::lock_guard lock(mu);
      finished.push_back(std::move(f));
      cv.notify_one();
    }
    std::lock_guard lock(mu);
    --workers_left;
    cv.notify_one();
  });
  for (;;) {
    Finished f;
    {
      std::unique_lock lock(mu);
      cv.wait(lock, [&] { return !finished.empty() || workers_left == 0; });
      if (finished.empty()) break;
      f = std::move(finished.front());
      finished.pop_front();
    }
    if (!record(std::move(f))) stop = true;
  }
  pool.Join();
}

// The calling thread's side of a run: each finished job into the catalog and the report.
struct Recorder {
  Catalog& catalog;
  const ConvertOptions& options;
  int64_t total = 0;  // jobs
  ConvertReport report;
  int64_t done = 0;  // results recorded, those of refused writes included
  // The first error that stops the batch; assets finished meanwhile are still recorded.
  Status output_error, catalog_error;

  // False when the batch cannot go on.
  bool Record(Finished f) {
    ++done;
    if (!f.output_error.ok()) {
      if (output_error.ok()) output_error = std::move(f.output_error);
      return false;
    }
    if (f.entry) {
      // The row goes in after the file is in place: a row never points at a missing file.
      if (catalog_error.ok()) catalog_error = catalog.Put(*f.entry);
      Count(*f.entry);
    } else {
      ++report.up_to_date;
    }
    if (options.on_item) options.on_item(f.outcome);
    if (options.progress) options.progress(done, total);
    return catalog_error.ok();
  }

  void Count(const CatalogEntry& entry) {
    report.bytes_in += entry.bytes_in;
    report.bytes_out += entry.bytes_out;
    switch (entry.status) {
      case AssetStatus::kOk: ++report.ok; break;
      case AssetStatus::kOkWithWarnings: ++report.ok_with_warnings; break;
      case AssetStatus::kFailed: ++report.failed; ++report.failure_codes[*entry.error_code]; break;
    }
    for (const json& w : entry.warnings) ++report.warning_codes[w["code"].get<std::string>()];
  }
};

// Runs the jobs on options.jobs threads; the calling thread owns the catalog.
Result<ConvertReport> RunJobs(std::vector<Job> jobs, const fs::path& out, const ConvertOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) return IoError(fmt::format("{}: cannot create the output directory: {}", out.string(), ec.message()));
  RemoveStaleTempsUnder(out);
  const fs::path catalog_path = out / "catalog.sqlite";
  SOLID_ASSIGN_OR_RETURN(Catalog catalog, Catalog::OpenForWriting(catalog_path));
  SOLID_ASSIGN_OR_RETURN(auto existing, RowsByKey(catalog));
  if (options.limit >= 0 && static_cast<int64_t>(jobs.size()) > options.limit) jobs.resize(static_cast<size_t>(options.limit));

  const JobContext context{out, options, std::move(existing), Xxh64(OptionsIdentity(options).dump()),
                           std::string(ConverterVersion())};
  Recorder recorder{catalog, options, static_cast<int64_t>(jobs.size())};
  ConvertOnWorkers(jobs, context, [&](Finished f) { return recorder.Record(std::move(f)); });
  // Closed on every path: its checkpoint is what removes the -wal and -shm files.
  const Status closed = catalog.Close();
  SOLID_RETURN_IF_ERROR(recorder.output_error);
  SOLID_RETURN_IF_ERROR(recorder.catalog_error);
  SOLID_RETURN_IF_ERROR(closed);
  ConvertReport& report = recorder.report;
  report.catalog = catalog_path;
  report.assets = static_cast<int64_t>(jobs.size());
  report.not_started = report.assets - recorder.done;
  report.cancelled = report.not_started > 0;
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace

namespace {

// True when every character of s is in `allowed` and its length is in [min, max].
bool AllOf(std::string_view s, std::string_view allowed, size_t min, size_t max) {
  return s.size() >= min && s.size() <= max && s.find_first_not_of(allowed) == std::string_view::npos;
}

constexpr std::string_view kDigits = "0123456789", kHexDigits = "0123456789abcdef";

bool IsSynsetName(std::string_view name) { return AllOf(name, kDigits, 8, 8); }

// ShapeNet ids: 28-32 lower-case hex digits, or "u" and a UUID (a few v2 models).
bool IsShapeNetModelId(std::string_view id) {
  if (AllOf(id, kHexDigits, 28, 32)) return true;
  if (id.size() != 37 || id[0] != 'u') return false;
  for (size_t i = 1; i < id.size(); ++i) {
    const bool dash = i == 9 || i == 14 || i == 19 || i == 24;
    if (dash ? id[i] != '-' : kHexDigits.find(id[i]) == std::string_view::npos) return false;
  }
  return true;
}

// Objaverse's `glbs/000-NNN/<uid>.glb`: the uid, or nothing for any other path.
std::optional<std::string> ObjaverseKey(std::string_view relative) {
  constexpr std::string_view kPrefix = "glbs/", kSuffix = ".glb";
  if (!relative.starts_with(kPrefix) || !relative.ends_with(kSuffix)) return std::nullopt;
  const std::string_view inner = relative.substr(kPrefix.size(), relative.size() - kPrefix.size() - kSuffix.size());
  if (inner.size() < 9 || !AllOf(inner.substr(0, 3), kDigits, 3, 3) || inner[3] != '-' ||
      !AllOf(inner.substr(4, 3), kDigits, 3, 3) || inner[7] != '/') {
    return std::nullopt;
  }
  const std::string_view uid = inner.substr(8);
  if (uid.find('/') != std::string_view::npos) return std::nullopt;
  return std::string(uid);
}

Result<ConvertReport> ConvertShapeNet(const fs::path& root, const fs::path& out, const ConvertOptions& options) {
  std::error_code ec;
  if (!fs::is_directory(root, ec)) return NotFoundError(root.string() + ": not a directory");
  std::vector<fs::path> synset_dirs;
  for (const fs::path& p : SortedEntries(root, true)) {
    std::string name = p.filename().string();
    if (!IsSynsetName(name)) continue;
    if (!options.synsets.empty() &&
        std::find(options.synsets.begin(), options.synsets.end(), name) == options.synsets.end()) {
      continue;
    }
    synset_dirs.push_back(p);
  }
  if (synset_dirs.empty()) {
    return NotFoundError(fmt::format("{}: no synset folders (8 digits) found{}", root.string(),
                                     options.synsets.empty() ? "" : " among the requested synsets"));
  }
  int version = options.shapenet_version.value_or(0);
  if (version == 0) {
    version = 1;
    for (const fs::path& s : synset_dirs) {
      for (const fs::path& m : SortedEntries(s, true)) {
        if (fs::is_regular_file(m / "models" / "model_normalized.obj", ec)) {
          version = 2;
          break;
        }
      }
      if (version == 2) break;
    }
  }
  bool have_taxonomy = false;
  std::map<std::string, std::string> taxonomy = ReadTaxonomy(root, &have_taxonomy);
  std::vector<Job> jobs;
  for (const fs::path& synset_dir : synset_dirs) {
    std::string synset = synset_dir.filename().string();
    json synset_info = {{"synset", synset}};
    if (auto it = taxonomy.find(synset); it != taxonomy.end()) synset_info["synset_name"] = it->second;
    for (const fs::path& model_dir : SortedEntries(synset_dir, true)) {
      std::string model = model_dir.filename().string();
      Job job;
      job.key = synset + "/" + model;
      job.kind = "model";
      job.source = version == 1 ? "shapenet_v1" : "shapenet_v2";
      job.output = fs::path("models") / synset / (model + ".glb");
      job.input_root = root;
      if (!SafePathComponent(model)) {
        job.discovery_failure = AssetFailure{"unsafe_name", fmt::format("{}: '{}' is not a safe file name",
                                                                        synset_dir.string(), model)};
        jobs.push_back(std::move(job));
        continue;
      }
      job.inputs = ModelInputFiles(model_dir);
      if (!have_taxonomy) {
        job.discovery_warnings.push_back({"missing_taxonomy", root.string() + "/taxonomy.json: not found"});
      }
      if (!IsShapeNetModelId(model)) {
        job.discovery_warnings.push_back({"unexpected_model_id", fmt::format("{}: '{}' is not a ShapeNet model id",
                                                                             synset_dir.string(), model)});
      }
      fs::path obj = version == 1 ? model_dir / "model.obj" : model_dir / "models" / "model_normalized.obj";
      std::string key = job.key;
      job.convert = [model_dir, obj, key, version, synset_info] {
        return ConvertShapeNetModel(model_dir, obj, key, version, synset_info);
      };
      jobs.push_back(std::move(job));
    }
  }
  return RunJobs(std::move(jobs), out, options);
}

}  // namespace

namespace {

// texture_folders: the library's non-empty folders when the texture-library step runs, else null.
std::variant<Converted, AssetFailure> ConvertSceneNetRoom(const fs::path& root, const fs::path& obj_path,
                                                          const std::string& key, bool keep_all,
                                                          const std::set<std::string>* texture_folders) {
  Converted c;
  std::variant<LoadedObj, AssetFailure> loaded_or = LoadObj(obj_path, &c.warnings);
  if (auto* failure = std::get_if<AssetFailure>(&loaded_or)) return *failure;
  LoadedObj& loaded = std::get<LoadedObj>(loaded_or);
  const ObjData* obj = &loaded.obj;
  // One node per OBJ object: `o`, else `g`.
  std::vector<std::string> names;
  for (const ObjFaceBlock& b : obj->blocks) {
    std::string name = !b.object.empty() ? b.object : b.group;
    if (names.empty() || names.back() != name) names.push_back(name);
  }
  std::set<std::string> kept, dropped;
  for (const std::string& n : names) (keep_all || SceneNetStructure(n) != Structure::kNone ? kept : dropped).insert(n);
  if (!keep_all && kept.empty()) {
    return AssetFailure{"no_structure", fmt::format("{}: no wall, floor or ceiling object among {} objects",
                                                    obj_path.string(), names.size())};
  }
  ObjAssetOptions& options = loaded.options;
  options.grouping = NodeGrouping::kPerObject;
  if (!keep_all) options.keep_object = [](const std::string& n) { return SceneNetStructure(n) != Structure::kNone; };
  options.textures = TextureMode::kValidateOnly;
  options.confine_root = root;
  Result<ObjAsset> built = BuildAssetFromObj(*obj, loaded.mtl ? &*loaded.mtl : nullptr, options);
  if (!built.ok()) {
    AssetFailure f = FailureFromStatus(built.status(), "no_structure");
    // Structure objects that exist but hold no triangle (only `l` records) leave nothing to render.
    if (f.code == "empty_geometry") f.code = "no_structure";
    return f;
  }
  c.asset = std::move(built->asset);
  c.warnings.insert(c.warnings.end(), built->warnings.begin(), built->warnings.end());
  c.counts = CountsJson(built->counts, *obj);
  Bounds b = ComputeBounds(c.asset);
  double extent = 0;
  for (int k = 0; k < 3; ++k) extent = std::max(extent, b.max[k] - b.min[k]);
  if (extent > 100) {
    return AssetFailure{"suspect_units", fmt::format("{}: the room is {:.0f} units across; SceneNet rooms are metres "
                                                     "(at most about 17 m): millimetres?",
                                                     obj_path.string(), extent)};
  }
  double floor_area = 0;
  json kept_nodes = json::array();
  for (Node& node : c.asset.nodes) {
    Structure s = SceneNetStructure(node.name);
    node.extras["category"] = SceneNetCategory(node.name);
    node.extras["structure"] = StructureName(s);
    kept_nodes.push_back(node.name);
    if (s != Structure::kFloor) continue;
    for (const Primitive& p : node.primitives) {
      for (size_t i = 0; i + 2 < p.indices.size(); i += 3) {
        const float* a = &p.positions[3 * size_t{p.indices[i]}];
        const float* q = &p.positions[3 * size_t{p.indices[i + 1]}];
        const float* r = &p.positions[3 * size_t{p.indices[i + 2]}];
        // Area projected on the horizontal (x, z) plane: glTF is +Y up.
        floor_area += 0.5 * std::fabs((q[0] - a[0]) * (r[2] - a[2]) - (q[2] - a[2]) * (r[0] - a[0]));
      }
    }
  }
  c.extras = {{"kept_objects", kept_nodes},
              {"dropped_objects", json(std::vector<std::string>(dropped.begin(), dropped.end()))},
              {"floor_area_m2", floor_area},
              {"height_m", b.empty ? 0.0 : b.max[1] - b.min[1]}};
  if (texture_folders != nullptr) {
    json unmatched = json::array();
    for (const Material& m : c.asset.materials) {
      std::string folder = SceneNetTextureFolder(m.name);
      if (!texture_folders->count(folder)) unmatched.push_back({{"material", m.name}, {"folder", folder}});
    }
    c.extras["unmatched_texture_folders"] = std::move(unmatched);
  }
  c.asset.extras["source"] = "scenenet";
  c.asset.extras["scene"] = key;
  return c;
}

}  // namespace

namespace {

Result<ConvertReport> ConvertSceneNet(const fs::path& root, const fs::path& out, const ConvertOptions& options) {
  std::error_code ec;
  if (!fs::is_directory(root, ec)) return NotFoundError(root.string() + ": not a directory");
  std::vector<fs::path> objs;
  for (fs::recursive_directory_iterator it(root, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_directory(ec) && it->path().filename() == "texture_library") {
      it.disable_recursion_pending();
      continue;
    }
    if (it->is_regular_file(ec) && it->path().extension() == ".obj") objs.push_back(it->path());
  }
  if (objs.empty()) return NotFoundError(root.string() + ": no .obj files found");
  std::sort(objs.begin(), objs.end(), [](const fs::path& a, const fs::path& b) { return a.native() < b.native(); });
  std::optional<TextureLibraryReport> textures;
  std::shared_ptr<const std::set<std::string>> texture_folders;
  if (options.texture_library) {
    SOLID_ASSIGN_OR_RETURN(textures, CopySceneNetTextureLibrary(root / "texture_library", out / "textures"));
    texture_folders = std::make_shared<const std::set<std::string>>(textures->categories.begin(),
                                                                    textures->categories.end());
  }
  std::vector<Job> jobs;
  for (const fs::path& obj : objs) {
    Job job;
    job.key = fs::relative(obj, root).replace_extension().generic_string();
    job.kind = "room";
    job.source = "scenenet";
    job.output = fs::path("rooms") / (job.key + ".glb");
    job.input_root = root;
    job.inputs = {obj};
    fs::path mtl = fs::path(obj).replace_extension(".mtl");
    if (fs::is_regular_file(mtl, ec)) job.inputs.push_back(mtl);
    if (textures) {
      // Which materials are unmatched depends on the library too: a new folder reconverts.
      job.generator_identity = "texture folders:";
      for (const std::string& f : textures->categories) job.generator_identity += " " + f;
    }
    std::string key = job.key;
    bool keep_all = options.keep_all_room_objects;
    job.convert = [root, obj, key, keep_all, texture_folders] {
      return ConvertSceneNetRoom(root, obj, key, keep_all, texture_folders.get());
    };
    jobs.push_back(std::move(job));
  }
  std::vector<std::string> keys;
  for (const Job& job : jobs) keys.push_back(job.key);
  if (options.limit >= 0 && static_cast<int64_t>(keys.size()) > options.limit) keys.resize(static_cast<size_t>(options.limit));
  SOLID_ASSIGN_OR_RETURN(ConvertReport report, RunJobs(std::move(jobs), out, options));
  if (textures) {
    // From the catalog, so that rooms skipped as up to date are reported too.
    SOLID_ASSIGN_OR_RETURN(Catalog catalog, Catalog::OpenReadOnly(report.catalog));
    for (const std::string& key : keys) {
      SOLID_ASSIGN_OR_RETURN(std::optional<CatalogEntry> row, catalog.Find(key));
      if (!row || !row->extras.is_object() || !row->extras.contains("unmatched_texture_folders")) continue;
      for (const json& u : row->extras["unmatched_texture_folders"]) {
        textures->unmatched[u.value("material", "")] = u.value("folder", "");
      }
    }
    report.textures = std::move(textures);
  }
  return report;
}

}  // namespace

Result<TextureLibraryReport> CopySceneNetTextureLibrary(const fs::path& library, const fs::path& textures) {
  std::error_code ec;
  if (!fs::is_directory(library, ec)) return NotFoundError(library.string() + ": no texture library folder");
  auto visible = [](const fs::path& p) {
    std::string name = p.filename().string();
    return !name.empty() && name[0] != '.' && !files::IsTempPath(p);
  };
  auto regular_files = [&](const fs::path& dir) {
    std::vector<fs::path> out;
    for (const fs::path& p : SortedEntries(dir, false)) {
      if (visible(p) && fs::is_regular_file(p, ec)) out.push_back(p);
    }
    return out;
  };
  TextureLibraryReport report;
  for (const fs::path& dir : SortedEntries(library, true)) {
    if (!visible(dir)) continue;
    std::vector<fs::path> images = regular_files(dir);
    if (images.empty()) continue;
    report.categories.push_back(dir.filename().string());
    const fs::path target_dir = textures / dir.filename();
    fs::create_directories(target_dir, ec);
    if (ec) return IoError(fmt::format("{}: cannot create: {}", target_dir.string(), ec.message()));
    for (const fs::path& source : images) {
      const fs::path target = target_dir / source.filename();
      SOLID_ASSIGN_OR_RETURN(files::FileDigest want, files::DigestFile(source));
      if (fs::is_regular_file(target, ec)) {
        Result<files::FileDigest> have = files::DigestFile(target);
        if (have.ok() && have->bytes == want.bytes && have->xxh64 == want.xxh64) {
          ++report.files_up_to_date;
          continue;
        }
      }
      SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, files::ReadFile(source, kMaxInputFileBytes));
      SOLID_RETURN_IF_ERROR(files::WriteFileAtomically(target, bytes));
      ++report.files_copied;
    }
  }
  const fs::path unknown = textures / "unknown";
  if (regular_files(unknown).empty()) {
    constexpr uint32_t kSide = 64;
    constexpr uint8_t kGrey = 163;  // 0.64 * 255, Blender's default Kd
    Image8 grey{kSide, kSide, 3, std::vector<uint8_t>(size_t{kSide} * kSide * 3, kGrey)};
    SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> png, EncodeImage(grey, ImageFormat::kPng));
    fs::create_directories(unknown, ec);
    if (ec) return IoError(fmt::format("{}: cannot create: {}", unknown.string(), ec.message()));
    SOLID_RETURN_IF_ERROR(files::WriteFileAtomically(unknown / "placeholder_grey.png", png));
    report.unknown_created = true;
  }
  return report;
}

namespace {

Result<ConvertReport> ConvertProcedural(const ProceduralSet& set, const fs::path& out, const ConvertOptions& options) {
  if (set.models < 0) return OptionError("procedural.models", "must not be negative");
  if (set.rooms < 0) return OptionError("procedural.rooms", "must not be negative");
  SOLID_RETURN_IF_ERROR(CheckProceduralShapeOptions(set.shapes).WithContext("procedural shapes"));
  std::vector<Job> jobs;
  auto add = [&](bool room, int i) {
    Job job;
    std::string name = fmt::format("{}-{:06d}", room ? "room" : "shape", i);
    job.key = "procedural/" + name;
    job.kind = room ? "room" : "model";
    job.source = "procedural";
    job.output = fs::path(room ? "rooms" : "models") / "procedural" / (name + ".glb");
    job.input_root = out;
    job.generator_identity = fmt::format("procedural {} seed {} index {}", room ? "room" : "shape", Hex64(set.seed), i);
    const ProceduralShapeOptions shapes = set.shapes;
    if (!room) {
      job.generator_identity += fmt::format(" triangles {}-{} texture {} family {}", shapes.min_triangles,
                                            shapes.max_triangles, shapes.texture_size,
                                            ShapeFamilyName(FamilyOfIndex(i, shapes)));
    }
    std::string key = job.key;
    uint64_t seed = set.seed;
    job.convert = [room, i, key, seed, shapes]() -> std::variant<Converted, AssetFailure> {
      Result<Asset> asset = room ? MakeProceduralRoom(seed, i, key) : MakeProceduralShape(seed, i, key, shapes);
      if (!asset.ok()) return AssetFailure{"generator_error", asset.status().message()};
      Converted c;
      c.asset = std::move(asset).value();
      c.extras = c.asset.extras;
      return c;
    };
    jobs.push_back(std::move(job));
  };
  for (int i = 0; i < set.models; ++i) add(false, i);
  for (int i = 0; i < set.rooms; ++i) add(true, i);
  return RunJobs(std::move(jobs), out, options);
}

// ---------------------------------------------------------------------------------------
// glTF/GLB corpora and folders of plain OBJ models (Objaverse, ABO, GSO, YCB): discovery
// by layout, then one model per job through RunJobs, normalised as ShapeNet v2 models are.

constexpr std::string_view kNormalisedFrame =
    "+Y up; centred at the vertex mean, scaled to a bounding-box diagonal of 1 (as ShapeNetCore.v2)";

// Every path component safe as a file name of the output tree.
bool SafeKey(const std::string& key) {
  if (key.empty()) return false;
  for (const auto& part : fs::path(key)) {
    if (!SafePathComponent(part.string())) return false;
  }
  return true;
}

// The external files a .gltf names (buffers and images that are not data URIs and stay in
// its folder): inputs of the job, so that a changed .bin reconverts. Unreadable JSON adds
// nothing here; the conversion reports it.
std::vector<fs::path> GltfExternalInputs(const fs::path& gltf) {
  std::vector<fs::path> out;
  if (gltf.extension() != ".gltf") return out;
  Result<std::vector<uint8_t>> bytes = files::ReadFile(gltf, kMaxInputFileBytes);
  if (!bytes.ok()) return out;
  Result<json> j = solid::json::ParseJson(std::string_view(reinterpret_cast<const char*>(bytes->data()), bytes->size()),
                                   gltf.string());
  if (!j.ok() || !j->is_object()) return out;
  std::error_code ec;
  for (const char* member : {"buffers", "images"}) {
    if (!j->contains(member) || !(*j)[member].is_array()) continue;
    for (const json& e : (*j)[member]) {
      if (!e.is_object() || !e.contains("uri") || !e["uri"].is_string()) continue;
      const std::string uri = e["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) continue;
      Result<fs::path> p = files::ResolveInside(gltf.parent_path(), uri);
      if (p.ok() && fs::is_regular_file(*p, ec)) out.push_back(*p);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::variant<Converted, AssetFailure> ConvertGltfModel(const fs::path& file, const std::string& key) {
  Result<std::vector<uint8_t>> bytes = files::ReadFile(file, kMaxInputFileBytes);
  if (!bytes.ok()) return FailureFromStatus(bytes.status(), "read_error");
  GltfReadResult read = ReadGltfModel(*bytes, file, file.parent_path(), key);
  if (!read.ok) return AssetFailure{read.failure.code, read.failure.message};
  Converted c;
  c.asset = std::move(read.model.asset);
  c.warnings = std::move(read.model.warnings);
  c.counts = std::move(read.model.counts);
  const std::array<double, 3> extent = NormalizeAsShapeNetV2(&c.asset);
  c.asset.extras["source_frame"] = fmt::format("gltf: metres, {}", kNormalisedFrame);
  c.asset.extras["source_extent_m"] = extent;
  c.extras = {{"source_extent_m", extent}};
  return c;
}

// A +Z-up frame to glTF's +Y up: y' = z, z' = -y (a quarter turn about x).
void RotateZUpToYUp(Asset* asset) {
  RotateAsset(asset, [](float&, float& y, float& z) { std::tie(y, z) = std::pair{z, -y}; });
}

std::variant<Converted, AssetFailure> ConvertObjModel(const fs::path& obj_path, const fs::path& confine_root,
                                                      const std::string& key, bool metres, bool z_up) {
  std::error_code ec;
  if (!fs::is_regular_file(obj_path, ec)) {
    return AssetFailure{"missing_obj", fmt::format("{}: not found", obj_path.string())};
  }
  Converted c;
  std::variant<LoadedObj, AssetFailure> loaded_or = LoadObj(obj_path, &c.warnings);
  if (auto* failure = std::get_if<AssetFailure>(&loaded_or)) return *failure;
  LoadedObj& loaded = std::get<LoadedObj>(loaded_or);
  loaded.options.grouping = NodeGrouping::kSingleNode;
  loaded.options.node_name = key;
  loaded.options.textures = TextureMode::kEmbed;
  loaded.options.confine_root = confine_root;
  Result<ObjAsset> built = BuildAssetFromObj(loaded.obj, loaded.mtl ? &*loaded.mtl : nullptr, loaded.options);
  if (!built.ok()) return FailureFromStatus(built.status(), "empty_geometry");
  c.asset = std::move(built->asset);
  c.warnings.insert(c.warnings.end(), built->warnings.begin(), built->warnings.end());
  c.counts = CountsJson(built->counts, loaded.obj);
  if (z_up) RotateZUpToYUp(&c.asset);
  // GSO and YCB scans are in metres; a flat folder's OBJ units are unknown. The extent is
  // along the asset's axes (after any turn to +Y up).
  const std::array<double, 3> extent = NormalizeAsShapeNetV2(&c.asset);
  const char* extent_key = metres ? "source_extent_m" : "source_extent";
  c.asset.extras["source_frame"] =
      fmt::format("obj{}{}, {}", metres ? ": metres" : "", z_up ? ", +Z up turned to +Y up (y' = z, z' = -y)" : "",
                  kNormalisedFrame);
  c.asset.extras[extent_key] = extent;
  c.extras = {{extent_key, extent}};
  return c;
}

// Jobs in key order; a key met twice is a failed row for every file after the first.
void AddModelJob(std::vector<Job>* jobs, std::set<std::string>* keys, Job job, const fs::path& shown) {
  job.kind = "model";
  job.output = fs::path("models") / (job.key + ".glb");
  if (!SafeKey(job.key)) {
    job.discovery_failure = AssetFailure{"unsafe_name", fmt::format("{}: '{}' is not a safe key", shown.string(), job.key)};
  } else if (!keys->insert(job.key).second) {
    job.discovery_failure = AssetFailure{"duplicate_key", fmt::format("{}: key '{}' is taken by an earlier file",
                                                                      shown.string(), job.key)};
    job.key += "#" + fs::path(shown).filename().string();
  }
  jobs->push_back(std::move(job));
}

std::vector<fs::path> FilesUnder(const fs::path& root, const std::function<bool(const fs::path&)>& want) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(root, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_regular_file(ec) && !files::IsTempPath(it->path()) && want(it->path())) out.push_back(it->path());
  }
  std::sort(out.begin(), out.end(), [](const fs::path& a, const fs::path& b) { return a.native() < b.native(); });
  return out;
}

Result<ConvertReport> ConvertGltf(const fs::path& root, const fs::path& out, GltfLayout layout,
                                  const ConvertOptions& options) {
  std::error_code ec;
  if (!fs::is_directory(root, ec)) return NotFoundError(root.string() + ": not a directory");
  std::vector<Job> jobs;
  std::set<std::string> keys;
  for (const fs::path& file : FilesUnder(root, [](const fs::path& p) {
         return p.extension() == ".glb" || p.extension() == ".gltf";
       })) {
    const std::string relative = fs::relative(file, root).generic_string();
    Job job;
    if (layout == GltfLayout::kObjaverse) {
      std::optional<std::string> key = ObjaverseKey(relative);
      if (!key) continue;
      job.key = std::move(*key);
    } else {
      job.key = fs::path(relative).replace_extension().generic_string();
    }
    job.source = "gltf";
    job.input_root = root;
    job.inputs = {file};
    for (const fs::path& p : GltfExternalInputs(file)) job.inputs.push_back(p);
    std::sort(job.inputs.begin(), job.inputs.end());
    const std::string key = job.key;
    job.convert = [file, key] { return ConvertGltfModel(file, key); };
    AddModelJob(&jobs, &keys, std::move(job), file);
  }
  if (jobs.empty()) {
    return NotFoundError(fmt::format("{}: no {} found", root.string(),
                                     layout == GltfLayout::kObjaverse ? "glbs/NNN-NNN/<uid>.glb" : ".glb or .gltf files"));
  }
  return RunJobs(std::move(jobs), out, options);
}

Result<ConvertReport> ConvertObjFolder(const fs::path& root, const fs::path& out, ObjLayout layout,
                                       const ConvertOptions& options) {
  std::error_code ec;
  if (!fs::is_directory(root, ec)) return NotFoundError(root.string() + ": not a directory");
  const bool z_up = ObjZUp(options);
  std::vector<Job> jobs;
  std::set<std::string> keys;
  if (layout == ObjLayout::kFlat) {
    for (const fs::path& obj : FilesUnder(root, [](const fs::path& p) { return p.extension() == ".obj"; })) {
      Job job;
      job.key = fs::relative(obj, root).replace_extension().generic_string();
      job.source = "obj";
      job.input_root = root;
      job.inputs = {obj};
      if (fs::path mtl = fs::path(obj).replace_extension(".mtl"); fs::is_regular_file(mtl, ec)) job.inputs.push_back(mtl);
      const std::string key = job.key;
      const fs::path dir = obj.parent_path();
      job.convert = [obj, dir, key, z_up] { return ConvertObjModel(obj, dir, key, /*metres=*/false, z_up); };
      AddModelJob(&jobs, &keys, std::move(job), obj);
    }
  } else {
    // One folder per model: GSO <name>/meshes/model.obj (texture in <name>/materials/),
    // YCB <name>/google_16k/textured.obj. A folder without its OBJ is a missing_obj row.
    const fs::path mesh = layout == ObjLayout::kGso ? fs::path("meshes") / "model.obj"
                                                    : fs::path("google_16k") / "textured.obj";
    for (const fs::path& model_dir : SortedEntries(root, true)) {
      const std::string name = model_dir.filename().string();
      if (name.empty() || name[0] == '.') continue;
      Job job;
      job.key = name;
      job.source = "obj";
      job.input_root = root;
      job.inputs = ModelInputFiles(model_dir);
      const fs::path obj = model_dir / mesh;
      const std::string key = job.key;
      job.convert = [obj, model_dir, key, z_up] { return ConvertObjModel(obj, model_dir, key, /*metres=*/true, z_up); };
      AddModelJob(&jobs, &keys, std::move(job), model_dir);
    }
  }
  if (jobs.empty()) return NotFoundError(root.string() + ": no OBJ models found");
  return RunJobs(std::move(jobs), out, options);
}

}  // namespace

Result<ConvertReport> Convert(const ConvertOptions& options) {
  if (options.out.empty()) return OptionError("out", "give the assets directory to write");
  switch (options.source) {
    case Source::kShapeNet:
      if (options.root.empty()) return OptionError("root", "give the ShapeNetCore tree to read");
      return ConvertShapeNet(options.root, options.out, options);
    case Source::kSceneNet:
      if (options.root.empty()) return OptionError("root", "give the SceneNet tree to read");
      return ConvertSceneNet(options.root, options.out, options);
    case Source::kProcedural:
      return ConvertProcedural(options.procedural, options.out, options);
    case Source::kGltf:
      if (options.root.empty()) return OptionError("root", "give the folder of glTF/GLB files to read");
      return ConvertGltf(options.root, options.out, options.gltf_layout, options);
    case Source::kObj:
      if (options.root.empty()) return OptionError("root", "give the folder of OBJ models to read");
      return ConvertObjFolder(options.root, options.out, options.obj_layout, options);
  }
  return OptionError("source", "not a source kind");
}

}  // namespace solid::convert
