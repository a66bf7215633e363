#include <fmt/format.h>

#include <iostream>

#include "commands.h"
#include "exit_codes.h"
#include "progress.h"
#include "signals.h"
#include "solid/convert/convert.h"

namespace solid::cli {
namespace {

struct ConvertFlags {
  std::string root, out;
  int jobs = 0;
  int64_t limit = -1;
  std::vector<std::string> synsets, families;
  int version = 0;
  bool retry_failed = false, all_objects = false, texture_library = false, verbose = false;
  gltf::DracoOptions draco;
  convert::ProceduralSet procedural;
  std::string gltf_layout = "flat", obj_layout = "flat";  // convert gltf / convert obj
};

void AddCommonFlags(CLI::App* cmd, ConvertFlags* f) {
  AddJobsOption(cmd, &f->jobs, "Parallel conversions");
  cmd->add_option("--limit", f->limit, "Convert at most N assets (after filters)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--position-bits", f->draco.position_bits, "Draco position quantization bits")
      ->capture_default_str()->check(CLI::Range(8, 30));
  cmd->add_option("--normal-bits", f->draco.normal_bits, "Draco normal quantization bits")
      ->capture_default_str()->check(CLI::Range(4, 30));
  cmd->add_option("--texcoord-bits", f->draco.texcoord_bits, "Draco texture coordinate quantization bits")
      ->capture_default_str()->check(CLI::Range(4, 30));
  cmd->add_option("--compression-level", f->draco.compression_level, "Draco compression level 0 (fast) .. 10")
      ->capture_default_str()->check(CLI::Range(0, 10));
  cmd->add_flag("--retry-failed", f->retry_failed, "Reconvert assets that failed before with unchanged inputs");
  cmd->add_flag("--verbose,-v", f->verbose, "Print a line per asset (failures are always printed)");
}

int Run(const ConvertFlags& f, const std::function<Result<convert::ConvertReport>(const convert::ConvertOptions&)>& fn) {
  convert::ConvertOptions options;
  options.jobs = f.jobs;
  options.limit = f.limit;
  options.synsets = f.synsets;
  if (f.version != 0) options.shapenet_version = f.version;
  options.draco = f.draco;
  options.retry_failed = f.retry_failed;
  options.keep_all_room_objects = f.all_objects;
  options.texture_library = f.texture_library;
  options.on_item = [&](const convert::ItemOutcome& item) {
    if (item.status == "failed") {
      fmt::print("FAILED\t{}\t{}\t{}\n", item.key, item.error_code, item.message);
    } else if (f.verbose) {
      fmt::print("{}\t{}\t{:.0f}\n", item.status == "up_to_date" ? "SKIP" : "OK", item.key, item.milliseconds);
    }
  };
  options.cancel = InstallStopHandlers();
  Result<convert::ConvertReport> report = [&] {
    ProgressLine progress("convert", "assets");
    options.progress = progress.Callback();
    return fn(options);
  }();
  if (!report.ok()) return Fail(report.status());
  const convert::ConvertReport& r = *report;
  fmt::print("\n{:<18} {}\n", "assets", r.assets);
  fmt::print("{:<18} {}\n", "up to date", r.up_to_date);
  fmt::print("{:<18} {}\n", "ok", r.ok);
  fmt::print("{:<18} {}\n", "ok with warnings", r.ok_with_warnings);
  fmt::print("{:<18} {}\n", "failed", r.failed);
  for (const auto& [code, n] : r.failure_codes) fmt::print("  failed {:<14} {}\n", code, n);
  for (const auto& [code, n] : r.warning_codes) fmt::print("  warning {:<13} {}\n", code, n);
  double converted = static_cast<double>(r.ok + r.ok_with_warnings + r.failed);
  fmt::print("{:<18} {:.1f} s ({:.1f} assets/s), {:.1f} MB in, {:.1f} MB out\n", "time", r.seconds,
             r.seconds > 0 ? converted / r.seconds : 0.0, r.bytes_in / 1e6, r.bytes_out / 1e6);
  fmt::print("{:<18} {}\n", "catalog", r.catalog.string());
  if (r.textures) {
    fmt::print("{:<18} {} folders, {} files copied, {} up to date{}\n", "textures", r.textures->categories.size(),
               r.textures->files_copied, r.textures->files_up_to_date,
               r.textures->unknown_created ? ", unknown/ created" : "");
    fmt::print("{:<18} {} materials (they render from textures/unknown/; per room: catalog extras "
               "unmatched_texture_folders)\n", "unmatched folders", r.textures->unmatched.size());
    for (const auto& [material, folder] : r.textures->unmatched) fmt::print("  {} -> {}/\n", material, folder);
  }
  if (r.cancelled) {
    fmt::print(stderr, "solid: stopped by {}: {} of {} assets done, each with its file and catalog row; {} not "
                       "started\nsolid: to resume, run the same command again:\n  {}\n",
               StopSignalName(), r.assets - r.not_started, r.assets, r.not_started, CommandLine());
    return StopExitCode();
  }
  if (r.failed > 0) {
    fmt::print(stderr, "solid: {} assets failed; reasons: solid inspect {}\n", r.failed, f.out);
    return kExitProblems;
  }
  return kExitOk;
}

}  // namespace

Command AddConvert(CLI::App& app) {
  auto f = std::make_shared<ConvertFlags>();
  CLI::App* cmd = app.add_subcommand("convert", "Convert ShapeNet models, SceneNet rooms, glTF or OBJ model folders, or "
                                                "procedural shapes and rooms into Draco-compressed glTF assets with an SQLite catalog.");
  cmd->require_subcommand(1);
  CLI::App* shapenet = cmd->add_subcommand("shapenet", "ShapeNetCore v1 or v2 tree -> OUT/models/<synset>/<id>.glb");
  shapenet->add_option("ROOT", f->root, "ShapeNetCore root (holding taxonomy.json and synset folders)")->required();
  shapenet->add_option("OUT", f->out, "Assets directory")->required();
  shapenet->add_option("--synsets", f->synsets, "Only these synsets (comma-separated)")->delimiter(',');
  shapenet->add_option("--shapenet-version", f->version, "ShapeNetCore version 1 or 2 (default: detected)")
      ->check(CLI::IsMember({1, 2}));
  AddCommonFlags(shapenet, f.get());
  CLI::App* scenenet = cmd->add_subcommand("scenenet", "SceneNet rooms (*.obj below ROOT) -> OUT/rooms/<scene>.glb");
  scenenet->add_option("ROOT", f->root, "SceneNet root (SceneNetData/, layouts/...)")->required();
  scenenet->add_option("OUT", f->out, "Assets directory")->required();
  scenenet->add_flag("--all-objects", f->all_objects, "Keep every object, not only walls, floors and ceilings");
  scenenet->add_flag("--texture-library", f->texture_library,
                     "Copy ROOT/texture_library/<category>/ to OUT/textures/, add textures/unknown/, and list "
                     "materials whose texture folder does not exist");
  AddCommonFlags(scenenet, f.get());
  CLI::App* procedural = cmd->add_subcommand("procedural", "Built-in label-free shapes and rooms (no download)");
  procedural->add_option("OUT", f->out, "Assets directory")->required();
  procedural->add_option("--models", f->procedural.models, "Number of shapes")->capture_default_str();
  procedural->add_option("--rooms", f->procedural.rooms, "Number of rooms")->capture_default_str();
  AddSeedOption(procedural, &f->procedural.seed, "Seed");
  procedural->add_option("--min-triangles", f->procedural.shapes.min_triangles,
                         "Fewest triangles of a shape (counts are drawn log-uniformly in the range)")
      ->capture_default_str();
  procedural->add_option("--max-triangles", f->procedural.shapes.max_triangles, "Most triangles of a shape")
      ->capture_default_str();
  procedural->add_option("--families", f->families,
                         "Only these shape families, comma-separated (default: all, mixed): chair, table, sofa, bed, "
                         "cabinet, bookshelf, lamp, display, car, airplane, bottle, vase, mug, bowl, bench, "
                         "trash_bin, guitar, laptop")
      ->delimiter(',');
  AddCommonFlags(procedural, f.get());
  // glTF corpora and plain OBJ folders.
  CLI::App* gltf = cmd->add_subcommand("gltf", "Every .glb/.gltf below ROOT (Objaverse, ABO...) -> OUT/models/<key>.glb");
  gltf->add_option("ROOT", f->root, "Folder of glTF models")->required();
  gltf->add_option("OUT", f->out, "Assets directory")->required();
  gltf->add_option("--layout", f->gltf_layout,
                   "flat: key = path below ROOT without extension; objaverse: glbs/NNN-NNN/<uid>.glb -> key <uid>")
      ->capture_default_str()->check(CLI::IsMember({"flat", "objaverse"}));
  AddCommonFlags(gltf, f.get());
  CLI::App* obj = cmd->add_subcommand("obj", "OBJ models below ROOT (Google Scanned Objects, YCB...) -> "
                                             "OUT/models/<key>.glb");
  obj->add_option("ROOT", f->root, "Folder of OBJ models")->required();
  obj->add_option("OUT", f->out, "Assets directory")->required();
  obj->add_option("--layout", f->obj_layout,
                  "flat: every .obj, key = path without extension; gso: <name>/meshes/model.obj; "
                  "ycb: <name>/google_16k/textured.obj")
      ->capture_default_str()->check(CLI::IsMember({"flat", "gso", "ycb"}));
  AddCommonFlags(obj, f.get());
  return [f, shapenet, scenenet, gltf, obj] {
    if (gltf->parsed()) {
      const auto layout = f->gltf_layout == "objaverse" ? convert::GltfLayout::kObjaverse : convert::GltfLayout::kFlat;
      return Run(*f, [&](const convert::ConvertOptions& o) { return convert::ConvertGltf(f->root, f->out, layout, o); });
    }
    if (obj->parsed()) {
      const auto layout = f->obj_layout == "gso"   ? convert::ObjLayout::kGso
                          : f->obj_layout == "ycb" ? convert::ObjLayout::kYcb
                                                   : convert::ObjLayout::kFlat;
      return Run(*f, [&](const convert::ConvertOptions& o) { return convert::ConvertObjFolder(f->root, f->out, layout, o); });
    }
    if (shapenet->parsed()) {
      return Run(*f, [&](const convert::ConvertOptions& o) { return convert::ConvertShapeNet(f->root, f->out, o); });
    }
    if (scenenet->parsed()) {
      return Run(*f, [&](const convert::ConvertOptions& o) { return convert::ConvertSceneNet(f->root, f->out, o); });
    }
    Result<std::vector<convert::ShapeFamily>> families = convert::ParseShapeFamilies(f->families);
    if (!families.ok()) return Fail(families.status().WithContext("--families"));
    f->procedural.shapes.families = std::move(families).value();
    return Run(*f, [&](const convert::ConvertOptions& o) { return convert::ConvertProcedural(f->procedural, f->out, o); });
  };
}

}  // namespace solid::cli
