// WriteReport: the page's content from the dataset, and the page as a browser shows it.
#include "solid/export/report.h"

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>

#include "export/export_test_util.h"
#include "fixtures/layered_dataset.h"
#include "fixtures/run_command.h"
#include "formats/test_util.h"
#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"

namespace solid::exporters {
namespace {

namespace fs = std::filesystem;
using solid::testing::TempDir;

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

size_t Count(const std::string& text, std::string_view needle) {
  size_t n = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++n;
  return n;
}

struct Report {
  TempDir dir;
  fs::path dataset = dir.path() / "dataset", page = dir.path() / "report.html";
  ReportSummary summary;
  std::string html;

  explicit Report(ReportOptions options) {
    fixtures::LayeredDatasetOptions layered;
    layered.images = 10;
    EXPECT_OK(fixtures::WriteLayeredDataset(dataset, layered));
    options.dataset = dataset;
    options.out = page;
    Result<ReportSummary> r = WriteReport(options);
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    if (r.ok()) summary = *r;
    html = ReadText(page);
  }
};

TEST(Report, ShowsPlotsAndSamplesWithDecodableImages) {
  ReportOptions o;
  o.samples = 4;
  Report r(o);
  EXPECT_EQ(r.summary.images, 10);
  EXPECT_EQ(r.summary.samples, 4);
  EXPECT_EQ(r.summary.target_row, "") << "the fixture's params are no preset";
  EXPECT_EQ(Count(r.html, "<svg class=\"plot\""), 4u) << "three histograms and the viewpoint map";
  EXPECT_EQ(Count(r.html, "class=\"card\""), 4u);
  EXPECT_EQ(Count(r.html, "class=\"sample\""), 8u) << "visible and full overlays per sample";
  EXPECT_GE(Count(r.html, "class=\"query\""), 4u);
  EXPECT_EQ(r.html.find("http"), std::string::npos) << "the page must need no network";

  // Every embedded image decodes.
  const std::regex uri("data:image/(png|jpeg|webp);base64,([A-Za-z0-9+/=]+)\"");
  int images = 0;
  for (auto it = std::sregex_iterator(r.html.begin(), r.html.end(), uri); it != std::sregex_iterator(); ++it, ++images) {
    Result<ImageFormat> format = ParseImageFormat((*it)[1].str());
    ASSERT_TRUE(format.ok());
    const std::vector<uint8_t> bytes = testing::DecodeBase64((*it)[2].str());
    Result<Image8> decoded = DecodeImage(bytes, *format);
    EXPECT_TRUE(decoded.ok()) << "image " << images << ": " << decoded.status().ToString();
  }
  EXPECT_GE(images, 12);
}

TEST(Report, ComparesWithATableRow) {
  ReportOptions o;
  o.samples = 0;
  o.target_row = "more-objects";
  Report r(o);
  EXPECT_EQ(r.summary.target_row, "more-objects");
  EXPECT_NE(r.html.find("Table-1 row <b>more-objects</b>"), std::string::npos);
  EXPECT_EQ(Count(r.html, "class=\"ok\"") + Count(r.html, "class=\"bad\""), 5u) << "one verdict per metric";

  TempDir dir;
  fixtures::LayeredDatasetOptions layered;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path() / "d", layered));
  o.dataset = dir.path() / "d";
  o.out = dir.path() / "r.html";
  o.target_row = "no-such-row";
  EXPECT_EQ(WriteReport(o).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(WriteReport(o).status().option(), "target_row");
  EXPECT_FALSE(fs::exists(o.out));
}

TEST(Report, OptionErrorsNameTheirFieldAndTheCliTheFlag) {
  TempDir dir;
  fixtures::LayeredDatasetOptions layered;
  ASSERT_OK(fixtures::WriteLayeredDataset(dir.path() / "d", layered));
  ReportOptions o;
  o.dataset = dir.path() / "d";
  o.out = dir.path() / "r.html";
  o.samples = -1;
  EXPECT_EQ(WriteReport(o).status().option(), "samples");
  o.samples = 0;
  o.query_models = kMaxReportQueryModels + 1;
  EXPECT_EQ(WriteReport(o).status().option(), "query_models");
  o.query_models = 0;
  o.out.clear();
  EXPECT_EQ(WriteReport(o).status().option(), "out");
  EXPECT_FALSE(fs::exists(dir.path() / "r.html"));

  const fixtures::CommandRun run = fixtures::RunCommand(
      std::string(SOLID_CLI_BINARY) + " report " + fixtures::ShellQuote((dir.path() / "d").string()) + " " +
      fixtures::ShellQuote((dir.path() / "r.html").string()) + " --target-row no-such-row");
  EXPECT_EQ(run.exit_status, 3) << run.output;
  EXPECT_NE(run.output.find("solid: --target-row: unknown Table-1 row \"no-such-row\""), std::string::npos)
      << run.output;
  EXPECT_FALSE(fs::exists(dir.path() / "r.html"));
}

// Headless Chromium opens the page: it loads without console errors, its DOM holds the
// plots and images, and the screenshot is a drawn page.
TEST(Report, ChromiumShowsThePage) {
  if (fixtures::RunCommand("command -v chromium >/dev/null").exit_status != 0) {
    GTEST_SKIP() << "chromium is not installed (scripts/install-deps.sh installs it)";
  }
  ReportOptions o;
  o.samples = 3;
  Report r(o);
  const fs::path dom = r.dir.path() / "dom.html", log = r.dir.path() / "chromium.log",
                 shot = r.dir.path() / "shot.png";
  const std::string chromium = "chromium --headless --disable-gpu --no-sandbox --user-data-dir=" +
                               fixtures::ShellQuote((r.dir.path() / "profile").string()) + " ";
  const std::string url = fixtures::ShellQuote("file://" + r.page.string());
  const fixtures::CommandRun dump = fixtures::RunCommand(chromium + "--enable-logging=stderr --v=0 --dump-dom " + url +
                                                         " >" + fixtures::ShellQuote(dom.string()) + " 2>" +
                                                         fixtures::ShellQuote(log.string()));
  ASSERT_EQ(dump.exit_status, 0) << ReadText(log);
  const std::string page = ReadText(dom), messages = ReadText(log);
  // The page has no script: any console message is a load error.
  EXPECT_EQ(messages.find(":CONSOLE("), std::string::npos) << messages;
  EXPECT_EQ(messages.find("ERR_"), std::string::npos) << messages;
  EXPECT_EQ(Count(page, "<svg class=\"plot\""), 4u);
  EXPECT_EQ(Count(page, "class=\"card\""), 3u);
  EXPECT_EQ(Count(page, "<img "), Count(r.html, "<img "));

  const fixtures::CommandRun capture = fixtures::RunCommand(
      chromium + "--hide-scrollbars --window-size=1200,2000 --screenshot=" + fixtures::ShellQuote(shot.string()) + " " +
      url + " 2>&1");
  ASSERT_EQ(capture.exit_status, 0) << capture.output;
  Result<std::vector<uint8_t>> png = files::ReadFile(shot, 1 << 26);
  ASSERT_TRUE(png.ok()) << png.status().ToString();
  Result<Image8> image = DecodeImage(*png, ImageFormat::kPng);
  ASSERT_TRUE(image.ok()) << image.status().ToString();
  EXPECT_EQ(image->width, 1200u);
  // The header band is dark and the page below it light: something was laid out and drawn.
  auto luma = [&](uint32_t x, uint32_t y) {
    const uint8_t* p = &image->pixels[(static_cast<size_t>(y) * image->width + x) * image->channels];
    return (p[0] + p[1] + p[2]) / 3;
  };
  EXPECT_LT(luma(600, 10), 80);
  EXPECT_GT(luma(5, 300), 200);
}

}  // namespace
}  // namespace solid::exporters
