-- solid query-view shard: queries/queries-NNNNNN.sqlite. Every model used by the
-- targets gets its views once per dataset; a model lives in exactly one query shard.
-- Conventions as in shard.sql.

PRAGMA application_id = 1397506129;  -- 0x534C4051, 'SL@Q'
PRAGMA user_version = 2;

CREATE TABLE shard_meta (
  key   TEXT PRIMARY KEY NOT NULL,
  value TEXT NOT NULL,
  row_xxh64 INTEGER NOT NULL
) WITHOUT ROWID;

-- One row per model rendered into this shard, including models whose views all
-- failed (view_count 0, failure says why), so that failures are never silent.
CREATE TABLE query_models (
  model_key  TEXT PRIMARY KEY NOT NULL,
  view_count INTEGER NOT NULL CHECK (view_count >= 0),
  failure    TEXT,
  row_xxh64  INTEGER NOT NULL
) WITHOUT ROWID;

CREATE TABLE query_views (
  query_id     INTEGER PRIMARY KEY,
  model_key    TEXT NOT NULL REFERENCES query_models (model_key),
  view_index   INTEGER NOT NULL CHECK (view_index >= 0),
  azimuth      REAL NOT NULL,             -- turntable angle about the vertical axis, radians
  elevation    REAL NOT NULL,             -- radians
  width        INTEGER NOT NULL CHECK (width > 0),
  height       INTEGER NOT NULL CHECK (height > 0),
  image_format TEXT NOT NULL CHECK (image_format IN ('png', 'jpeg', 'webp')),
  image        BLOB NOT NULL,
  image_xxh64  INTEGER NOT NULL,
  box_x INTEGER NOT NULL, box_y INTEGER NOT NULL,  -- the object's box in the stored crop
  box_w INTEGER NOT NULL, box_h INTEGER NOT NULL,
  row_xxh64    INTEGER NOT NULL,
  UNIQUE (model_key, view_index)
);
