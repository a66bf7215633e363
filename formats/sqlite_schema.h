// Internal: creating and recognising our SQLite files from the embedded DDL.
#pragma once

#include <string_view>

#include "solid/formats/status.h"
#include "sqlite_util.h"

namespace solid::sqlite {

// Executes schemas/<ddl_name> (which sets application_id and user_version) on a new database.
Status CreateSchema(Db& db, std::string_view ddl_name);

// Checks that db is a file of ours of exactly the DDL's version: application_id,
// user_version, and every table and index equal to what the DDL creates.
// kCorrupt for a foreign or altered file, kUnsupportedVersion for another version.
Status CheckSchema(Db& db, std::string_view ddl_name);

}  // namespace solid::sqlite
