// Writes a fixture dataset of stacked 2D shapes through the writer API
// (tests/fixtures/layered_dataset.h). Until `solid render` exists, this is how the
// README's first command produces data for index, validate and inspect.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "fixtures/layered_dataset.h"

int main(int argc, char** argv) {
  solid::fixtures::LayeredDatasetOptions options;
  std::string out;
  CLI::App app{"Write a fixture dataset of stacked 2D shapes"};
  app.add_option("OUT", out, "Dataset directory to create")->required();
  app.add_option("--images", options.images, "Number of images")->capture_default_str();
  app.add_option("--shard-size", options.shard_size, "Images per shard")->capture_default_str();
  app.add_option("--seed", options.seed, "Dataset seed")->capture_default_str();
  app.add_option("--width", options.width, "Image width")->capture_default_str();
  app.add_option("--height", options.height, "Image height")->capture_default_str();
  app.add_flag("--depth", options.depth, "Store depth EXRs");
  CLI11_PARSE(app, argc, argv);
  solid::Status status = solid::fixtures::WriteLayeredDataset(out, options);
  if (!status.ok()) {
    fmt::print(stderr, "make_fixture_dataset: {}\n", status.message());
    return 1;
  }
  fmt::print("wrote {} images to {}\n", options.images, out);
  return 0;
}
