#include <fmt/format.h>

#include <iostream>
#include <map>

#include "commands.h"
#include "exit_codes.h"
#include "progress.h"
#include "signals.h"
#include "solid/convert/convert.h"

namespace solid::cli {
namespace {

struct ConvertFlags {
  convert::ConvertOptions options;
  std::vector<std::string> families;
  int version = 0;
  bool verbose = false;
};

// Where a message about an options field names it, the user sees the flag.
const FlagNames kConvertFlags = {{"procedural.models", "--models"}, {"procedural.rooms", "--rooms"}};

void AddCommonFlags(CLI::App* cmd, ConvertFlags* f) {
  convert::ConvertOptions& o = f->options;
  AddJobsOption(cmd, &o.jobs, "Parallel conversions");
  cmd->add_option("--limit", o.limit, "Convert at most N assets (after filters)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--position-bits", o.draco.position_bits, "Draco position quantization bits")
      ->capture_default_str()->check(CLI::Range(8, 30));
  cmd->add_option("--normal-bits", o.draco.normal_bits, "Draco normal quantization bits")
      ->capture_default_str()->check(CLI::Range(4, 30));
  cmd->add_option("--texcoord-bits", o.draco.texcoord_bits, "Draco texture coordinate quantization bits")
      ->capture_default_str()->check(CLI::Range(4, 30));
  cmd->add_option("--compression-level", o.draco.compression_level, "Draco compression level 0 (fast) .. 10")
      ->capture_default_str()->check(CLI::Range(0, 10));
  cmd->add_flag("--retry-failed", o.retry_failed, "Reconvert assets that failed before with unchanged inputs");
  cmd->add_flag("--verbose,-v", f->verbose, "Print a line per asset (failures are always printed)");
}

int Run(ConvertFlags& f) {
  convert::ConvertOptions& options = f.options;
  if (f.version != 0) options.shapenet_version = f.version;
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
    return convert::Convert(options);
  }();
  if (!report.ok()) return Fail(report.status(), kConvertFlags);
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
    fmt::print(stderr, "solid: {} assets failed; reasons: solid inspect {}\n", r.failed, f.options.out.string());
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
  shapenet->add_option("ROOT", f->options.root, "ShapeNetCore root (holding taxonomy.json and synset folders)")->required();
  shapenet->add_option("OUT", f->options.out, "Assets directory")->required();
  shapenet->add_option("--synsets", f->options.synsets, "Only these synsets (comma-separated)")->delimiter(',');
  shapenet->add_option("--shapenet-version", f->version, "ShapeNetCore version 1 or 2 (default: detected)")
      ->check(CLI::IsMember({1, 2}));
  AddCommonFlags(shapenet, f.get());
  CLI::App* scenenet = cmd->add_subcommand("scenenet", "SceneNet rooms (*.obj below ROOT) -> OUT/rooms/<scene>.glb");
  scenenet->add_option("ROOT", f->options.root, "SceneNet root (SceneNetData/, layouts/...)")->required();
  scenenet->add_option("OUT", f->options.out, "Assets directory")->required();
  scenenet->add_flag("--all-objects", f->options.keep_all_room_objects, "Keep every object, not only walls, floors and ceilings");
  scenenet->add_flag("--texture-library", f->options.texture_library,
                     "Copy ROOT/texture_library/<category>/ to OUT/textures/, add textures/unknown/, and list "
                     "materials whose texture folder does not exist");
  AddCommonFlags(scenenet, f.get());
  CLI::App* procedural = cmd->add_subcommand("procedural", "Built-in label-free shapes and rooms (no download)");
  procedural->add_option("OUT", f->options.out, "Assets directory")->required();
  procedural->add_option("--models", f->options.procedural.models, "Number of shapes")->capture_default_str();
  procedural->add_option("--rooms", f->options.procedural.rooms, "Number of rooms")->capture_default_str();
  AddSeedOption(procedural, &f->options.procedural.seed, "Seed");
  procedural->add_option("--min-triangles", f->options.procedural.shapes.min_triangles,
                         "Fewest triangles of a shape (counts are drawn log-uniformly in the range)")
      ->capture_default_str();
  procedural->add_option("--max-triangles", f->options.procedural.shapes.max_triangles, "Most triangles of a shape")
      ->capture_default_str();
  procedural->add_option("--families", f->families,
                         "Only these shape families, comma-separated (default: all, mixed): chair, table, sofa, bed, "
                         "cabinet, bookshelf, lamp, display, car, airplane, bottle, vase, mug, bowl, bench, "
                         "trash_bin, guitar, laptop")
      ->delimiter(',');
  AddCommonFlags(procedural, f.get());
  const std::map<std::string, convert::GltfLayout> gltf_layouts = {{"flat", convert::GltfLayout::kFlat},
                                                                    {"objaverse", convert::GltfLayout::kObjaverse}};
  CLI::App* gltf = cmd->add_subcommand("gltf", "Every .glb/.gltf below ROOT (Objaverse, ABO...) -> OUT/models/<key>.glb");
  gltf->add_option("ROOT", f->options.root, "Folder of glTF models")->required();
  gltf->add_option("OUT", f->options.out, "Assets directory")->required();
  gltf->add_option("--layout", f->options.gltf_layout,
                   "flat: key = path below ROOT without extension; objaverse: glbs/NNN-NNN/<uid>.glb -> key <uid> "
                   "(default: flat)")
      ->transform(CLI::CheckedTransformer(gltf_layouts));
  AddCommonFlags(gltf, f.get());
  const std::map<std::string, convert::ObjLayout> obj_layouts = {
      {"flat", convert::ObjLayout::kFlat}, {"gso", convert::ObjLayout::kGso}, {"ycb", convert::ObjLayout::kYcb}};
  CLI::App* obj = cmd->add_subcommand("obj", "OBJ models below ROOT (Google Scanned Objects, YCB...) -> "
                                             "OUT/models/<key>.glb");
  obj->add_option("ROOT", f->options.root, "Folder of OBJ models")->required();
  obj->add_option("OUT", f->options.out, "Assets directory")->required();
  obj->add_option("--layout", f->options.obj_layout,
                  "flat: every .obj, key = path without extension; gso: <name>/meshes/model.obj; "
                  "ycb: <name>/google_16k/textured.obj (default: flat)")
      ->transform(CLI::CheckedTransformer(obj_layouts));
  const std::map<std::string, convert::UpAxis> up_axes = {{"y", convert::UpAxis::kY}, {"z", convert::UpAxis::kZ}};
  obj->add_option("--up", f->options.obj_up,
                  "The OBJs' up axis, y or z; a +Z-up model is turned to +Y up (default: z for gso and ycb, "
                  "whose scans were made for Gazebo's +Z-up world; y for flat)")
      ->transform(CLI::CheckedTransformer(up_axes));
  AddCommonFlags(obj, f.get());
  return [f, shapenet, scenenet, gltf, obj] {
    f->options.source = shapenet->parsed()   ? convert::Source::kShapeNet
                        : scenenet->parsed() ? convert::Source::kSceneNet
                        : gltf->parsed()     ? convert::Source::kGltf
                        : obj->parsed()      ? convert::Source::kObj
                                             : convert::Source::kProcedural;
    if (f->options.source == convert::Source::kProcedural) {
      Result<std::vector<convert::ShapeFamily>> families = convert::ParseShapeFamilies(f->families);
      if (!families.ok()) return Fail(families.status().WithContext("--families"));
      f->options.procedural.shapes.families = std::move(families).value();
    }
    return Run(*f);
  };
}

}  // namespace solid::cli
