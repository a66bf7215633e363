// SceneNet object labels: which room pieces are walls, floors and ceilings, and which
// texture folder a material draws from.
// Exactly the reference loaders' rules (docs "input-formats" 3.4): BlenderProc's
// category rule over NYU-40 ids, then SOLID's structure rule.
#pragma once

#include <string>
#include <string_view>

namespace solid::convert {

// NYU-40 category id of an object name (BlenderProc `_set_category_ids`): lower-case,
// cut at the first '.', NORMALIZE table, exact label, label minus its last character,
// 'painting' -> 11, else 38 (otherstructure).
int SceneNetCategory(std::string_view object_name);

enum class Structure { kNone, kWall, kFloor, kCeiling };
std::string_view StructureName(Structure s);  // "", "wall", "floor", "ceiling"

// SOLID `filter_objs_by_cat`: wall = category 1; floor = category 2 or the lower-case
// name contains "floor"; ceiling = category 22 or the name contains "ceiling".
Structure SceneNetStructure(std::string_view object_name);

// The texture_library folder the reference loader (BlenderProc `SceneNetLoader`, docs
// "input-formats" 3.3) picks a random image from for a material: the name cut at the first
// '.', then every '_' and ASCII digit deleted, case kept. "wall.034" -> "wall";
// "Walls.132" -> "Walls" and "metal_plastic.001" -> "metalplastic", folders the library
// does not have, so those materials fall back to "unknown".
std::string SceneNetTextureFolder(std::string_view material_name);

}  // namespace solid::convert
