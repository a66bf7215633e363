// `solid optimize` and `solid metrics` as library calls (fit.h, dataset_metrics.h): option
// errors name fields, a second fit with nothing changed is reused, and the CLI names its flags.
#include "solid/optimizer/fit.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <tuple>

#include "fixtures/run_command.h"
#include "formats/test_util.h"
#include "render/test_assets.h"
#include "solid/formats/files.h"
#include "solid/optimizer/dataset_metrics.h"
#include "solid/render/params.h"

namespace solid::optimizer {
namespace {

using ::testing::HasSubstr;

// random-placement at 80x60, scale classes as at 640x480, searched on 20 layouts at the output
// resolution and confirmed on 40: a fit of a few seconds.
FitOptions SmallFitOptions(const std::filesystem::path& dir) {
  render::LayoutParams start = render::LoadPreset("random-placement").value();
  std::tie(start.scale_width, start.scale_height) = render::ScaleClassResolution(start);
  start.width = 80;
  start.height = 60;
  const std::string text = render::ParamsToJson(start).dump(2);
  EXPECT_OK(files::WriteFileAtomically(dir / "start.json", {reinterpret_cast<const uint8_t*>(text.data()), text.size()}));
  FitOptions o;
  o.params = dir / "start.json";
  o.assets = render::testing::ProceduralAssetsDir();
  o.out = {dir / "fitted.json", dir / "trace.csv"};
  o.targets.target_count = 6;
  o.targets.tol_count = 1;
  o.search.layouts = 20;
  o.search.eval_width = 80;
  o.search.eval_height = 60;
  o.search.confirm_layouts = 40;
  o.search.max_evaluations = 6;
  o.search.max_rounds = 1;
  o.search.jobs = 2;
  return o;
}

TEST(Fit, OptionErrorsNameTheirField) {
  solid::testing::TempDir dir;
  FitOptions o = SmallFitOptions(dir.path());
  o.targets.target_scale = {0.3, 0.7};
  Result<FitReport> r = Fit(o);
  EXPECT_EQ(r.status().option(), "target_scale") << r.status().message();

  o = SmallFitOptions(dir.path());
  o.targets = {};
  EXPECT_EQ(Fit(o).status().option(), "targets");

  o = SmallFitOptions(dir.path());
  o.targets.target_row = "no-such-row";
  r = Fit(o);
  EXPECT_EQ(r.status().option(), "target_row");
  EXPECT_THAT(r.status().message(), HasSubstr("the rows are random-placement"));

  o = SmallFitOptions(dir.path());
  o.search.algorithm = "simplex";
  EXPECT_EQ(Fit(o).status().option(), "algorithm");

  o = SmallFitOptions(dir.path());
  o.preset = "occlusion";
  EXPECT_EQ(Fit(o).status().option(), "preset") << "a preset and a params file";
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "fitted.json")) << "nothing written on an option error";
}

TEST(Fit, ASecondFitOfTheSameInputsIsReusedAndARefitSearchesAgain) {
  solid::testing::TempDir dir;
  FitOptions o = SmallFitOptions(dir.path());
  Result<FitReport> first = Fit(o);
  ASSERT_OK(first.status());
  EXPECT_FALSE(first->reused);
  ASSERT_TRUE(first->optimized.has_value());
  ASSERT_TRUE(std::filesystem::exists(o.out.params));
  ASSERT_TRUE(std::filesystem::exists(o.out.trace));

  Result<FitReport> second = Fit(o);
  ASSERT_OK(second.status());
  EXPECT_TRUE(second->reused);
  EXPECT_FALSE(second->optimized.has_value());
  EXPECT_EQ(second->summary, first->summary);
  EXPECT_EQ(second->all_met, first->all_met);

  o.targets.target_count = 7;
  Result<FitReport> other = Fit(o);
  ASSERT_OK(other.status());
  EXPECT_FALSE(other->reused) << "another target";

  o.refit = true;
  Result<FitReport> refit = Fit(o);
  ASSERT_OK(refit.status());
  EXPECT_FALSE(refit->reused);
}

TEST(MeasureDataset, OptionErrorsNameTheirField) {
  MetricsOptions o;
  o.dataset = "/nonexistent";
  o.compare = "params.json";
  EXPECT_EQ(MeasureDataset(o).status().option(), "assets");
  o.target_row = "more-objects";
  EXPECT_EQ(MeasureDataset(o).status().option(), "target_row");
  o = {};
  o.dataset = "/nonexistent";
  o.layouts = 0;
  EXPECT_EQ(MeasureDataset(o).status().option(), "layouts");
}

// The CLI prints the flag that sets a field a library call refused, and exits 2.
TEST(FitCli, OptionErrorsNameTheFlag) {
  const fixtures::CommandRun optimize = fixtures::RunCommand(
      std::string(SOLID_CLI_BINARY) + " optimize --preset random-placement --assets " +
      fixtures::ShellQuote(render::testing::ProceduralAssetsDir().string()) + " --out /nonexistent/p.json --target-scale 0.3,0.7");
  EXPECT_EQ(optimize.exit_status, 2) << optimize.output;
  EXPECT_THAT(optimize.output, HasSubstr("--target-scale: expected three shares SMALL,MEDIUM,LARGE"));
  const fixtures::CommandRun metrics =
      fixtures::RunCommand(std::string(SOLID_CLI_BINARY) + " metrics /nonexistent --compare p.json");
  EXPECT_EQ(metrics.exit_status, 2) << metrics.output;
  EXPECT_THAT(metrics.output, HasSubstr("--assets: comparing with a params file"));
}

}  // namespace
}  // namespace solid::optimizer
