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
    options.out = path;
    options.procedural = {16, 3, 7};
    const auto report = convert::Convert(options);
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

SmallLayout DrawSmallLayout(const std::string& preset, uint64_t seed) {
  LayoutParams params = LoadPreset(preset).value();
  params.width = 96;
  params.height = 72;
  SmallLayout out;
  out.sampler = LayoutSampler::Create(params, ProceduralLibrary()).value();
  out.g = GenerateLayout(*out.sampler, seed, 0).value();
  return out;
}

}  // namespace solid::render::testing
