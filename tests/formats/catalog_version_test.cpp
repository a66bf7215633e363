// Catalog schema versions: a version-1 catalog (schemas/catalog_v1.sql, before the glTF and
// OBJ-folder sources) is still read as it is, and migrated in place when written.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <fstream>
#include <sstream>

#include "formats/test_util.h"
#include "solid/formats/catalog.h"

namespace solid {
namespace {

CatalogEntry Row(std::string key, std::string source) {
  CatalogEntry e;
  e.key = std::move(key);
  e.kind = "model";
  e.source = std::move(source);
  e.file = "models/" + e.key + ".glb";
  e.input_hash = 0x1234;
  e.converter_version = "test";
  e.output_xxh64 = 42;
  e.extras = {{"synset", "02691156"}};
  return e;
}

int64_t UserVersion(const std::filesystem::path& path) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* s = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, "PRAGMA user_version", -1, &s, nullptr), SQLITE_OK);
  EXPECT_EQ(sqlite3_step(s), SQLITE_ROW);
  const int64_t v = sqlite3_column_int64(s, 0);
  sqlite3_finalize(s);
  sqlite3_close(db);
  return v;
}

TEST(CatalogVersion, Version1IsReadAsItIsAndMigratedWhenWritten) {
  testing::TempDir dir;
  const auto path = dir.path() / "catalog.sqlite";
  std::ifstream ddl_file(std::string(SOLID_SCHEMAS_DIR) + "/catalog_v1.sql");
  std::stringstream ddl;
  ddl << ddl_file.rdbuf();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, ddl.str().c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
  // What a version-1 converter wrote; a glTF source did not exist then.
  ASSERT_EQ(sqlite3_exec(db,
                         "INSERT INTO assets (key, kind, source, file, status, input_files, input_hash, "
                         "converter_version, options_hash, output_xxh64, extras) VALUES ('02691156/a', 'model', "
                         "'shapenet_v2', 'models/02691156/a.glb', 'ok', '[]', '0000000000001234', 'old', "
                         "'0000000000000000', 42, '{\"synset\": \"02691156\"}')",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  EXPECT_NE(sqlite3_exec(db,
                         "INSERT INTO assets (key, kind, source, status, input_files, input_hash, converter_version, "
                         "options_hash) VALUES ('b', 'model', 'gltf', 'failed', '[]', '0', 'old', '0')",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  ASSERT_EQ(UserVersion(path), 1);
  {
    auto read = Catalog::OpenReadOnly(path);
    ASSERT_TRUE(read.ok()) << read.status().ToString();
    auto row = read->Find("02691156/a");
    ASSERT_TRUE(row.ok() && *row);
    EXPECT_EQ((*row)->source, "shapenet_v2");
  }
  EXPECT_EQ(UserVersion(path), 1) << "reading must not migrate";
  {
    auto write = Catalog::OpenForWriting(path);
    ASSERT_TRUE(write.ok()) << write.status().ToString();
    ASSERT_OK(write->Put(Row("uid123", "gltf")));
    ASSERT_OK(write->Put(Row("Mug", "obj")));
    auto all = write->All();
    ASSERT_TRUE(all.ok());
    ASSERT_EQ(all->size(), 3u);
    EXPECT_EQ((*all)[0].key, "02691156/a");
    EXPECT_EQ((*all)[0].extras["synset"], "02691156");
    EXPECT_EQ((*all)[0].output_xxh64, 42u);
    ASSERT_OK(write->Close());
  }
  EXPECT_EQ(UserVersion(path), 2);
  auto again = Catalog::OpenReadOnly(path);
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  auto uid = again->Find("uid123");
  ASSERT_TRUE(uid.ok() && *uid);
  EXPECT_EQ((*uid)->source, "gltf");
}

TEST(CatalogVersion, AFutureVersionIsRefused) {
  testing::TempDir dir;
  const auto path = dir.path() / "catalog.sqlite";
  { ASSERT_TRUE(Catalog::OpenForWriting(path).ok()); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "PRAGMA user_version = 3", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  EXPECT_EQ(Catalog::OpenReadOnly(path).status().code(), StatusCode::kUnsupportedVersion);
  EXPECT_EQ(Catalog::OpenForWriting(path).status().code(), StatusCode::kUnsupportedVersion);
}

}  // namespace
}  // namespace solid
