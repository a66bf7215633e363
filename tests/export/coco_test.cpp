// ExportCoco read back by a reader written against the COCO instances format
// (cocodataset.org/#format-data): every decoded mask, box and area equals the shard's.
#include "solid/export/coco.h"

#include <gtest/gtest.h>

#include <fmt/format.h>

#include <fstream>
#include <functional>
#include <set>

#include "fixtures/layered_dataset.h"
#include "fixtures/run_command.h"
#include "formats/test_util.h"
#include "solid/formats/dataset.h"
#include "solid/formats/files.h"

namespace solid::exporters {
namespace {

namespace fs = std::filesystem;
using solid::testing::TempDir;

nlohmann::json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// An RLE segmentation as COCO defines it: {"size": [h, w], "counts": compressed string}.
rle::Rle ReadSegmentation(const nlohmann::json& seg, const Manifest& m) {
  EXPECT_TRUE(seg.is_object());
  EXPECT_EQ(seg.at("size"), nlohmann::json::array({m.height, m.width}));
  Result<rle::Rle> mask = rle::FromString(seg.at("counts").get<std::string>(), m.height, m.width);
  EXPECT_TRUE(mask.ok()) << mask.status().ToString();
  return mask.ok() ? *mask : rle::Rle{};
}

std::vector<int64_t> Box(const rle::Box& b) { return {b.x, b.y, b.w, b.h}; }

// Small crowded images.
Status WriteCrowded(const fs::path& root) {
  fixtures::LayeredDatasetOptions o;
  o.images = 10;
  o.shard_size = 4;
  o.width = 64;
  o.height = 48;
  o.max_objects = 12;
  return fixtures::WriteLayeredDataset(root, o);
}

// Two layered images plus, in image 1, a copy of its first object hidden entirely behind it.
Status WriteWithHiddenObject(const fs::path& root) {
  fixtures::LayeredDatasetOptions o;
  o.images = 2;
  o.shard_size = 2;
  o.queries = false;
  SOLID_RETURN_IF_ERROR(CreateDataset(root, fixtures::LayeredManifest(o)));
  SOLID_ASSIGN_OR_RETURN(ShardWriter shard, ShardWriter::Create(DatasetPaths(root).shard(0)));
  for (int64_t id = 0; id < 2; ++id) {
    SOLID_ASSIGN_OR_RETURN(fixtures::LayeredImage image, fixtures::MakeLayeredImage(o, id));
    SOLID_RETURN_IF_ERROR(shard.AddImage(image.image));
    for (const InstanceRecord& in : image.instances) SOLID_RETURN_IF_ERROR(shard.AddInstance(in));
    if (id == 0) continue;
    const InstanceRecord& front = image.instances.front();
    InstanceRecord hidden = front;
    hidden.ordinal = static_cast<int32_t>(image.instances.size());
    SOLID_ASSIGN_OR_RETURN(rle::Rle behind, rle::FromString(front.visible_rle, o.height, o.width));
    SOLID_RETURN_IF_ERROR(SetInstanceMasks(rle::FromBox({}, o.height, o.width), behind, &hidden));
    SOLID_RETURN_IF_ERROR(shard.AddInstance(hidden));
  }
  return shard.Commit();
}

struct Exported {
  TempDir dir;
  fs::path dataset = dir.path() / "dataset", out = dir.path() / "coco";
  nlohmann::json json;

  explicit Exported(CocoExportOptions options, const std::function<Status(const fs::path&)>& write = WriteCrowded) {
    EXPECT_OK(write(dataset));
    options.dataset = dataset;
    options.out_dir = out;
    Result<CocoExportReport> r = ExportCoco(options);
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    json = ReadJson(out / "annotations.json");
  }
};

// Checks the document against the COCO spec and the dataset; returns the annotations per image.
void CheckAgainstDataset(const Exported& e, CocoMasks masks) {
  const nlohmann::json& j = e.json;
  for (const char* key : {"info", "licenses", "images", "annotations", "categories"}) ASSERT_TRUE(j.contains(key)) << key;
  std::set<int64_t> category_ids;
  for (const auto& c : j["categories"]) {
    ASSERT_TRUE(c.at("id").is_number_integer() && c.at("name").is_string() && c.at("supercategory").is_string());
    EXPECT_TRUE(category_ids.insert(c["id"].get<int64_t>()).second);
  }
  Result<Dataset> dataset = Dataset::Open(e.dataset);
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  const Manifest& m = dataset->manifest();

  size_t image = 0, annotation = 0;
  std::set<int64_t> annotation_ids;
  ASSERT_OK(dataset->ForEachImage([&](const ImageRecord& rec, const std::vector<InstanceRecord>& instances) -> Status {
    const nlohmann::json& img = j["images"].at(image++);
    EXPECT_EQ(img.at("id"), rec.image_id);
    EXPECT_EQ(img.at("width"), rec.width);
    EXPECT_EQ(img.at("height"), rec.height);
    Result<std::vector<uint8_t>> bytes = files::ReadFile(e.out / "images" / img.at("file_name").get<std::string>(), 1 << 24);
    EXPECT_TRUE(bytes.ok() && *bytes == rec.image) << "image " << rec.image_id;
    for (const InstanceRecord& in : instances) {
      const bool full = masks == CocoMasks::kFull;
      if ((full ? in.full_area : in.visible_area) == 0) continue;
      const nlohmann::json& a = j["annotations"].at(annotation++);
      EXPECT_TRUE(annotation_ids.insert(a.at("id").get<int64_t>()).second);
      EXPECT_GT(a["id"].get<int64_t>(), 0) << "pycocotools' evaluation treats annotation id 0 as no match";
      EXPECT_EQ(a.at("image_id"), rec.image_id);
      EXPECT_EQ(a.at("iscrowd"), 0);
      EXPECT_TRUE(category_ids.contains(a.at("category_id").get<int64_t>()));
      EXPECT_EQ(a.at("model_key"), in.model_key);
      const rle::Rle seg = ReadSegmentation(a.at("segmentation"), m);
      const std::string& stored = full ? in.full_rle : in.visible_rle;
      EXPECT_EQ(rle::DecodeRowMajor(seg), rle::DecodeRowMajor(*rle::FromString(stored, m.height, m.width)))
          << "image " << rec.image_id << " instance " << in.ordinal;
      EXPECT_EQ(a.at("area").get<uint64_t>(), rle::Area(seg));
      EXPECT_EQ(a.at("bbox").get<std::vector<int64_t>>(), Box(rle::ToBbox(seg)));
      EXPECT_EQ(a.at("area").get<uint64_t>(), full ? in.full_area : in.visible_area);
      if (in.occlusion) EXPECT_DOUBLE_EQ(a.at("occlusion").get<double>(), *in.occlusion);
      else EXPECT_TRUE(a.at("occlusion").is_null());
      if (full) {
        EXPECT_EQ(a.at("visible_bbox").get<std::vector<int64_t>>(), Box(in.visible_box));
      } else {
        EXPECT_EQ(a.at("full_bbox").get<std::vector<int64_t>>(), Box(in.full_box));
        EXPECT_EQ(a.at("full_area").get<uint64_t>(), in.full_area);
      }
      EXPECT_EQ(a.contains("full_segmentation"), masks == CocoMasks::kBoth);
      if (masks == CocoMasks::kBoth) {
        const rle::Rle amodal = ReadSegmentation(a["full_segmentation"], m);
        EXPECT_EQ(rle::DecodeRowMajor(amodal), rle::DecodeRowMajor(*rle::FromString(in.full_rle, m.height, m.width)));
      }
    }
    return Status::Ok();
  }));
  EXPECT_EQ(image, j["images"].size());
  EXPECT_EQ(annotation, j["annotations"].size()) << "annotations the dataset does not have";
}

TEST(ExportCoco, BothMasksMatchTheShards) {
  CocoExportOptions o;
  Exported e(o);
  CheckAgainstDataset(e, CocoMasks::kBoth);
  ASSERT_EQ(e.json["categories"].size(), 1u);
  EXPECT_EQ(e.json["categories"][0]["name"], "object");
}

TEST(ExportCoco, VisibleMasksSkipHiddenObjectsAndFullMasksKeepThem) {
  CocoExportOptions o;
  o.masks = CocoMasks::kVisible;
  Exported visible(o, WriteWithHiddenObject);
  CheckAgainstDataset(visible, CocoMasks::kVisible);
  o.masks = CocoMasks::kFull;
  Exported full(o, WriteWithHiddenObject);
  CheckAgainstDataset(full, CocoMasks::kFull);
  EXPECT_EQ(full.json["annotations"].size(), visible.json["annotations"].size() + 1);
  EXPECT_EQ(full.json["annotations"].back()["visible_area"], 0);
}

TEST(ExportCoco, PerModelCategoriesNameTheModels) {
  CocoExportOptions o;
  o.categories = CocoCategories::kModel;
  Exported e(o);
  CheckAgainstDataset(e, CocoMasks::kBoth);
  std::map<int64_t, std::string> names;
  for (const auto& c : e.json["categories"]) names[c["id"].get<int64_t>()] = c["name"].get<std::string>();
  EXPECT_GT(names.size(), 1u);
  for (const auto& a : e.json["annotations"]) EXPECT_EQ(names.at(a["category_id"].get<int64_t>()), a["model_key"]);
}

TEST(ExportCoco, LinkHardLinksAnEarlierExportOfTheSameDataset) {
  CocoExportOptions o;
  Exported e(o);
  o.dataset = e.dataset;
  o.out_dir = e.dir.path() / "linked";
  o.images = CocoImages::kLink;
  EXPECT_EQ(ExportCoco(o).status().code(), StatusCode::kInvalidArgument) << "link needs link_from";
  EXPECT_EQ(ExportCoco(o).status().option(), "link_from");
  o.link_from = e.dir.path() / "no-export";
  const Status not_an_export = ExportCoco(o).status();
  EXPECT_EQ(not_an_export.code(), StatusCode::kNotFound) << not_an_export.ToString();
  EXPECT_EQ(not_an_export.option(), "link_from");

  o.link_from = e.out;
  o.masks = CocoMasks::kFull;
  ASSERT_OK(ExportCoco(o).status());
  const std::string first = e.json["images"][0]["file_name"];
  EXPECT_TRUE(fs::equivalent(o.out_dir / "images" / first, e.out / "images" / first));
  EXPECT_EQ(fs::hard_link_count(e.out / "images" / first), 2u);

  // A different image under the same name is refused, naming the file.
  fs::remove(e.out / "images" / first);
  std::ofstream(e.out / "images" / first) << "not the image";
  Status s = ExportCoco(o).status();
  EXPECT_EQ(s.code(), StatusCode::kCorrupt);
  EXPECT_NE(s.message().find(first), std::string::npos) << s.ToString();
}

// pycocotools, the reference reader, when it is installed: loads the file, decodes every
// mask and checks its area and box.
TEST(ExportCoco, PycocotoolsReadsIt) {
  if (fixtures::RunCommand("python3 -c 'import pycocotools' 2>/dev/null").exit_status != 0) {
    GTEST_SKIP() << "pycocotools is not installed (pip install pycocotools)";
  }
  CocoExportOptions o;
  Exported e(o);
  const std::string script =
      "import sys\n"
      "from pycocotools.coco import COCO\n"
      "from pycocotools import mask as M\n"
      "c = COCO(sys.argv[1])\n"
      "for a in c.loadAnns(c.getAnnIds()):\n"
      "    m = c.annToMask(a)\n"
      "    assert m.sum() == a['area'], a['id']\n"
      "    assert list(M.toBbox(a['segmentation'])) == a['bbox'], a['id']\n"
      "print('checked', len(c.getAnnIds()))\n";
  const fixtures::CommandRun run = fixtures::RunCommand("python3 -c " + fixtures::ShellQuote(script) + " " +
                                                        fixtures::ShellQuote((e.out / "annotations.json").string()));
  EXPECT_EQ(run.exit_status, 0) << run.output;
}

// Cancelled after 3 images (in pass 1) and during the annotations (pass 2): kCancelled,
// no annotations.json and no temporary; the images written are whole; a rerun completes.
TEST(ExportCoco, CancelledExportsLeaveNoAnnotationsAndARerunCompletes) {
  TempDir dir;
  const fs::path dataset = dir.path() / "dataset", out = dir.path() / "coco";
  ASSERT_OK(WriteCrowded(dataset));
  for (const int64_t stop_at : {3, 10}) {
    SCOPED_TRACE(stop_at);
    fs::remove_all(out);
    CancelFlag cancel{false};
    CocoExportOptions o;
    o.dataset = dataset;
    o.out_dir = out;
    o.cancel = &cancel;
    o.progress = [&](int64_t done, int64_t) {
      if (done == stop_at) cancel = true;
    };
    Result<CocoExportReport> r = ExportCoco(o);
    ASSERT_EQ(r.status().code(), StatusCode::kCancelled) << r.status().ToString();
    EXPECT_NE(r.status().message().find(fmt::format("stopped after {} of 10 images", stop_at)), std::string::npos)
        << r.status().message();
    EXPECT_FALSE(fs::exists(out / "annotations.json"));
    int64_t images = 0;
    for (const auto& entry : fs::recursive_directory_iterator(out)) {
      EXPECT_FALSE(files::IsTempPath(entry.path())) << entry.path();
      if (entry.is_regular_file()) ++images;
    }
    EXPECT_EQ(images, stop_at);
  }
  CocoExportOptions o;
  o.dataset = dataset;
  o.out_dir = out;
  ASSERT_OK(ExportCoco(o).status());
  EXPECT_EQ(ReadJson(out / "annotations.json")["images"].size(), 10u);
}

TEST(ExportCli, ExportsAndRefusesLinkWithoutASource) {
  TempDir dir;
  fixtures::LayeredDatasetOptions layered;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path() / "d", layered));
  const std::string base = std::string(SOLID_CLI_BINARY) + " export coco " + fixtures::ShellQuote((dir.path() / "d").string()) +
                           " " + fixtures::ShellQuote((dir.path() / "out").string());
  const fixtures::CommandRun ok = fixtures::RunCommand(base + " --masks visible --categories model");
  EXPECT_EQ(ok.exit_status, 0) << ok.output;
  EXPECT_NE(ok.output.find("annotations.json: 8 images"), std::string::npos) << ok.output;
  const fixtures::CommandRun link = fixtures::RunCommand(base + " --images link");
  EXPECT_EQ(link.exit_status, 2) << link.output;
  EXPECT_NE(link.output.find("solid: --link-from: needed to link the images"), std::string::npos) << link.output;
  const fixtures::CommandRun elsewhere = fixtures::RunCommand(
      base + " --images link --link-from " + fixtures::ShellQuote((dir.path() / "d").string()));
  EXPECT_EQ(elsewhere.exit_status, 3) << elsewhere.output;
  EXPECT_NE(elsewhere.output.find("solid: --link-from: "), std::string::npos) << elsewhere.output;
  EXPECT_NE(elsewhere.output.find("not an export of this dataset"), std::string::npos) << elsewhere.output;
}

}  // namespace
}  // namespace solid::exporters
