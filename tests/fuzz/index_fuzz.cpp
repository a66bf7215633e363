// libFuzzer target for index.sqlite. A small dataset (fuzz_util.h's SeedDatasetOptions,
// the one the index seeds come from) is written once into this process's scratch
// directory; each input replaces its index.sqlite, which is then read the way
// `solid validate` (CompareIndex) and the query sampling (Dataset's lookups by model,
// which trust an index that lists the shard files present) read it.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "fixtures/layered_dataset.h"
#include "fuzz/fuzz_util.h"
#include "solid/formats/dataset.h"
#include "solid/formats/index.h"

using solid::fuzz::Fail;

namespace {

const solid::DatasetPaths& FixtureDataset() {
  static const solid::DatasetPaths paths = [] {
    solid::DatasetPaths p(solid::fuzz::ScratchDir() / "dataset");
    const solid::Status written = solid::fixtures::WriteLayeredDataset(p.root, solid::fuzz::SeedDatasetOptions());
    if (!written.ok()) Fail("cannot write the fixture dataset: " + written.message());
    return p;
  }();
  return paths;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const solid::DatasetPaths& paths = FixtureDataset();
  solid::fuzz::RemoveSqliteFiles(paths.index());
  solid::fuzz::WriteFileOrDie(paths.index(), std::span<const uint8_t>(data, size));
  (void)solid::CompareIndex(paths.root);
  solid::Result<solid::Dataset> dataset = solid::Dataset::Open(paths.root);
  if (!dataset.ok()) Fail("the fixture dataset does not open: " + dataset.status().message());
  for (int m = 0; m < solid::fuzz::SeedDatasetOptions().models; ++m) {
    const std::string key = "fixture/model-0" + std::to_string(m);
    (void)dataset->OccurrencesOfModel(key);
    solid::Result<std::vector<solid::InstanceRecord>> instances = dataset->InstancesOfModel(key);
    if (instances.ok()) {
      for (const solid::InstanceRecord& in : *instances) {
        if (in.model_key != key) Fail("InstancesOfModel returned another model's instance");
      }
    }
    solid::Result<std::vector<solid::QueryViewRecord>> views = dataset->QueryViews(key);
    if (views.ok()) {
      for (const solid::QueryViewRecord& v : *views) {
        if (v.model_key != key) Fail("QueryViews returned another model's view");
      }
    }
  }
  solid::fuzz::RemoveSqliteFiles(paths.index());
  return 0;
}
