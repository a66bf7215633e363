#include "render/test_assets.h"

#include <unistd.h>

#include <cstdlib>
#include <string>

#include "solid/convert/convert.h"

namespace solid::render::testing {
namespace {

struct AssetsDir {
  std::filesystem::path path;
  AssetsDir() {
    path = std::filesystem::temp_directory_path() / ("solid-render-assets-" + std::to_string(::getpid()));
    std::filesystem::remove_all(path);
    convert::ConvertOptions options;
    options.jobs = 2;
    const auto report = convert::ConvertProcedural({16, 3, 7}, path, options);
    if (!report.ok() || report->failed != 0) std::abort();
  }
  ~AssetsDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

}  // namespace

const std::filesystem::path& ProceduralAssetsDir() {
  static const AssetsDir dir;
  return dir.path;
}

std::shared_ptr<AssetLibrary> ProceduralLibrary() {
  static const std::shared_ptr<AssetLibrary> library =
      AssetLibrary::Open(ProceduralAssetsDir(), ProceduralAssetsDir()).value();
  return library;
}

}  // namespace solid::render::testing
