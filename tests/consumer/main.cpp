// Encodes a mask with the installed library and checks pycocotools' string for it; links solid::export.
#include <solid/export/coco.h>
#include <solid/formats/rle.h>

#include <cstdio>
#include <vector>

int main() {
  // 5x5 with the single pixel (x=3, y=1) set: COCO counts "`018" (testdata single-5x5-4).
  std::vector<uint8_t> mask(25, 0);
  mask[1 * 5 + 3] = 1;
  std::string counts = solid::rle::ToString(solid::rle::EncodeRowMajor(mask, 5, 5));
  if (counts != "`018") {
    std::fprintf(stderr, "consumer: got '%s', expected '`018'\n", counts.c_str());
    return 1;
  }
  // solid::export links (with the render and optimize libraries it needs) and reports a missing dataset.
  solid::exporters::CocoExportOptions options;
  options.dataset = "no-such-dataset";
  options.out_dir = "coco-out";
  if (solid::exporters::ExportCoco(options).ok()) {
    std::fprintf(stderr, "consumer: exporting a missing dataset succeeded\n");
    return 1;
  }
  std::printf("consumer: ok\n");
  return 0;
}
