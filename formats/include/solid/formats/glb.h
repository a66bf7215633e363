// glTF 2.0 binary (.glb) output with KHR_draco_mesh_compression, declared in both
// extensionsUsed and extensionsRequired. Every primitive's geometry is Draco-encoded
// (edgebreaker); materials are metallic-roughness; textures are embedded in the
// binary chunk with a REPEAT/REPEAT sampler. Deterministic: same asset and options,
// same bytes. Thread-safe.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "solid/formats/asset.h"
#include "solid/formats/status.h"

namespace solid::gltf {

struct DracoOptions {
  int position_bits = 14;
  int normal_bits = 10;
  int texcoord_bits = 12;
  // Draco speed = 10 - level; above level 5, each primitive is also encoded at Draco's
  // default speed 5 and the smaller stream kept.
  int compression_level = 7;
};

// One glTF node and one mesh (both named Node::name, node extras = Node::extras) per
// node, one primitive per Primitive; asset.extras = Asset::extras. Accessor counts
// and POSITION min/max describe the Draco-decoded data (edgebreaker may reorder,
// merge and split vertices), and they carry no bufferView (no uncompressed fallback).
// kInvalidArgument for an inconsistent asset (attribute sizes, indices out of range,
// material or texture index out of range, a node without primitives, non-finite
// attributes, material factors outside [0, 1], texture bytes that are not the
// declared PNG/JPEG, names or extras that are not UTF-8) or options out of range
// (bits 1..30, normals 2..30, level 0..10); kLimitExceeded past 4 GiB; kInternal
// when Draco fails.
Result<std::vector<uint8_t>> WriteGlb(const Asset& asset, const DracoOptions& options = {});

// Packs a glTF JSON document and its binary chunk (length a multiple of 4; may be
// empty) into a .glb container, for writers of other glTF content (scene exports).
// kLimitExceeded past 4 GiB.
Result<std::vector<uint8_t>> PackGlb(const nlohmann::json& gltf, std::span<const uint8_t> bin);

// Totals over all primitives of all nodes that ReadGlb accepts (the OBJ reader's
// defaults). They are checked on the accessor counts before any Draco stream is decoded.
inline constexpr uint64_t kMaxGlbVertices = 50'000'000;
inline constexpr uint64_t kMaxGlbTriangles = 50'000'000;

// Reads a .glb written by WriteGlb (or any glb whose meshes are Draco-compressed or
// plain), decoding Draco, into an Asset: for round-trip and fidelity checks, and for
// `solid inspect` of an assets directory. Untrusted input: errors, never crashes;
// messages start with `name` and the JSON location ("x.glb: meshes[2].primitives[0]:
// ..."). Each node with a mesh becomes a Node, in file order; node transforms,
// the node hierarchy and scenes are ignored (WriteGlb writes none), so a foreign
// file's meshes come back in mesh-local coordinates. Every glTF texture becomes a
// Texture (its image must live in a bufferView); absent material members take
// glTF's defaults (metallic 1). Codes: kParseError (container, JSON, member types),
// kCorrupt (indices, lengths, Draco streams, accessor counts that disagree with
// the Draco data), kUnsupportedVersion (glTF 1, unknown required extensions,
// external buffers or images, sparse accessors, non-triangle modes),
// kLimitExceeded (JSON nested deeper than 64, more than kMaxGlbVertices or
// kMaxGlbTriangles in all). Draco 1.5.5 itself may allocate a
// few hundred MB on a corrupt stream before it fails.
Result<Asset> ReadGlb(std::span<const uint8_t> bytes, std::string_view name);

}  // namespace solid::gltf
