// libFuzzer target for params files as `solid render --params` and `solid optimize`
// read them: render::LoadParamsFile (size and depth limits, JSON parsing, the params
// JSON Schema, the preset a file names, the semantic checks). Params it accepts must
// pass CheckParams and survive the documented round trip ParseParams(ParamsToJson(p)) == p.
#include <cstdint>
#include <span>

#include "fuzz/fuzz_util.h"
#include "solid/render/params.h"

using solid::fuzz::Fail;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::filesystem::path path = solid::fuzz::ScratchDir() / "params.json";
  solid::fuzz::WriteFileOrDie(path, std::span<const uint8_t>(data, size));
  solid::Result<solid::render::LayoutParams> params = solid::render::LoadParamsFile(path);
  if (!params.ok()) return 0;
  if (!solid::render::CheckParams(*params, "fuzz").ok()) Fail("accepted params fail CheckParams");
  solid::Result<solid::render::LayoutParams> again =
      solid::render::ParseParams(solid::render::ParamsToJson(*params), {}, "round trip");
  if (!again.ok()) Fail("ParamsToJson output does not parse: " + again.status().message());
  if (!(*again == *params)) Fail("ParseParams(ParamsToJson(p)) != p");
  return 0;
}
