#include <fmt/format.h>

#include <map>

#include "commands.h"
#include "exit_codes.h"
#include "progress.h"
#include "solid/export/coco.h"
#include "solid/export/report.h"

namespace solid::cli {

Command AddExport(CLI::App& app) {
  auto* cmd = app.add_subcommand("export", "Export a dataset to another format.");
  cmd->require_subcommand(1);
  auto* coco = cmd->add_subcommand(
      "coco", "COCO instances: OUT_DIR/annotations.json (compressed RLE masks) and OUT_DIR/images/.");
  auto o = std::make_shared<exporters::CocoExportOptions>();
  coco->add_option("dataset", o->dataset, "Dataset directory")->required();
  coco->add_option("out_dir", o->out_dir, "Output directory")->required();
  coco->add_option("--masks", o->masks,
                   "Mask of segmentation/area/bbox: visible, full (amodal, keeps hidden objects), or both "
                   "(visible, plus full_segmentation)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, exporters::CocoMasks>{
          {"visible", exporters::CocoMasks::kVisible},
          {"full", exporters::CocoMasks::kFull},
          {"both", exporters::CocoMasks::kBoth}}))
      ->default_str("both");
  coco->add_option("--categories", o->categories, "object: one category; model: one per model")
      ->transform(CLI::CheckedTransformer(std::map<std::string, exporters::CocoCategories>{
          {"object", exporters::CocoCategories::kObject}, {"model", exporters::CocoCategories::kModel}}))
      ->default_str("object");
  coco->add_option("--images", o->images, "copy: write the image files; link: hard-link them from --link-from")
      ->transform(CLI::CheckedTransformer(std::map<std::string, exporters::CocoImages>{
          {"copy", exporters::CocoImages::kCopy}, {"link", exporters::CocoImages::kLink}}))
      ->default_str("copy");
  coco->add_option("--link-from", o->link_from, "An earlier COCO export of the same dataset, for --images link");
  return [o]() -> int {
    Result<exporters::CocoExportReport> result = [&] {
      ProgressLine line("export", "images");
      o->progress = line.Callback();
      return exporters::ExportCoco(*o);
    }();
    SOLID_ASSIGN_OR_RETURN_EXIT(exporters::CocoExportReport r, std::move(result));
    fmt::print("{}: {} images, {} annotations in {} categor{} ({} instances with an empty mask skipped), "
               "{:.1f} MB of images, {:.2f} s\n",
               (o->out_dir / "annotations.json").string(), r.images, r.annotations, r.categories,
               r.categories == 1 ? "y" : "ies", r.skipped_invisible, r.image_bytes / 1e6, r.seconds);
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
  cmd->add_option("--samples", o->samples, "Sample images shown")->capture_default_str()->check(CLI::Range(0, 1000));
  cmd->add_option("--query-models", o->query_models, "Query views shown per sample")
      ->capture_default_str()
      ->check(CLI::Range(0, 64));
  return [o]() -> int {
    SOLID_ASSIGN_OR_RETURN_EXIT(exporters::ReportSummary r, exporters::WriteReport(*o));
    fmt::print("{}: {} images, {} instances, {} samples, {}, {:.1f} MB\n", o->out.string(), r.images, r.instances,
               r.samples, r.target_row.empty() ? "no targets" : "targets of " + r.target_row, r.bytes / 1e6);
    return kExitOk;
  };
}

}  // namespace solid::cli
