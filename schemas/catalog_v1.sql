-- solid asset catalog, version 1 (before glTF and OBJ-folder sources): kept so that
-- catalogs written by older converters are still recognised, read, and migrated to
-- catalog.sql when written. Not for new files.
-- OUT/catalog.sqlite next to models/ and rooms/ of an assets
-- directory. One row per converted (or failed) model or room, written after its file.
-- Unlike shards, the catalog is updated in place as a batch runs (WAL journal).
-- Conventions as in shard.sql.

PRAGMA application_id = 1397506115;  -- 0x534C4043, 'SL@C'
PRAGMA user_version = 1;

CREATE TABLE catalog_meta (
  key   TEXT PRIMARY KEY NOT NULL,
  value TEXT NOT NULL
) WITHOUT ROWID;

CREATE TABLE assets (
  key               TEXT PRIMARY KEY NOT NULL,  -- 'synset/model_id', a SceneNet scene path, 'procedural/shape-000001'
  kind              TEXT NOT NULL CHECK (kind IN ('model', 'room')),
  source            TEXT NOT NULL CHECK (source IN ('shapenet_v1', 'shapenet_v2', 'scenenet', 'procedural')),
  file              TEXT,                     -- .glb relative to the assets directory; NULL when failed
  status            TEXT NOT NULL CHECK (status IN ('ok', 'ok_with_warnings', 'failed')),
  input_files       TEXT NOT NULL,            -- JSON array of input paths relative to the source root
  input_hash        TEXT NOT NULL,            -- 16 hex digits: XXH64 over the input files' names and bytes
  converter_version TEXT NOT NULL,
  options_hash      TEXT NOT NULL,            -- 16 hex digits: the options that change the output
  vertices          INTEGER NOT NULL DEFAULT 0,
  triangles         INTEGER NOT NULL DEFAULT 0,
  materials         INTEGER NOT NULL DEFAULT 0,
  textures          INTEGER NOT NULL DEFAULT 0,
  min_x REAL, min_y REAL, min_z REAL,         -- glTF frame (+Y up); NULL when failed
  max_x REAL, max_y REAL, max_z REAL,
  bytes_in          INTEGER NOT NULL DEFAULT 0,
  bytes_out         INTEGER NOT NULL DEFAULT 0,
  output_xxh64      INTEGER,                  -- of the .glb; NULL when failed
  warnings          TEXT NOT NULL DEFAULT '[]',  -- JSON array of {"code", "message"}
  error_code        TEXT,                     -- failure code (missing_obj, parse_error...) when failed
  error             TEXT,                     -- message naming file and line where that applies
  counts            TEXT NOT NULL DEFAULT '{}',  -- JSON object: cleaning and parsing counters
  extras            TEXT NOT NULL DEFAULT '{}',  -- JSON object: per-source details (room floor area...)
  CHECK ((status = 'failed') = (file IS NULL))
) WITHOUT ROWID;
