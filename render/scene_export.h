// A sampled layout as a glTF 2.0 scene (.glb) that Blender or any glTF viewer opens:
// the room, every placed object as a node with its transform (one mesh per model,
// shared by its instances), and the camera as a glTF camera node, so that a user sees
// exactly what was sampled, from where. Geometry is stored uncompressed (no
// extension required); materials and textures are the assets' own. The scene's extras
// carry the layout's identity and, under "lights", the LightRig that `solid render`
// lights it with (LightRig::ToJson, world frame, Z up).
//
// Frames: a root node "world" turns our Z-up world into glTF's Y-up; under it, object
// nodes carry world_from_object and the camera node world_from_camera unchanged
// (glTF cameras, like ours, look along -Z with +Y up).
#pragma once

#include <cstdint>
#include <vector>

#include "solid/formats/status.h"
#include "solid/render/layout.h"

namespace solid::render {

Result<std::vector<uint8_t>> ExportSceneGlb(const Layout& layout);

}  // namespace solid::render
