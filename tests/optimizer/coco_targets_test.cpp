// Targets from a COCO instances file: exact counts and shares on small files the tests write
// (crowd left out, empty images counted or skipped, areas rescaled per image, the class
// thresholds at their boundaries, either order of the arrays), and each kind of bad file
// with its code and the JSON Pointer in the message.
#include "solid/optimizer/coco_targets.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include <fmt/format.h>

#include "formats/test_util.h"

namespace solid::optimizer {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr double kZ95 = 1.959963984540054;

class CocoTargetsTest : public ::testing::Test {
 protected:
  std::filesystem::path Write(std::string_view text, std::string_view name = "coco.json") {
    const std::filesystem::path path = dir_.path() / name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }

  Result<CocoMatch> Match(std::string_view text, const CocoMatchOptions& options = {}) {
    return TargetsFromCoco(Write(text), options);
  }

  // The error of `text`, which must fail with `code`; its message starts with the file.
  std::string ErrorOf(std::string_view text, StatusCode code, const CocoMatchOptions& options = {}) {
    const std::filesystem::path path = Write(text);
    Result<CocoMatch> m = TargetsFromCoco(path, options);
    EXPECT_FALSE(m.ok());
    if (m.ok()) return {};
    EXPECT_EQ(m.status().code(), code) << m.status().ToString();
    EXPECT_THAT(m.status().message(), StartsWith(path.string() + ":"));
    return m.status().message();
  }

  solid::testing::TempDir dir_;
};

// Three 640x480 images: one with small, medium and large objects, one with a small object and
// a crowd region, one without annotations; with the other keys a real file has.
constexpr std::string_view kBasic = R"({
  "info": {"description": "test", "year": 2026},
  "licenses": [{"id": 1, "name": "x", "url": "http://example.com/a/b"}],
  "images": [
    {"id": 1, "file_name": "a.png", "width": 640, "height": 480, "license": 1},
    {"id": 2, "file_name": "b.png", "width": 640, "height": 480},
    {"id": 7, "file_name": "c.png", "width": 640, "height": 480}
  ],
  "annotations": [
    {"id": 1, "image_id": 1, "category_id": 1, "area": 100, "bbox": [0, 0, 10, 10], "iscrowd": 0,
     "segmentation": [[0, 0, 10, 0, 10, 10, 0, 10]]},
    {"id": 2, "image_id": 1, "category_id": 1, "area": 2000.5, "bbox": [0, 0, 40, 50], "iscrowd": 0,
     "segmentation": [[0, 0, 40.5, 0, 40.5, 50, 0, 50], [1, 1, 2, 2, 1, 2]]},
    {"id": 3, "image_id": 1, "category_id": 1, "area": 10000, "bbox": [0, 0, 100, 100],
     "segmentation": {"size": [480, 640], "counts": "PPYo0"}},
    {"id": 4, "image_id": 2, "category_id": 1, "area": 500, "bbox": [0, 0, 20, 25], "iscrowd": false,
     "segmentation": [[0, 0, 20, 0, 20, 25]]},
    {"id": 5, "image_id": 2, "category_id": 1, "area": 50000, "bbox": [0, 0, 300, 200], "iscrowd": 1,
     "segmentation": {"size": [480, 640], "counts": [0, 100, 307100]}}
  ],
  "categories": [{"id": 1, "name": "object", "supercategory": "thing"}]
})";

TEST_F(CocoTargetsTest, DerivesCountsAndSharesExactly) {
  Result<CocoMatch> m = Match(kBasic);
  ASSERT_OK(m.status());
  EXPECT_EQ(m->images, 3);
  EXPECT_EQ(m->images_counted, 3);
  EXPECT_EQ(m->empty_images, 1);
  EXPECT_EQ(m->annotations, 4);
  EXPECT_EQ(m->crowd_skipped, 1);
  EXPECT_EQ(m->width, 640);
  EXPECT_EQ(m->height, 480);
  // Objects per image 3, 1, 0: mean 4/3, sample variance 7/3.
  EXPECT_DOUBLE_EQ(m->objects_per_image.mean, 4.0 / 3);
  EXPECT_DOUBLE_EQ(m->objects_per_image.ci95, kZ95 * std::sqrt(7.0 / 3 / 3));
  EXPECT_DOUBLE_EQ(m->small.mean, 0.5);
  EXPECT_DOUBLE_EQ(m->small.ci95, kZ95 * std::sqrt(0.25 / 4));
  EXPECT_DOUBLE_EQ(m->medium.mean, 0.25);
  EXPECT_DOUBLE_EQ(m->large.mean, 0.25);
  EXPECT_DOUBLE_EQ(m->large.ci95, kZ95 * std::sqrt(0.25 * 0.75 / 4));

  ASSERT_EQ(m->targets.size(), 4u);
  const Metric order[] = {Metric::kObjectsPerImage, Metric::kSmall, Metric::kMedium, Metric::kLarge};
  const double values[] = {4.0 / 3, 0.5, 0.25, 0.25};
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(m->targets[i].metric, order[i]);
    EXPECT_DOUBLE_EQ(m->targets[i].value, values[i]);
    EXPECT_EQ(m->targets[i].tolerance, DefaultTolerance(order[i]));
  }
}

TEST_F(CocoTargetsTest, SkipsEmptyImagesWhenAsked) {
  CocoMatchOptions options;
  options.skip_empty_images = true;
  Result<CocoMatch> m = Match(kBasic, options);
  ASSERT_OK(m.status());
  EXPECT_EQ(m->images, 3);
  EXPECT_EQ(m->images_counted, 2);
  EXPECT_EQ(m->empty_images, 1);
  EXPECT_DOUBLE_EQ(m->objects_per_image.mean, 2);
  EXPECT_DOUBLE_EQ(m->objects_per_image.ci95, kZ95 * std::sqrt(2.0 / 2));
  EXPECT_DOUBLE_EQ(m->small.mean, 0.5);  // the shares do not depend on images without objects
}

TEST_F(CocoTargetsTest, AnImageWithOnlyCrowdRegionsIsEmpty) {
  Result<CocoMatch> m = Match(R"({"images": [{"id": 1, "width": 10, "height": 10}, {"id": 2, "width": 10, "height": 10}],
    "annotations": [{"image_id": 1, "area": 5}, {"image_id": 2, "iscrowd": 1}, {"image_id": 2, "iscrowd": true}]})");
  ASSERT_OK(m.status());  // a crowd region needs no area
  EXPECT_EQ(m->empty_images, 1);
  EXPECT_EQ(m->crowd_skipped, 2);
  EXPECT_DOUBLE_EQ(m->objects_per_image.mean, 0.5);
}

// At 640x480, 320x240 (areas x4) and 1280x960 (areas / 4), each class boundary from both
// sides after rescaling: 1023 small, 1024 and 9216 medium, 9217 large.
constexpr std::string_view kMixedSizes = R"({
  "images": [{"id": 10, "width": 320, "height": 240}, {"id": 20, "width": 1280, "height": 960},
             {"id": 30, "width": 640, "height": 480}],
  "annotations": [
    {"image_id": 10, "area": 255.75}, {"image_id": 10, "area": 256}, {"image_id": 10, "area": 2304},
    {"image_id": 10, "area": 2304.25},
    {"image_id": 20, "area": 4092}, {"image_id": 20, "area": 4096}, {"image_id": 20, "area": 36864},
    {"image_id": 20, "area": 36868},
    {"image_id": 30, "area": 1023}, {"image_id": 30, "area": 1024}, {"image_id": 30, "area": 9216},
    {"image_id": 30, "area": 9217}
  ]})";

TEST_F(CocoTargetsTest, RescalesEachAreaByItsImagesPixelCountAtTheThresholds) {
  Result<CocoMatch> m = Match(kMixedSizes);
  ASSERT_OK(m.status());
  EXPECT_EQ(m->annotations, 12);
  EXPECT_DOUBLE_EQ(m->objects_per_image.mean, 4);
  EXPECT_DOUBLE_EQ(m->objects_per_image.ci95, 0);
  EXPECT_DOUBLE_EQ(m->small.mean, 3.0 / 12);
  EXPECT_DOUBLE_EQ(m->medium.mean, 6.0 / 12);
  EXPECT_DOUBLE_EQ(m->large.mean, 3.0 / 12);
}

TEST_F(CocoTargetsTest, CountsAtTheResolutionOfTheOptionsRoundingToWholePixels) {
  // At 320x240 a 640x480 image's areas count a quarter: 4092 -> 1023, 4094 -> 1023.5 -> 1024
  // (rounded as MetricsAccumulator rounds scaled areas), 36864 -> 9216, 36866 -> 9216.5 -> 9217.
  CocoMatchOptions options;
  options.width = 320;
  options.height = 240;
  Result<CocoMatch> m = Match(R"({"images": [{"id": 1, "width": 640, "height": 480}],
    "annotations": [{"image_id": 1, "area": 4092}, {"image_id": 1, "area": 4094}, {"image_id": 1, "area": 36864},
                    {"image_id": 1, "area": 36866}]})",
                              options);
  ASSERT_OK(m.status());
  EXPECT_EQ(m->width, 320);
  EXPECT_DOUBLE_EQ(m->small.mean, 0.25);
  EXPECT_DOUBLE_EQ(m->medium.mean, 0.5);
  EXPECT_DOUBLE_EQ(m->large.mean, 0.25);
}

TEST_F(CocoTargetsTest, AnnotationsBeforeImagesGiveTheSameTargets) {
  Result<CocoMatch> images_first = Match(kMixedSizes);
  ASSERT_OK(images_first.status());
  Result<CocoMatch> annotations_first = Match(R"({
  "annotations": [
    {"image_id": 10, "area": 255.75}, {"image_id": 10, "area": 256}, {"image_id": 10, "area": 2304},
    {"image_id": 10, "area": 2304.25},
    {"image_id": 20, "area": 4092}, {"image_id": 20, "area": 4096}, {"image_id": 20, "area": 36864},
    {"image_id": 20, "area": 36868},
    {"image_id": 30, "area": 1023}, {"image_id": 30, "area": 1024}, {"image_id": 30, "area": 9216},
    {"image_id": 30, "area": 9217}
  ],
  "images": [{"id": 30, "width": 640, "height": 480}, {"id": 20, "width": 1280, "height": 960},
             {"id": 10, "width": 320, "height": 240}, {"id": 40, "width": 640, "height": 480}]})");
  ASSERT_OK(annotations_first.status());
  EXPECT_EQ(annotations_first->images, 4);
  EXPECT_EQ(annotations_first->empty_images, 1);
  EXPECT_DOUBLE_EQ(annotations_first->objects_per_image.mean, 3);
  for (Metric metric : {Metric::kSmall, Metric::kMedium, Metric::kLarge}) {
    EXPECT_DOUBLE_EQ(annotations_first->targets[static_cast<int>(metric) - 1].value,
                     images_first->targets[static_cast<int>(metric) - 1].value)
        << MetricName(metric);
  }
}

TEST_F(CocoTargetsTest, TextInMemoryGivesWhatTheFileGives) {
  Result<CocoMatch> file = Match(kBasic);
  Result<CocoMatch> text = TargetsFromCocoText(kBasic, "memory.json");
  ASSERT_OK(file.status());
  ASSERT_OK(text.status());
  EXPECT_EQ(text->ToJson(), file->ToJson());
  Result<CocoMatch> bad = TargetsFromCocoText(R"({"images": [], "annotations": [{"image_id": 1}]})", "memory.json");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().message(), "memory.json: /annotations/0: an annotation without \"area\" (needed unless iscrowd is 1)");
}

TEST_F(CocoTargetsTest, ToJsonHasTheTargetsAndTheirSampleSizes) {
  Result<CocoMatch> m = Match(kBasic);
  ASSERT_OK(m.status());
  const nlohmann::json j = m->ToJson();
  EXPECT_EQ(j["resolution"], nlohmann::json::array({640, 480}));
  EXPECT_EQ(j["images"], 3);
  EXPECT_EQ(j["images_counted"], 3);
  EXPECT_EQ(j["empty_images"], 1);
  EXPECT_EQ(j["annotations"], 4);
  EXPECT_EQ(j["crowd_skipped"], 1);
  ASSERT_EQ(j["targets"].size(), 4u);
  EXPECT_EQ(j["targets"][0]["metric"], "objects_per_image");
  EXPECT_EQ(j["targets"][0]["n"], 3);
  EXPECT_EQ(j["targets"][0]["tolerance"], 0.25);
  EXPECT_DOUBLE_EQ(j["targets"][0]["ci95"].get<double>(), m->objects_per_image.ci95);
  EXPECT_EQ(j["targets"][3]["metric"], "large");
  EXPECT_EQ(j["targets"][3]["n"], 4);
  EXPECT_EQ(j["targets"][3]["value"], 0.25);
}

// ---------------------------------------------------------------------------------------------
// Bad files

TEST_F(CocoTargetsTest, AMissingFileIsNotFound) {
  const std::filesystem::path path = dir_.path() / "absent.json";
  Result<CocoMatch> m = TargetsFromCoco(path);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().code(), StatusCode::kNotFound);
  EXPECT_EQ(m.status().message(), path.string() + ": no such file");
}

TEST_F(CocoTargetsTest, ADirectoryIsAnIoError) {
  Result<CocoMatch> m = TargetsFromCoco(dir_.path());
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().code(), StatusCode::kIoError);
  EXPECT_EQ(m.status().message(), dir_.path().string() + ": not a regular file");
}

TEST_F(CocoTargetsTest, NotJsonIsAParseErrorWithLineColumnAndByteOffset) {
  const std::string message = ErrorOf("{\n  \"images\": [\n    x\n", StatusCode::kParseError);
  EXPECT_THAT(message, HasSubstr("coco.json:3:5: not JSON: syntax error while parsing value - invalid literal"));
  EXPECT_THAT(message, HasSubstr("(byte offset 20)"));
  EXPECT_THAT(ErrorOf(R"({"images": [1e400]})", StatusCode::kParseError),
              HasSubstr("coco.json:1:17: not JSON: number overflow parsing '1e400'"));
  EXPECT_THAT(ErrorOf("", StatusCode::kParseError), HasSubstr("coco.json:1:1: not JSON: "));
  EXPECT_THAT(ErrorOf(R"({"images": [], "annotations": []} x)", StatusCode::kParseError),
              HasSubstr("(byte offset 34)"));
}

TEST_F(CocoTargetsTest, JsonThatIsNotCocoInstancesNamesWhatIsMissing) {
  EXPECT_THAT(ErrorOf("[1, 2]", StatusCode::kParseError),
              HasSubstr("coco.json: not a COCO instances file: the top level is an array, not an object"));
  EXPECT_THAT(ErrorOf(R"({"images": [], "categories": []})", StatusCode::kParseError),
              HasSubstr("coco.json: not a COCO instances file: no \"annotations\" array at the top level"));
  EXPECT_THAT(ErrorOf(R"({"annotations": [{"image_id": 1, "area": 1}]})", StatusCode::kParseError),
              HasSubstr("coco.json: not a COCO instances file: no \"images\" array at the top level"));
  EXPECT_THAT(ErrorOf(R"({"images": {"id": 1}, "annotations": []})", StatusCode::kParseError),
              HasSubstr("coco.json: /images: not a COCO instances file: must be an array, not an object"));
  EXPECT_THAT(ErrorOf(R"({"images": [], "annotations": null})", StatusCode::kParseError),
              HasSubstr("/annotations: not a COCO instances file: must be an array, not null"));
  EXPECT_THAT(ErrorOf(R"({"images": [], "images": [], "annotations": []})", StatusCode::kParseError),
              HasSubstr("coco.json: /images: given twice"));
  EXPECT_THAT(ErrorOf(R"({"images": [{"id": 1, "width": 1, "height": 1}, 5], "annotations": []})",
                      StatusCode::kParseError),
              HasSubstr("coco.json: /images/1: an image must be an object, not 5"));
  EXPECT_THAT(ErrorOf(R"({"images": [], "annotations": [[]]})", StatusCode::kParseError),
              HasSubstr("coco.json: /annotations/0: an annotation must be an object, not an array"));
}

TEST_F(CocoTargetsTest, NoAnnotationsOrOnlyCrowdIsAnError) {
  EXPECT_THAT(ErrorOf(R"({"images": [{"id": 1, "width": 1, "height": 1}], "annotations": []})", StatusCode::kCorrupt),
              HasSubstr("coco.json: /annotations: no annotations"));
  EXPECT_THAT(ErrorOf(R"({"images": [{"id": 1, "width": 1, "height": 1}],
                          "annotations": [{"image_id": 1, "area": 3, "iscrowd": 1}]})",
                      StatusCode::kCorrupt),
              HasSubstr("coco.json: /annotations: all 1 annotations are crowd"));
}

TEST_F(CocoTargetsTest, ImagesNeedAnIdAndAPositiveSize) {
  EXPECT_THAT(ErrorOf(R"({"images": [{"id": 1, "width": 2, "height": 2}, {"id": 2, "height": 480}],
                          "annotations": [{"image_id": 1, "area": 1}]})",
                      StatusCode::kParseError),
              HasSubstr("coco.json: /images/1: an image without \"width\" (images need id, width and height)"));
  EXPECT_THAT(ErrorOf(R"({"images": [{"width": 2, "height": 2}], "annotations": []})", StatusCode::kParseError),
              HasSubstr("/images/0: an image without \"id\""));
  EXPECT_THAT(ErrorOf(R"({"images": [{"id": 1, "width": 0, "height": 2}], "annotations": []})",
                      StatusCode::kParseError),
              HasSubstr("coco.json: /images/0/width: must be an integer from 1 to 2147483647, not 0"));
  EXPECT_THAT(ErrorOf(R"({"images": [{"id": 1, "width": 2, "height": "480"}], "annotations": []})",
                      StatusCode::kParseError),
              HasSubstr("/images/0/height: must be an integer from 1 to 2147483647, not a string"));
  EXPECT_THAT(ErrorOf(R"({"images": [{"id": 1.5, "width": 2, "height": 2}], "annotations": []})",
                      StatusCode::kParseError),
              HasSubstr("/images/0/id: must be an integer, not 1.5"));
  EXPECT_THAT(ErrorOf(R"({"images": [{"id": 1, "width": 2, "width": 3, "height": 2}], "annotations": []})",
                      StatusCode::kParseError),
              HasSubstr("/images/0/width: given twice"));
  // A whole number written as a float is an integer.
  EXPECT_OK(Match(R"({"images": [{"id": 1, "width": 640.0, "height": 480}], "annotations": [{"image_id": 1.0, "area": 1}]})")
                .status());
}

TEST_F(CocoTargetsTest, AreasMustBeNumbersAtLeastZero) {
  // Seventeen good annotations, then the bad one at index 17.
  std::string good;
  for (int i = 0; i < 17; ++i) good += R"({"image_id": 1, "area": 1, "segmentation": [[1, 2, 3, 4, 5, 6]]}, )";
  auto file = [&](std::string_view bad) {
    return R"({"images": [{"id": 1, "width": 640, "height": 480}], "annotations": [)" + good + std::string(bad) + "]}";
  };
  EXPECT_THAT(ErrorOf(file(R"({"image_id": 1, "area": "12"})"), StatusCode::kParseError),
              HasSubstr("coco.json: /annotations/17/area: must be a number >= 0, not a string"));
  EXPECT_THAT(ErrorOf(file(R"({"image_id": 1, "area": -1})"), StatusCode::kParseError),
              HasSubstr("coco.json: /annotations/17/area: must be a number >= 0, not -1"));
  EXPECT_THAT(ErrorOf(file(R"({"image_id": 1, "area": [3]})"), StatusCode::kParseError),
              HasSubstr("coco.json: /annotations/17/area: must be a number >= 0, not an array"));
  EXPECT_THAT(ErrorOf(file(R"({"image_id": 1, "bbox": [0, 0, 1, 1]})"), StatusCode::kParseError),
              HasSubstr("coco.json: /annotations/17: an annotation without \"area\" (needed unless iscrowd is 1)"));
  EXPECT_THAT(ErrorOf(file(R"({"area": 3})"), StatusCode::kParseError),
              HasSubstr("coco.json: /annotations/17: an annotation without \"image_id\""));
  EXPECT_THAT(ErrorOf(file(R"({"image_id": 1, "area": 3, "iscrowd": 2})"), StatusCode::kParseError),
              HasSubstr("coco.json: /annotations/17/iscrowd: must be 0, 1, true or false, not 2"));
  EXPECT_THAT(ErrorOf(file(R"({"image_id": 1, "area": 3, "area": 4})"), StatusCode::kParseError),
              HasSubstr("coco.json: /annotations/17/area: given twice"));
}

TEST_F(CocoTargetsTest, AnImageIdNotAmongTheImagesIsNamed) {
  // Read after the images and before them.
  EXPECT_THAT(ErrorOf(R"({"images": [{"id": 1, "width": 2, "height": 2}],
                          "annotations": [{"image_id": 1, "area": 1}, {"image_id": 99, "area": 1}]})",
                      StatusCode::kCorrupt),
              HasSubstr("coco.json: /annotations/1/image_id: image 99 is not among the images"));
  EXPECT_THAT(ErrorOf(R"({"annotations": [{"image_id": 1, "area": 1}, {"image_id": 1, "area": 1},
                                          {"image_id": -4, "iscrowd": 1}],
                          "images": [{"id": 1, "width": 2, "height": 2}]})",
                      StatusCode::kCorrupt),
              HasSubstr("coco.json: /annotations/2/image_id: image -4 is not among the images"));
}

TEST_F(CocoTargetsTest, TwoImagesWithOneIdAreAnError) {
  EXPECT_THAT(ErrorOf(R"({"images": [{"id": 3, "width": 2, "height": 2}, {"id": 1, "width": 2, "height": 2},
                                     {"id": 3, "width": 4, "height": 4}], "annotations": []})",
                      StatusCode::kCorrupt),
              HasSubstr("coco.json: /images/2/id: image id 3 is also that of /images/0"));
}

TEST_F(CocoTargetsTest, LimitsAreLimitExceededErrors) {
  CocoMatchOptions options;
  options.max_images = 2;
  EXPECT_THAT(ErrorOf(kBasic, StatusCode::kLimitExceeded, options),
              HasSubstr("coco.json: /images/2: more than the limit of 2 images"));
  options = {};
  options.max_annotations = 3;
  EXPECT_THAT(ErrorOf(kBasic, StatusCode::kLimitExceeded, options),
              HasSubstr("coco.json: /annotations/3: more than the limit of 3 annotations"));
  options = {};
  options.max_file_bytes = 100;
  EXPECT_THAT(ErrorOf(kBasic, StatusCode::kLimitExceeded, options),
              HasSubstr(fmt::format("coco.json: {} bytes is more than the limit of 100 bytes", kBasic.size())));
  // Nesting inside a value that is not read, under a key the pointer escapes.
  options = {};
  options.max_depth = 4;
  EXPECT_THAT(ErrorOf(R"({"images": [], "a/b~": [[[[1]]]], "annotations": []})", StatusCode::kLimitExceeded, options),
              HasSubstr("coco.json: /a~1b~0: nested deeper than the limit of 4 levels"));
  // A string longer than max_token_bytes stops the read at the next chunk of 1 MiB.
  options = {};
  options.max_token_bytes = 1000;
  const std::string long_name(std::size_t{3} << 20, 'x');
  EXPECT_THAT(ErrorOf(R"({"info": ")" + long_name + R"("})", StatusCode::kLimitExceeded, options),
              HasSubstr("coco.json: byte 7: more than the limit of 1000 bytes before the next value ends"));
}

TEST_F(CocoTargetsTest, TheResolutionMustBePositive) {
  CocoMatchOptions options;
  options.width = 0;
  Result<CocoMatch> m = Match(kBasic, options);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace solid::optimizer
