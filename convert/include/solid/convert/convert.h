// `solid convert`: batch conversion of ShapeNet v1/v2 models, SceneNet rooms and
// procedural shapes and rooms into an assets directory:
//
//   OUT/models/<synset>/<model_id>.glb   ShapeNet (key "<synset>/<model_id>")
//   OUT/models/procedural/shape-NNNNNN.glb    (key "procedural/shape-NNNNNN")
//   OUT/rooms/<scene key>.glb            SceneNet (key = path below the root, no extension)
//   OUT/rooms/procedural/room-NNNNNN.glb      (key "procedural/room-NNNNNN")
//   OUT/catalog.sqlite                   one row per asset (schemas/catalog.sql)
//   OUT/textures/<category>/...          SceneNet with texture_library: ROOT/texture_library copied
//
// Every asset is converted alone: a bad one becomes a `failed` row with a reason naming
// the file and line, and the batch goes on. Files are published atomically and the
// catalog row is written after the file. A rerun converts only the assets that are
// missing or whose inputs, converter version or options changed.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "solid/formats/cancel.h"
#include "solid/formats/glb.h"
#include "solid/formats/progress.h"
#include "solid/convert/procedural.h"
#include "solid/formats/status.h"

namespace solid::convert {

// The converter's version: part of every catalog row, so a new version reconverts.
std::string_view ConverterVersion();

struct ItemOutcome {
  std::string key;
  std::string status;       // "ok", "ok_with_warnings", "failed", "up_to_date"
  std::string error_code;   // failures: missing_obj, parse_error, ...
  std::string message;
  double milliseconds = 0;
};

// What Convert reads.
enum class Source {
  kShapeNet,    // a ShapeNetCore v1 or v2 tree at `root`
  kSceneNet,    // SceneNet rooms (*.obj below `root`)
  kProcedural,  // built-in shapes and rooms (`procedural`), no input
  // glTF 2.0 corpora (`solid convert gltf`): every .glb/.gltf below root, read through
  // tinygltf (docs/limits.md), the default scene flattened into one node with one primitive
  // per material, then normalised as ShapeNet v2 models are; the catalog row's extras keep
  // "source_extent_m" (the bounding box in metres before normalisation). Output
  // OUT/models/<key>.glb, source "gltf". Failure codes: those of convert/gltf_reader.h, plus
  // unsafe_name and duplicate_key.
  kGltf,
  // Folders of plain OBJ models (`solid convert obj`), through ShapeNet's OBJ/MTL reader and
  // cleaning and with its failure codes, normalised as ShapeNet v2. Output
  // OUT/models/<key>.glb, source "obj".
  kObj,
};

// kGltf: kFlat: key = path below root without extension; kObjaverse: glbs/NNN-NNN/<uid>.glb
// gives key <uid> (other files are not considered).
enum class GltfLayout { kFlat, kObjaverse };
// kObj: kFlat: every .obj below root, key = path without extension, textures confined to the
// OBJ's folder; kGso: <name>/meshes/model.obj; kYcb: <name>/google_16k/textured.obj (key
// <name>, textures confined to <name>/, extent in metres).
enum class ObjLayout { kFlat, kGso, kYcb };
// kObj: the OBJ's up axis. kLayoutDefault is +Z for kGso and kYcb (Google's scans, made for
// Gazebo, whose world is +Z up) and +Y for kFlat; a +Z-up model is turned to +Y up
// (y' = z, z' = -y) before it is normalised as ShapeNet v2.
enum class UpAxis { kLayoutDefault, kY, kZ };

struct ProceduralSet {
  int models = 64;
  int rooms = 8;
  uint64_t seed = 1;
  ProceduralShapeOptions shapes;  // part of each shape's identity: a new range reconverts
};

struct ConvertOptions {
  Source source = Source::kProcedural;
  std::filesystem::path root;  // the input tree (ShapeNet, SceneNet, glTF, OBJ folders)
  std::filesystem::path out;   // the assets directory written
  ProceduralSet procedural;    // kProcedural
  GltfLayout gltf_layout = GltfLayout::kFlat;  // kGltf
  ObjLayout obj_layout = ObjLayout::kFlat;     // kObj
  UpAxis obj_up = UpAxis::kLayoutDefault;      // kObj
  int jobs = 0;                      // 0: all cores
  int64_t limit = -1;                // convert at most this many assets (after filtering); -1: all
  std::vector<std::string> synsets;  // ShapeNet: only these synset folders (empty: all)
  std::optional<int> shapenet_version;  // 1 or 2; detected when empty
  gltf::DracoOptions draco;
  bool retry_failed = false;         // reconvert assets whose row says failed with unchanged inputs
  bool keep_all_room_objects = false;  // SceneNet: keep every object, not only walls, floors, ceilings
  // SceneNet: also run the texture-library step (CopySceneNetTextureLibrary from
  // ROOT/texture_library to OUT/textures) and record in each room's catalog extras
  // "unmatched_texture_folders": [{"material", "folder"}] for its materials whose derived
  // folder (SceneNetTextureFolder) is missing or empty in the library, i.e. that render
  // from textures/unknown/. A missing ROOT/texture_library is then a fatal kNotFound.
  bool texture_library = false;
  ProgressCallback progress;         // assets done / total
  std::function<void(const ItemOutcome&)> on_item;  // called from the calling thread
  // Stops the batch (solid/formats/cancel.h): the assets in flight are finished and get
  // their catalog rows, no other is started (report.cancelled, not_started).
  const CancelFlag* cancel = nullptr;
};

// What the SceneNet texture-library step did.
struct TextureLibraryReport {
  std::vector<std::string> categories;  // library folders holding at least one file, sorted
  int64_t files_copied = 0;             // written (new, or different from the library's)
  int64_t files_up_to_date = 0;         // already identical in the output
  bool unknown_created = false;         // textures/unknown/ got the placeholder image
  // Rooms' material names whose derived folder is not among `categories` -> that folder
  // (filled by Convert, for SceneNet, from the catalog rows of the rooms considered).
  std::map<std::string, std::string> unmatched;
};

struct ConvertReport {
  int64_t assets = 0;      // considered (after filters and the limit)
  int64_t up_to_date = 0;  // skipped: the catalog row matches
  int64_t ok = 0, ok_with_warnings = 0, failed = 0;
  std::map<std::string, int64_t> failure_codes, warning_codes;
  int64_t bytes_in = 0, bytes_out = 0;
  double seconds = 0;
  std::filesystem::path catalog;
  std::optional<TextureLibraryReport> textures;  // SceneNet with options.texture_library
  bool cancelled = false;   // stopped through options.cancel
  int64_t not_started = 0;  // assets left for a rerun when cancelled
};

// `solid convert` as one call: the assets of options.source into options.out. Fatal errors
// (a root that is not a ShapeNet tree, an output that cannot be created) are returned as a
// Status, a wrong field as OptionError naming it ("out", "root", "procedural.models",
// "procedural.rooms"); per-asset failures are in the report and the catalog.
Result<ConvertReport> Convert(const ConvertOptions& options);

// The texture-library step of docs "input-formats" 4 (SceneNet output 3), on its own:
// copies every regular file of each `library/<category>/` (no deeper) to
// `textures/<category>/`, each written through a temporary sibling and renamed, and skips
// files already there with the same size and XXH64, so a rerun or an interrupted run
// converges to the same tree. Files in `textures` that the library lacks are left alone.
// Then, when `textures/unknown/` holds no file (the library has none: it "does not exist
// after download"), writes `textures/unknown/placeholder_grey.png`: the reference loader
// sends unmatched materials there and fails on an empty folder; flat grey is the colour
// the SceneNet MTLs give every material (Kd 0.64). Folder and file names starting with '.'
// and our temporary files are skipped. Errors: kNotFound (no library folder), kIoError
// naming the file. `unmatched` is left empty.
Result<TextureLibraryReport> CopySceneNetTextureLibrary(const std::filesystem::path& library,
                                                        const std::filesystem::path& textures);


}  // namespace solid::convert
