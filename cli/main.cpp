#include <CLI/CLI.hpp>

int main(int argc, char** argv) {
  CLI::App app{"solid: label-free synthetic pretraining data for object detectors"};
  app.set_version_flag("--version", SOLID_VERSION);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
