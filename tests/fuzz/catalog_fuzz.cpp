// libFuzzer target for an assets directory's catalog.sqlite as `solid render`,
// `solid convert` (rerun) and `solid inspect` read it: Catalog::OpenReadOnly, every row
// (All, then Find by each key) and the content hash.
#include <cstdint>
#include <span>
#include <vector>

#include "fuzz/fuzz_util.h"
#include "solid/formats/catalog.h"

using solid::fuzz::Fail;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::filesystem::path path = solid::fuzz::ScratchDir() / "catalog.sqlite";
  solid::fuzz::RemoveSqliteFiles(path);
  solid::fuzz::WriteFileOrDie(path, std::span<const uint8_t>(data, size));
  {
    solid::Result<solid::Catalog> catalog = solid::Catalog::OpenReadOnly(path);
    if (catalog.ok()) {
      solid::Result<std::vector<solid::CatalogEntry>> rows = catalog->All();
      if (rows.ok()) {
        for (const solid::CatalogEntry& row : *rows) {
          solid::Result<std::optional<solid::CatalogEntry>> found = catalog->Find(row.key);
          if (found.ok() && found->has_value() && (*found)->key != row.key) Fail("Find returned another key's row");
        }
      }
      (void)catalog->ContentHash();
    }
  }
  solid::fuzz::RemoveSqliteFiles(path);
  return 0;
}
