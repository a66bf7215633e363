// SceneNet object labels: which room pieces are walls, floors and ceilings.
// Exactly the reference loaders' rules (docs "input-formats" 3.4): BlenderProc's
// category rule over NYU-40 ids, then SOLID's structure rule.
#pragma once

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

}  // namespace solid::convert
