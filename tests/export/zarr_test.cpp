// ExportZarr read back by a decoder written here from the zarr v2 spec and numcodecs'
// VLenArray encoding (solid-method.md 5.1): every chunk decodes to the shard's boxes,
// masks and statistics; query views cycle into their 8 slots; what is refused is refused
// with nothing left behind. python/tests/test_zarr.py reads the same store with zarr itself.
#include "solid/export/zarr.h"

#include <blosc.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <fmt/format.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>

#include "fixtures/layered_dataset.h"
#include "fixtures/run_command.h"
#include "formats/test_util.h"
#include "solid/formats/dataset.h"
#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"
#include "solid/formats/shard.h"

namespace solid::exporters {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<uint8_t>;
using solid::testing::TempDir;

nlohmann::json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

Bytes ReadBytes(const fs::path& path) {
  Result<Bytes> bytes = files::ReadFile(path, uint64_t{1} << 32);
  EXPECT_TRUE(bytes.ok()) << bytes.status().ToString();
  return bytes.ok() ? *bytes : Bytes{};
}

uint32_t Le32(const uint8_t* p) { return p[0] | p[1] << 8 | p[2] << 16 | uint32_t{p[3]} << 24; }

// One chunk as its .zarray says: Blosc-decompressed when it has a compressor, then (for "|O")
// the VLenArray items.
Bytes RawChunk(const fs::path& array, const std::string& key) {
  const nlohmann::json meta = ReadJson(array / ".zarray");
  Bytes stored = ReadBytes(array / key);
  if (meta["compressor"].is_null()) return stored;
  EXPECT_EQ(meta["compressor"], nlohmann::json({{"id", "blosc"}, {"cname", "lz4"}, {"clevel", 5}, {"shuffle", 1},
                                                {"blocksize", 0}}));
  size_t raw_size = 0, compressed = 0, block = 0;
  blosc_cbuffer_sizes(stored.data(), &raw_size, &compressed, &block);
  EXPECT_EQ(compressed, stored.size()) << array / key;
  Bytes raw(raw_size);
  EXPECT_EQ(blosc_decompress_ctx(stored.data(), raw.data(), raw.size(), 1), static_cast<int>(raw_size)) << array / key;
  return raw;
}

std::vector<Bytes> Items(const fs::path& array, const std::string& key) {
  const Bytes raw = RawChunk(array, key);
  std::vector<Bytes> items;
  if (raw.size() < 4) {
    ADD_FAILURE() << array / key << ": " << raw.size() << " bytes";
    return items;
  }
  const uint32_t count = Le32(raw.data());
  size_t at = 4;
  for (uint32_t i = 0; i < count; ++i) {
    if (at + 4 > raw.size()) break;
    const uint32_t n = Le32(raw.data() + at);
    at += 4;
    if (at + n > raw.size()) break;
    items.emplace_back(raw.begin() + static_cast<std::ptrdiff_t>(at), raw.begin() + static_cast<std::ptrdiff_t>(at + n));
    at += n;
  }
  EXPECT_EQ(items.size(), count) << array / key << ": items overrun the chunk";
  EXPECT_EQ(at, raw.size()) << array / key << ": bytes after the last item";
  return items;
}

// Every row of a per-image array: its chunks in order, each of `chunk` items, past row n empty.
std::vector<Bytes> Rows(const fs::path& array) {
  const nlohmann::json meta = ReadJson(array / ".zarray");
  const int64_t n = meta["shape"][0], chunk = meta["chunks"][0];
  std::vector<Bytes> rows;
  for (int64_t c = 0; c * chunk < n; ++c) {
    std::vector<Bytes> items = Items(array, std::to_string(c));
    EXPECT_EQ(static_cast<int64_t>(items.size()), chunk) << "chunk " << c << " of " << array << " is not whole";
    for (int64_t k = 0; k < static_cast<int64_t>(items.size()); ++k) {
      if (c * chunk + k < n) {
        rows.push_back(std::move(items[k]));
      } else {
        EXPECT_TRUE(items[k].empty()) << array << " row " << c * chunk + k << " past the shape";
      }
    }
  }
  EXPECT_FALSE(fs::exists(array / std::to_string((n + chunk - 1) / chunk))) << "a chunk past the shape";
  return rows;
}

template <typename T>
std::vector<T> As(const Bytes& b) {
  std::vector<T> out(b.size() / sizeof(T));
  std::memcpy(out.data(), b.data(), out.size() * sizeof(T));
  return out;
}

using Mat3 = std::array<std::array<double, 3>, 3>;

Mat3 Mul(const Mat3& a, const Mat3& b) {
  Mat3 m{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m[r][c] = a[r][0] * b[0][c] + a[r][1] * b[1][c] + a[r][2] * b[2][c];
  }
  return m;
}

// R = Rz(z) Ry(y) Rx(x): Blender's Euler XYZ.
Mat3 EulerXyz(double x, double y, double z) {
  const Mat3 rx = {{{1, 0, 0}, {0, std::cos(x), -std::sin(x)}, {0, std::sin(x), std::cos(x)}}};
  const Mat3 ry = {{{std::cos(y), 0, std::sin(y)}, {0, 1, 0}, {-std::sin(y), 0, std::cos(y)}}};
  const Mat3 rz = {{{std::cos(z), -std::sin(z), 0}, {std::sin(z), std::cos(z), 0}, {0, 0, 1}}};
  return Mul(rz, Mul(ry, rx));
}

// The camera-relative rotation the test gives instance `ordinal` of image `id`.
std::array<double, 3> PoseAngles(int64_t id, int32_t ordinal) {
  return {0.3 + 0.1 * ordinal, -0.4 + 0.02 * static_cast<double>(id), 1.1 - 0.05 * static_cast<double>(id)};
}

std::string ModelKey(int m) { return fmt::format("fixture/model-{:02d}", m); }

// Distinct bytes per (model, view): a tiny PNG whose pixels spell both.
Bytes ViewPng(int model, int view) {
  Image8 im{4, 3, 3, Bytes(4 * 3 * 3, 0)};
  im.pixels[0] = static_cast<uint8_t>(model);
  im.pixels[1] = static_cast<uint8_t>(view);
  Result<Bytes> png = EncodeImage(im, ImageFormat::kPng);
  EXPECT_TRUE(png.ok());
  return png.ok() ? *png : Bytes{};
}

struct Fixture {
  fixtures::LayeredDatasetOptions layered;
  std::vector<int> views;  // per model; 0: a failed model
  bool queries = true;
};

// The layered fixture's images, each instance posed at PoseAngles relative to the camera with
// a non-uniform scale, and one query shard where model m has views[m] views.
Status WriteDataset(const fs::path& root, const Fixture& f) {
  const fixtures::LayeredDatasetOptions& o = f.layered;
  const Manifest manifest = fixtures::LayeredManifest(o);
  SOLID_RETURN_IF_ERROR(CreateDataset(root, manifest));
  for (int64_t k = 0; k < manifest.ShardCount(); ++k) {
    SOLID_ASSIGN_OR_RETURN(ShardWriter writer, ShardWriter::Create(DatasetPaths(root).shard(k)));
    SOLID_RETURN_IF_ERROR(WriteProvenance(writer, manifest, k));
    for (int64_t id = k * o.shard_size; id < std::min(o.images, (k + 1) * o.shard_size); ++id) {
      SOLID_ASSIGN_OR_RETURN(fixtures::LayeredImage image, fixtures::MakeLayeredImage(o, id));
      SOLID_RETURN_IF_ERROR(writer.AddImage(image.image));
      const Affine3x4& cam = image.image.camera.world_from_camera;
      const Mat3 camera = {{{cam[0], cam[1], cam[2]}, {cam[4], cam[5], cam[6]}, {cam[8], cam[9], cam[10]}}};
      for (InstanceRecord& in : image.instances) {
        const auto [x, y, z] = PoseAngles(id, in.ordinal);
        const Mat3 r = Mul(camera, Mul(EulerXyz(x, y, z), {{{2, 0, 0}, {0, 0.5, 0}, {0, 0, 3}}}));
        in.world_from_object = {r[0][0], r[0][1], r[0][2], 1, r[1][0], r[1][1], r[1][2], 2, r[2][0], r[2][1], r[2][2], 3};
        SOLID_RETURN_IF_ERROR(writer.AddInstance(in));
      }
    }
    SOLID_RETURN_IF_ERROR(writer.Commit());
  }
  if (!f.queries) return Status::Ok();
  SOLID_ASSIGN_OR_RETURN(QueryShardWriter writer, QueryShardWriter::Create(DatasetPaths(root).query_shard(0)));
  SOLID_RETURN_IF_ERROR(WriteProvenance(writer, manifest, 0));
  for (int m = 0; m < o.models; ++m) {
    const int n = f.views.at(static_cast<size_t>(m));
    SOLID_RETURN_IF_ERROR(writer.AddModel(
        {ModelKey(m), n, n < 8 ? std::optional<std::string>(fmt::format("{} of 8 views failed", 8 - n)) : std::nullopt}));
    for (int v = 0; v < n; ++v) {
      QueryViewRecord view;
      view.model_key = ModelKey(m);
      view.view_index = v;
      view.width = 4;
      view.height = 3;
      view.image = ViewPng(m, v);
      view.box = {0, 0, 4, 3};
      SOLID_RETURN_IF_ERROR(writer.AddView(view));
    }
  }
  return writer.Commit();
}

Fixture Default() {
  Fixture f;
  f.layered.images = 10;
  f.layered.shard_size = 4;
  f.layered.width = 40;
  f.layered.height = 30;
  f.layered.max_objects = 5;
  f.layered.models = 9;
  f.views = {8, 1, 2, 3, 4, 5, 6, 7, 8};
  return f;
}

struct Exported {
  TempDir dir;
  fs::path dataset = dir.path() / "dataset", out = dir.path() / "store";
  Result<ZarrExportReport> report = InternalError("not run");

  explicit Exported(const Fixture& f, ZarrExportOptions options = {}) {
    EXPECT_OK(WriteDataset(dataset, f));
    options.dataset = dataset;
    options.out_dir = out;
    report = ExportZarr(options);
  }
};

// Nothing under out, and no temporary beside it.
void ExpectNothingLeft(const fs::path& out) {
  EXPECT_FALSE(fs::exists(out)) << out;
  for (const auto& e : fs::directory_iterator(out.parent_path())) {
    EXPECT_FALSE(e.path().filename().string().starts_with(out.filename().string() + ".tmp-")) << e.path();
  }
}

TEST(ExportZarr, ChunksDecodeToTheShards) {
  ZarrExportOptions o;
  o.chunk = 4;  // 10 images: chunks 0 and 1 full, chunk 2 half empty
  Exported e(Default(), o);
  ASSERT_TRUE(e.report.ok()) << e.report.status().ToString();
  const fs::path& z = e.out;
  EXPECT_EQ(ReadBytes(z / ".zgroup"), Bytes({'{', '\n', ' ', ' ', ' ', ' ', '"', 'z', 'a', 'r', 'r', '_', 'f', 'o', 'r',
                                             'm', 'a', 't', '"', ':', ' ', '2', '\n', '}'}));
  const std::vector<Bytes> images = Rows(z / "images"), boxes = Rows(z / "bboxes"), masks = Rows(z / "masks"),
                           visibilities = Rows(z / "visibilities"), ratios = Rows(z / "mask_bbox_ratios"),
                           angles = Rows(z / "angles");
  ASSERT_EQ(images.size(), 10u);
  for (const auto* rows : {&boxes, &masks, &visibilities, &ratios, &angles}) ASSERT_EQ(rows->size(), 10u);
  EXPECT_EQ(e.report->images, 10);
  EXPECT_EQ(e.report->chunks, 3);
  EXPECT_EQ(ReadJson(z / "images" / ".zarray")["filters"],
            nlohmann::json::array({{{"id", "vlen-array"}, {"dtype", "|i1"}}}));
  EXPECT_EQ(ReadJson(z / "bboxes" / ".zarray")["filters"][0]["dtype"], "<i4");
  EXPECT_EQ(ReadJson(z / "angles" / ".zarray")["dtype"], "|O");

  Result<Dataset> dataset = Dataset::Open(e.dataset);
  ASSERT_OK(dataset.status());
  size_t row = 0;
  int64_t instances = 0;
  ASSERT_OK(dataset->ForEachImage([&](const ImageRecord& image, const std::vector<InstanceRecord>& all) -> Status {
    std::vector<const InstanceRecord*> visible;
    for (const InstanceRecord& in : all) {
      if (in.visible_area > 0) visible.push_back(&in);
    }
    if (visible.empty()) return Status::Ok();
    const size_t r = row++;
    SCOPED_TRACE(fmt::format("image {} row {}", image.image_id, r));
    EXPECT_EQ(images.at(r), image.image);
    const std::vector<int32_t> b = As<int32_t>(boxes.at(r));
    const std::vector<float> v = As<float>(visibilities.at(r)), q = As<float>(ratios.at(r)), a = As<float>(angles.at(r));
    EXPECT_EQ(b.size(), 5 * visible.size());
    EXPECT_EQ(masks.at(r).size(), visible.size() * image.width * image.height);
    EXPECT_EQ(v.size(), visible.size());
    EXPECT_EQ(a.size(), 3 * visible.size());
    if (b.size() != 5 * visible.size() || masks[r].size() != visible.size() * image.width * image.height ||
        v.size() != visible.size() || a.size() != 3 * visible.size()) {
      return Status::Ok();
    }
    for (size_t k = 0; k < visible.size(); ++k) {
      const InstanceRecord& in = *visible[k];
      const rle::Box& box = in.visible_box;
      // Classes are the models in key order: fixture/model-NN is class NN.
      const int32_t klass = std::stoi(in.model_key.substr(in.model_key.size() - 2));
      EXPECT_EQ(std::vector<int32_t>(b.begin() + 5 * k, b.begin() + 5 * k + 5),
                std::vector<int32_t>({static_cast<int32_t>(box.x), static_cast<int32_t>(box.y),
                                      static_cast<int32_t>(box.x + box.w), static_cast<int32_t>(box.y + box.h), klass}));
      const std::vector<uint8_t> want = rle::DecodeRowMajor(*rle::FromString(in.visible_rle, image.height, image.width));
      const size_t plane = size_t{image.width} * image.height;
      EXPECT_TRUE(std::equal(want.begin(), want.end(), masks[r].begin() + static_cast<std::ptrdiff_t>(k * plane)))
          << "mask " << k;
      EXPECT_EQ(v[k], static_cast<float>(static_cast<double>(in.visible_area) / static_cast<double>(in.full_area)));
      EXPECT_EQ(q[k], static_cast<float>(static_cast<double>(in.visible_area) / static_cast<double>(box.w * box.h)));
      const std::array<double, 3> pose = PoseAngles(image.image_id, in.ordinal);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[3 * k + c], pose[c], 2e-6) << "angle " << c << " of instance " << k;
    }
    instances += static_cast<int64_t>(visible.size());
    return Status::Ok();
  }));
  EXPECT_EQ(row, 10u);
  EXPECT_EQ(e.report->instances, instances);

  std::vector<int64_t> all_ids;
  for (int c = 0; c < 3; ++c) {
    const std::vector<int64_t> chunk = As<int64_t>(RawChunk(z / "solid_image_ids", std::to_string(c)));
    ASSERT_EQ(chunk.size(), 4u);
    all_ids.insert(all_ids.end(), chunk.begin(), chunk.end());
  }
  EXPECT_EQ(all_ids, std::vector<int64_t>({0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 0, 0}));
  const Bytes valids = RawChunk(z / "valids", "0");
  EXPECT_EQ(ReadJson(z / "valids" / ".zarray")["chunks"], nlohmann::json::array({10}));
  EXPECT_EQ(valids, Bytes(10, 1));
  EXPECT_EQ(As<int64_t>(RawChunk(z / "query_ids", "0")), std::vector<int64_t>({0, 1, 2, 3, 4, 5, 6, 7, 8}));
  EXPECT_EQ(ReadJson(z / "scenenet_models" / ".zarray")["dtype"], "|S128");
  EXPECT_FALSE(fs::exists(z / "scenenet_models" / "0")) << "the reference never writes it";
  const nlohmann::json about = ReadJson(z / "solid_export.json");
  EXPECT_EQ(about["classes"].size(), 9u);
  EXPECT_EQ(about["classes"][3], ModelKey(3));
  EXPECT_TRUE(about["dropped_models"].empty());
}

TEST(ExportZarr, OneToSevenViewsCycleIntoEightSlots) {
  ZarrExportOptions o;
  o.chunk = 4;  // 9 classes: row blocks 0, 1 and 2 of the queries, chunks 4 x 4
  Exported e(Default(), o);
  ASSERT_TRUE(e.report.ok()) << e.report.status().ToString();
  const nlohmann::json meta = ReadJson(e.out / "queries" / ".zarray");
  EXPECT_EQ(meta["shape"], nlohmann::json::array({9, 8}));
  EXPECT_EQ(meta["chunks"], nlohmann::json::array({4, 4}));
  EXPECT_TRUE(meta["compressor"].is_null());
  const std::vector<int> views = Default().views;
  for (int block = 0; block < 3; ++block) {
    for (int f = 0; f < 2; ++f) {
      const std::vector<Bytes> items = Items(e.out / "queries", fmt::format("{}.{}", block, f));
      ASSERT_EQ(items.size(), 16u);
      for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) {
          const int klass = block * 4 + r, slot = f * 4 + c;
          const Bytes& item = items[static_cast<size_t>(r * 4 + c)];
          if (klass >= 9) {
            EXPECT_TRUE(item.empty()) << "class " << klass << " past the shape";
          } else {
            EXPECT_EQ(item, ViewPng(klass, slot % views[static_cast<size_t>(klass)])) << "class " << klass << " slot " << slot;
          }
        }
      }
    }
  }
}

TEST(ExportZarr, AModelWithoutViewsIsRefusedOrDroppedWithItsInstances) {
  Fixture f = Default();
  f.views[2] = 0;
  Exported refused(f);
  ASSERT_EQ(refused.report.status().code(), StatusCode::kNotFound) << refused.report.status().ToString();
  const std::string& m = refused.report.status().message();
  EXPECT_NE(m.find("1 of 9 models have no query view"), std::string::npos) << m;
  EXPECT_NE(m.find(ModelKey(2)), std::string::npos) << m;
  EXPECT_NE(m.find("8 of 8 views failed"), std::string::npos) << m;
  EXPECT_EQ(m.find("--"), std::string::npos) << "a library message names no flag: " << m;
  ExpectNothingLeft(refused.out);

  ZarrExportOptions o;
  o.drop_viewless_models = true;
  Exported dropped(f, o);
  ASSERT_TRUE(dropped.report.ok()) << dropped.report.status().ToString();
  EXPECT_EQ(dropped.report->classes, 8);
  EXPECT_EQ(dropped.report->dropped_models, std::vector<std::string>({ModelKey(2)}));
  EXPECT_GT(dropped.report->dropped_instances, 0);
  const nlohmann::json about = ReadJson(dropped.out / "solid_export.json");
  ASSERT_EQ(about["classes"].size(), 8u);
  EXPECT_EQ(about["classes"][1], ModelKey(1));
  EXPECT_EQ(about["classes"][2], ModelKey(3)) << "renumbered densely";
  EXPECT_EQ(about["dropped_models"],
            nlohmann::json::array({{{"model_key", ModelKey(2)}, {"failure", "8 of 8 views failed"}}}));
  EXPECT_EQ(ReadJson(dropped.out / "queries" / ".zarray")["shape"], nlohmann::json::array({8, 8}));
  EXPECT_EQ(As<int64_t>(RawChunk(dropped.out / "query_ids", "0")), std::vector<int64_t>({0, 1, 2, 3, 4, 5, 6, 7}));
  // Class k's views are model k's below the dropped one, model k + 1's above it.
  const std::vector<Bytes> slots = Items(dropped.out / "queries", "0.0");
  EXPECT_EQ(slots[2 * 256], ViewPng(3, 0));
  EXPECT_EQ(slots[2 * 256 + 3], ViewPng(3, 0)) << "model 3 has 3 views: slot 3 is view 0";

  int64_t boxes = 0;
  for (const Bytes& row : Rows(dropped.out / "bboxes")) {
    const std::vector<int32_t> b = As<int32_t>(row);
    ASSERT_FALSE(b.empty()) << "an image left with no instance is skipped";
    for (size_t k = 4; k < b.size(); k += 5) EXPECT_LT(b[k], 8);
    boxes += static_cast<int64_t>(b.size() / 5);
  }
  EXPECT_EQ(boxes, dropped.report->instances);
  EXPECT_EQ(dropped.report->instances + dropped.report->dropped_instances,
            Exported(Default()).report->instances);
}

TEST(ExportZarr, RefusesBadInputAndLeavesNothing) {
  {  // a dataset rendered without query views
    Fixture f = Default();
    f.queries = false;
    Exported e(f);
    EXPECT_EQ(e.report.status().code(), StatusCode::kNotFound) << e.report.status().ToString();
    EXPECT_NE(e.report.status().message().find("has no query views"), std::string::npos) << e.report.status().message();
    ExpectNothingLeft(e.out);
  }
  {  // an incomplete one: a target shard missing
    TempDir dir;
    const fs::path dataset = dir.path() / "dataset";
    ASSERT_OK(WriteDataset(dataset, Default()));
    fs::remove(DatasetPaths(dataset).shard(1));
    ZarrExportOptions o;
    o.dataset = dataset;
    o.out_dir = dir.path() / "store";
    const Status s = ExportZarr(o).status();
    EXPECT_EQ(s.code(), StatusCode::kNotFound) << s.ToString();
    EXPECT_NE(s.message().find("incomplete: 1 of its 3 target shards are missing (1)"), std::string::npos) << s.ToString();
    ExpectNothingLeft(o.out_dir);
  }
  {  // an existing store is never touched; an empty directory is used
    TempDir dir;
    ZarrExportOptions o;
    o.dataset = dir.path() / "dataset";
    o.out_dir = dir.path() / "store";
    ASSERT_OK(WriteDataset(o.dataset, Default()));
    fs::create_directories(o.out_dir);
    std::ofstream(o.out_dir / "mine") << "keep";
    const Status s = ExportZarr(o).status();
    EXPECT_EQ(s.code(), StatusCode::kAlreadyExists) << s.ToString();
    EXPECT_NE(s.message().find(o.out_dir.string() + ": exists and is not an empty directory"), std::string::npos)
        << s.ToString();
    EXPECT_EQ(ReadBytes(o.out_dir / "mine"), Bytes({'k', 'e', 'e', 'p'}));
    fs::remove(o.out_dir / "mine");
    ASSERT_OK(ExportZarr(o).status());
    EXPECT_TRUE(fs::exists(o.out_dir / ".zgroup"));
  }
  {  // options
    ZarrExportOptions o;
    o.dataset = "d";
    o.out_dir = "o";
    o.chunk = 0;
    EXPECT_EQ(ExportZarr(o).status().option(), "chunk");
    o.chunk = kMaxZarrChunk + 1;
    EXPECT_EQ(ExportZarr(o).status().option(), "chunk");
    o.chunk = 256;
    o.max_chunk_bytes = kBloscMaxBufferBytes + 1;
    EXPECT_EQ(ExportZarr(o).status().option(), "max_chunk_bytes");
  }
}

// Blosc takes at most kBloscMaxBufferBytes: a raw mask chunk over the limit is refused
// before it is decoded (here a lowered limit stands in for the 2 GiB one).
TEST(ExportZarr, AMaskChunkOverTheLimitIsRefused) {
  ZarrExportOptions o;
  o.chunk = 4;
  o.max_chunk_bytes = 4 + 4 * 4 + 3 * 40 * 30;  // three masks of 40 x 30
  Exported e(Default(), o);
  ASSERT_EQ(e.report.status().code(), StatusCode::kLimitExceeded) << e.report.status().ToString();
  const std::string& m = e.report.status().message();
  EXPECT_NE(m.find((e.out / "masks" / "0").string() + ": the raw chunk of images 0 to 3 would be"), std::string::npos) << m;
  EXPECT_NE(m.find("smaller chunk"), std::string::npos) << m;
  ExpectNothingLeft(e.out);
}

// While the export runs, out_dir does not exist and the temporary beside it opens as no
// zarr group (no .zgroup): a killed export leaves nothing that reads as a store. A dead
// writer's temporary is removed by the next export; a cancelled one removes its own.
TEST(ExportZarr, NothingReadsAsAStoreBeforeTheEnd) {
  TempDir dir;
  ZarrExportOptions o;
  o.dataset = dir.path() / "dataset";
  o.out_dir = dir.path() / "store";
  o.chunk = 4;
  ASSERT_OK(WriteDataset(o.dataset, Default()));
  const fixtures::CommandRun dead = fixtures::RunCommand("echo $$");
  const std::string mine = files::TempPathFor(o.out_dir).filename().string();
  const std::string host_prefix = mine.substr(0, mine.find(std::to_string(::getpid())));
  const fs::path stale = dir.path() / (host_prefix + std::to_string(std::stoi(dead.output)) + "-0");
  fs::create_directories(stale / "masks");
  std::ofstream(stale / "masks" / "0") << "half a chunk";

  CancelFlag cancel{false};
  int checked = 0;
  o.cancel = &cancel;
  o.progress = [&](int64_t done, int64_t) {
    if (done != 6) return;
    EXPECT_FALSE(fs::exists(o.out_dir));
    EXPECT_FALSE(fs::exists(stale)) << "a dead writer's temporary";
    for (const auto& entry : fs::directory_iterator(dir.path())) {
      if (!files::IsTempPath(entry.path())) continue;
      ++checked;
      EXPECT_TRUE(fs::exists(entry.path() / "masks" / "0")) << "chunk 0 is written";
      EXPECT_FALSE(fs::exists(entry.path() / ".zgroup"));
    }
    cancel = true;
  };
  const Status s = ExportZarr(o).status();
  EXPECT_EQ(checked, 1);
  EXPECT_EQ(s.code(), StatusCode::kCancelled) << s.ToString();
  EXPECT_NE(s.message().find("no store written"), std::string::npos) << s.ToString();
  ExpectNothingLeft(o.out_dir);
  o.cancel = nullptr;
  o.progress = {};
  ASSERT_OK(ExportZarr(o).status());
}

TEST(ExportZarrCli, ExitCodesAndMessages) {
  TempDir dir;
  const fs::path dataset = dir.path() / "dataset";
  Fixture f = Default();
  f.views[4] = 0;
  ASSERT_OK(WriteDataset(dataset, f));
  auto run = [&](const std::string& args) {
    return fixtures::RunCommand(std::string(SOLID_CLI_BINARY) + " export zarr " + fixtures::ShellQuote(dataset.string()) +
                                " " + fixtures::ShellQuote((dir.path() / "store").string()) + args);
  };
  const fixtures::CommandRun viewless = run("");
  EXPECT_EQ(viewless.exit_status, 3) << viewless.output;
  EXPECT_NE(viewless.output.find("solid: " + dataset.string() + ": 1 of 9 models have no query view"), std::string::npos)
      << viewless.output;
  const fixtures::CommandRun chunk = run(" --chunk 0");
  EXPECT_EQ(chunk.exit_status, 2) << chunk.output;
  const fixtures::CommandRun ok = run(" --chunk 8 --drop-viewless-models");
  EXPECT_EQ(ok.exit_status, 0) << ok.output;
  EXPECT_NE(ok.output.find("store: 10 images"), std::string::npos) << ok.output;
  EXPECT_NE(ok.output.find("1 viewless model dropped"), std::string::npos) << ok.output;
  const fixtures::CommandRun again = run(" --drop-viewless-models");
  EXPECT_EQ(again.exit_status, 4) << again.output;
  EXPECT_NE(again.output.find("exists and is not an empty directory"), std::string::npos) << again.output;
}

}  // namespace
}  // namespace solid::exporters
