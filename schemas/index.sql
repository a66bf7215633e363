-- solid dataset index: index.sqlite, rebuilt from the shards present by `solid index`.
-- Derived data only: deleting it loses nothing. Conventions as in shard.sql.

PRAGMA application_id = 1397506121;  -- 0x534C4049, 'SL@I'
PRAGMA user_version = 2;

CREATE TABLE index_meta (
  key   TEXT PRIMARY KEY NOT NULL,
  value TEXT NOT NULL
) WITHOUT ROWID;

CREATE TABLE shards (
  shard_index    INTEGER PRIMARY KEY,
  file           TEXT NOT NULL UNIQUE,    -- relative to the dataset root
  bytes          INTEGER NOT NULL,
  file_xxh64     INTEGER NOT NULL,        -- of the whole file as indexed
  images         INTEGER NOT NULL,
  instances      INTEGER NOT NULL,
  first_image_id INTEGER,
  last_image_id  INTEGER
);

CREATE TABLE query_shards (
  shard_index INTEGER PRIMARY KEY,
  file        TEXT NOT NULL UNIQUE,
  bytes       INTEGER NOT NULL,
  file_xxh64  INTEGER NOT NULL,
  models      INTEGER NOT NULL,
  views       INTEGER NOT NULL
);

-- model key -> every (shard, image) it occurs in, with its instance count there.
CREATE TABLE occurrences (
  model_key   TEXT NOT NULL,
  image_id    INTEGER NOT NULL,
  shard_index INTEGER NOT NULL REFERENCES shards (shard_index),
  instances   INTEGER NOT NULL,
  PRIMARY KEY (model_key, image_id)
) WITHOUT ROWID;

CREATE TABLE models (
  model_key         TEXT PRIMARY KEY NOT NULL,
  instances         INTEGER NOT NULL,
  images            INTEGER NOT NULL,
  query_shard_index INTEGER,              -- NULL when the model has no query views yet
  view_count        INTEGER NOT NULL
) WITHOUT ROWID;

-- Aggregated proxy metrics over the indexed shards (names in docs/dataset-format.md).
CREATE TABLE metrics (
  name  TEXT PRIMARY KEY NOT NULL,
  value REAL NOT NULL
) WITHOUT ROWID;
