#include <fmt/format.h>


#include "commands.h"
#include "exit_codes.h"
#include "progress.h"
#include "signals.h"
#include "solid/export/coco.h"
#include "solid/export/report.h"
#include "solid/export/zarr.h"

namespace solid::cli {
namespace {

// Checked against their lists by CLI11 before the command runs.
struct CocoFlags {
  std::string masks = "both", categories = "object", images = "copy";
};

Command AddZarr(CLI::App* cmd) {
  auto* zarr = cmd->add_subcommand(
      "zarr", "The reference SOLID renderer's zarr v2 store, for SOLID's own pretraining reader: OUT_DIR (new, or an "
              "empty directory) with images, bboxes, masks, statistics and queries.");
  auto o = std::make_shared<exporters::ZarrExportOptions>();
  zarr->add_option("dataset", o->dataset, "Dataset directory")->required();
  zarr->add_option("out_dir", o->out_dir, "The store to create: must not exist, or be an empty directory")->required();
  zarr->add_option("--chunk", o->chunk, "Images per chunk (the queries' chunk is chunk x chunk)")
      ->capture_default_str()
      ->check(CLI::Range(1, exporters::kMaxZarrChunk));
  zarr->add_flag("--drop-viewless-models", o->drop_viewless_models,
                 "Leave out the models without query views, and their instances, renumbering the classes "
                 "(solid_export.json lists them); without it such a dataset is refused");
  return [o]() -> int {
    o->cancel = InstallStopHandlers();
    Result<exporters::ZarrExportReport> result = [&] {
      ProgressLine line("export", "images");
      o->progress = line.Callback();
      return exporters::ExportZarr(*o);
    }();
    if (result.status().code() == StatusCode::kCancelled) {
      fmt::print(stderr, "solid: stopped by {}: {}\nsolid: to export, run the same command again:\n  {}\n",
                 StopSignalName(), result.status().message(), CommandLine());
      return StopExitCode();
    }
    if (!result.ok()) return Fail(result.status(), {{"chunk", "--chunk"}});
    fmt::print("{}", result->ToText());
    return kExitOk;
  };
}

}  // namespace

Command AddExport(CLI::App& app) {
  auto* cmd = app.add_subcommand("export", "Export a dataset to another format.");
  cmd->require_subcommand(1);
  auto* coco = cmd->add_subcommand(
      "coco", "COCO instances: OUT_DIR/annotations.json (compressed RLE masks) and OUT_DIR/images/.");
  auto o = std::make_shared<exporters::CocoExportOptions>();
  auto f = std::make_shared<CocoFlags>();
  coco->add_option("dataset", o->dataset, "Dataset directory")->required();
  coco->add_option("out_dir", o->out_dir, "Output directory")->required();
  coco->add_option("--masks", f->masks,
                   "Mask of segmentation/area/bbox: visible, full (amodal, keeps hidden objects), or both "
                   "(visible, plus full_segmentation)")
      ->check(CLI::IsMember({"visible", "full", "both"}))
      ->capture_default_str();
  coco->add_option("--categories", f->categories, "object: one category; model: one per model")
      ->check(CLI::IsMember({"object", "model"}))
      ->capture_default_str();
  coco->add_option("--images", f->images, "copy: write the image files; link: hard-link them from --link-from")
      ->check(CLI::IsMember({"copy", "link"}))
      ->capture_default_str();
  coco->add_option("--link-from", o->link_from, "An earlier COCO export of the same dataset, for --images link");
  const Command zarr = AddZarr(cmd);
  return [coco, o, f, zarr]() -> int {
    if (!coco->parsed()) return zarr();
    o->masks = f->masks == "visible" ? exporters::CocoMasks::kVisible
               : f->masks == "full"  ? exporters::CocoMasks::kFull
                                     : exporters::CocoMasks::kBoth;
    o->categories = f->categories == "model" ? exporters::CocoCategories::kModel : exporters::CocoCategories::kObject;
    o->images = f->images == "link" ? exporters::CocoImages::kLink : exporters::CocoImages::kCopy;
    o->cancel = InstallStopHandlers();
    Result<exporters::CocoExportReport> result = [&] {
      ProgressLine line("export", "images");
      o->progress = line.Callback();
      return exporters::ExportCoco(*o);
    }();
    if (result.status().code() == StatusCode::kCancelled) {
      fmt::print(stderr, "solid: stopped by {}: {}; the image files written are complete\n"
                         "solid: to finish, run the same command again (it writes every file anew):\n  {}\n",
                 StopSignalName(), result.status().message(), CommandLine());
      return StopExitCode();
    }
    if (!result.ok()) return Fail(result.status(), {{"link_from", "--link-from"}});
    fmt::print("{}", result->ToText());
    return kExitOk;
  };
}

Command AddReport(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "report", "One self-contained HTML page: manifest, proxy metrics against targets, histograms, viewpoints, "
                "sample images with mask overlays and query views.");
  auto o = std::make_shared<exporters::ReportOptions>();
  cmd->add_option("dataset", o->dataset, "Dataset directory")->required();
  cmd->add_option("out", o->out, "The .html file to write")->required();
  cmd->add_option("--target-row", o->target_row,
                  "Compare with this Table-1 row (a preset name), or none; default: the preset the dataset's "
                  "params equal, if any");
  cmd->add_option("--samples", o->samples, "Sample images shown")->capture_default_str()->check(CLI::Range(0, exporters::kMaxReportSamples));
  cmd->add_option("--query-models", o->query_models, "Query views shown per sample")
      ->capture_default_str()
      ->check(CLI::Range(0, exporters::kMaxReportQueryModels));
  return [o]() -> int {
    Result<exporters::ReportSummary> report = exporters::WriteReport(*o);
    if (!report.ok()) {
      return Fail(report.status(),
                  {{"target_row", "--target-row"}, {"samples", "--samples"}, {"query_models", "--query-models"}});
    }
    fmt::print("{}", report->ToText());
    return kExitOk;
  };
}

}  // namespace solid::cli
