// libFuzzer target for a dataset's manifest.json as every command that opens a dataset
// reads it: ReadManifest (size limit, JSON, the manifest JSON Schema, hex fields, the
// params hash). A manifest it accepts must write back to a manifest that reads the same.
#include <cstdint>
#include <span>
#include <string>

#include "fuzz/fuzz_util.h"
#include "solid/formats/dataset.h"

using solid::fuzz::Fail;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const solid::DatasetPaths paths(solid::fuzz::ScratchDir());
  solid::fuzz::WriteFileOrDie(paths.manifest(), std::span<const uint8_t>(data, size));
  solid::Result<solid::Manifest> manifest = solid::ReadManifest(paths.root);
  if (!manifest.ok()) return 0;
  const std::string text = manifest->ToJson().dump(2);
  solid::Result<solid::Manifest> again = solid::Manifest::Parse(text, "round trip");
  if (!again.ok()) Fail("a manifest written back does not parse: " + again.status().message());
  if (!solid::ManifestDifference(*manifest, *again).empty()) Fail("a manifest written back reads differently");
  return 0;
}
