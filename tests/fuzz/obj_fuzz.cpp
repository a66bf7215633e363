// libFuzzer target for ReadObj and ReadMtl (the same bytes go to both). Besides crashes and
// sanitizer reports, it aborts when a successful parse breaks the reader's contract: every
// triangle corner indexes the arrays it returns and no limit is exceeded.
#include <cstdint>
#include <cstdlib>
#include <span>

#include "obj.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  solid::convert::ObjReadOptions options;
  options.max_faces = 1'000'000;  // a short input fans into at most ~size triangles anyway
  solid::Result<solid::convert::ObjData> obj = solid::convert::ReadObj(bytes, "fuzz.obj", options);
  if (obj.ok()) {
    const solid::convert::ObjData& d = *obj;
    uint64_t triangles = 0;
    for (const solid::convert::ObjFaceBlock& block : d.blocks) {
      triangles += block.triangles.size();
      for (const solid::convert::ObjTriangle& t : block.triangles) {
        for (const solid::convert::ObjCorner& c : t.corners) {
          if (c.v < 0 || static_cast<uint64_t>(c.v) >= d.positions.size()) std::abort();
          if (c.vt < -1 || c.vt >= static_cast<int64_t>(d.uvs.size())) std::abort();
          if (c.vn < -1 || c.vn >= static_cast<int64_t>(d.normals.size())) std::abort();
        }
      }
    }
    if (triangles > options.max_faces) std::abort();
  }
  (void)solid::convert::ReadMtl(bytes, "fuzz.mtl", options);
  return 0;
}
