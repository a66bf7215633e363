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

#include "solid/convert/asset.h"
#include "solid/formats/status.h"

namespace solid::convert {

struct DracoOptions {
  int position_bits = 14;
  int normal_bits = 10;
  int texcoord_bits = 12;
  int compression_level = 7;  // Draco speed = 10 - level
};

// kInvalidArgument for an inconsistent asset (attribute sizes, indices out of range,
// material or texture index out of range); kInternal when Draco fails.
Result<std::vector<uint8_t>> WriteGlb(const Asset& asset, const DracoOptions& options = {});

// Reads a .glb written by WriteGlb (or any glb whose meshes are Draco-compressed or
// plain), decoding Draco, into an Asset: for round-trip and fidelity checks, and for
// `solid inspect` of an assets directory. Untrusted input: errors, never crashes.
Result<Asset> ReadGlb(std::span<const uint8_t> bytes, std::string_view name);

}  // namespace solid::convert
