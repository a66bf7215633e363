// libFuzzer target for search-space files of `solid optimize --space`:
// optimizer::SearchSpace::Load (limits, JSON, the search-space JSON Schema, bounds), then
// what the optimizer does with an accepted space: its dimensions for the start params
// (the file's preset, or "more-objects", whose scale law is a mixture), and Encode and
// Decode at the start and at the corners of the box.
#include <cstdint>
#include <span>
#include <vector>

#include "fuzz/fuzz_util.h"
#include "solid/optimizer/search_space.h"

using solid::fuzz::Fail;
namespace optimizer = solid::optimizer;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::filesystem::path path = solid::fuzz::ScratchDir() / "space.json";
  solid::fuzz::WriteFileOrDie(path, std::span<const uint8_t>(data, size));
  solid::Result<optimizer::SearchSpace> space = optimizer::SearchSpace::Load(path);
  if (!space.ok()) return 0;
  solid::Result<solid::render::LayoutParams> start =
      solid::render::LoadPreset(space->start_preset().value_or("more-objects"));
  if (!start.ok()) return 0;  // an unknown preset name: refused when the optimizer starts
  solid::Result<std::vector<optimizer::Dimension>> dims = space->Dimensions(*start);
  if (!dims.ok()) return 0;
  const std::vector<double> x = space->Encode(*start);
  if (x.size() != dims->size()) Fail("Encode gives a point of the wrong dimension");
  for (size_t i = 0; i < x.size(); ++i) {
    if (!(x[i] >= (*dims)[i].lo && x[i] <= (*dims)[i].hi)) Fail("Encode leaves the bounds of " + (*dims)[i].name);
  }
  (void)space->Decode(*start, x);
  std::vector<double> lo, hi;
  for (const optimizer::Dimension& d : *dims) {
    lo.push_back(d.lo);
    hi.push_back(d.hi);
  }
  (void)space->Decode(*start, lo);
  (void)space->Decode(*start, hi);
  return 0;
}
