-- solid target shard: one SQLite file per shard, shards/shard-NNNNNN.sqlite.
-- Images [K * shard_size, (K + 1) * shard_size) of the dataset live in shard K.
-- This file is the single source of truth: the library embeds and executes it,
-- and reads the expected application_id / user_version from it.
--
-- Conventions: 64-bit unsigned values (seeds, xxHash64 checksums) are stored in
-- INTEGER columns as the signed 64-bit integer with the same bits. Every BLOB or
-- mask string has a sibling <column>_xxh64 = XXH64(bytes, seed 0), and every row
-- of every table a last column row_xxh64: XXH64 of all its other values
-- (docs/dataset-format.md, "Checksums"). shard_meta's content_xxh64 covers the
-- set of rows. Boxes are COCO
-- [x, y, w, h] in pixels (x, y of the top-left pixel; w, h >= 0; all zero for an
-- empty mask). Masks are COCO compressed RLE strings (column-major runs).
-- Matrices are BLOBs of 12 little-endian float64, row-major 3x4 [R | t].
-- World frame: metres, Z up. Camera frame: looks along -Z, +Y up.

PRAGMA application_id = 1397506131;  -- 0x534C4053, 'SL@S'
PRAGMA user_version = 2;

-- Per-shard provenance and bookkeeping: shard_index, manifest (what the shard was
-- made from), content_xxh64, stage timings (JSON)... Keys are documented in
-- docs/dataset-format.md.
CREATE TABLE shard_meta (
  key   TEXT PRIMARY KEY NOT NULL,
  value TEXT NOT NULL,
  row_xxh64 INTEGER NOT NULL
) WITHOUT ROWID;

CREATE TABLE images (
  image_id     INTEGER PRIMARY KEY CHECK (image_id >= 0),  -- dataset-global index i
  seed         INTEGER NOT NULL,          -- hash(dataset seed, i): re-renders image i alone
  width        INTEGER NOT NULL CHECK (width > 0),
  height       INTEGER NOT NULL CHECK (height > 0),
  image_format TEXT NOT NULL CHECK (image_format IN ('png', 'jpeg', 'webp')),
  image        BLOB NOT NULL,
  image_xxh64  INTEGER NOT NULL,
  -- pinhole intrinsics in pixels (principal point in pixel coordinates, origin at the
  -- top-left corner of the top-left pixel)
  fx REAL NOT NULL, fy REAL NOT NULL, cx REAL NOT NULL, cy REAL NOT NULL,
  world_from_camera       BLOB NOT NULL,
  world_from_camera_xxh64 INTEGER NOT NULL,
  depth        BLOB,                      -- optional OpenEXR, one half-float channel Z, metres
  depth_xxh64  INTEGER,
  room_key     TEXT,                      -- asset key of the room, NULL for none
  row_xxh64    INTEGER NOT NULL,
  CHECK ((depth IS NULL) = (depth_xxh64 IS NULL))
);

CREATE TABLE instances (
  instance_id   INTEGER PRIMARY KEY,
  image_id      INTEGER NOT NULL REFERENCES images (image_id),
  ordinal       INTEGER NOT NULL CHECK (ordinal >= 0),  -- render-id order within the image
  model_key     TEXT NOT NULL,            -- asset catalog key, e.g. 'synset/model_id'
  visible_rle   TEXT NOT NULL,
  visible_rle_xxh64 INTEGER NOT NULL,
  full_rle      TEXT NOT NULL,            -- the object with everything else hidden
  full_rle_xxh64 INTEGER NOT NULL,
  visible_x INTEGER NOT NULL, visible_y INTEGER NOT NULL,
  visible_w INTEGER NOT NULL, visible_h INTEGER NOT NULL,
  full_x INTEGER NOT NULL, full_y INTEGER NOT NULL,
  full_w INTEGER NOT NULL, full_h INTEGER NOT NULL,
  visible_area  INTEGER NOT NULL CHECK (visible_area >= 0),  -- n_p
  full_area     INTEGER NOT NULL CHECK (full_area >= visible_area),  -- n_f
  occlusion     REAL,                     -- (n_f - n_p) / n_f; NULL when n_f = 0
  truncation    REAL NOT NULL CHECK (truncation >= 0 AND truncation <= 1),
  scale_class   TEXT CHECK (scale_class IN ('small', 'medium', 'large')),  -- NULL when n_p = 0
  world_from_object       BLOB NOT NULL,  -- pose with scale
  world_from_object_xxh64 INTEGER NOT NULL,
  object_scale  REAL NOT NULL,            -- largest local extent, metres
  camera_distance REAL NOT NULL,          -- camera centre to object centre, metres
  view_azimuth  REAL NOT NULL,            -- camera direction in the object frame, radians
  view_elevation REAL NOT NULL,
  row_xxh64     INTEGER NOT NULL,
  UNIQUE (image_id, ordinal)
);

CREATE INDEX instances_by_model ON instances (model_key, image_id);
