"""Reading a solid dataset (docs/dataset-format.md) with sqlite3 and NumPy.

A `Dataset` holds only paths and small tables read from ``index.sqlite`` at open.
SQLite connections are opened on first use in each process and thread: a
connection must not cross a fork, and PyTorch's DataLoader forks its workers
from a process that has usually read from the dataset already.
"""

from __future__ import annotations

import io
import json
import os
import sqlite3
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import rle

__all__ = ["Dataset", "Image", "Instance", "QueryView", "decode_image"]

_FORMAT_VERSION = 2
# The values of schemas/{shard,queries,index}.sql, which are normative ('SL@S', 'SL@Q', 'SL@I').
_APPLICATION_IDS = {"shard": 1397506131, "queries": 1397506129, "index": 1397506121}


def decode_image(data: bytes) -> np.ndarray:
    """Encoded PNG, JPEG or WebP bytes as an H x W x 3 uint8 RGB array (Pillow)."""
    from PIL import Image as PILImage

    with PILImage.open(io.BytesIO(data)) as image:
        return np.asarray(image.convert("RGB"))


@dataclass(frozen=True)
class Instance:
    """One object of a target image, in render-id order (``ordinal``)."""

    instance_id: int
    ordinal: int
    model_key: str
    visible_rle: str
    full_rle: str
    visible_box: tuple[int, int, int, int]  # COCO x, y, w, h; all zero when invisible
    full_box: tuple[int, int, int, int]
    visible_area: int
    full_area: int
    occlusion: float | None
    truncation: float


@dataclass(frozen=True)
class Image:
    image_id: int
    width: int
    height: int
    image_format: str
    data: bytes  # the encoded image
    instances: tuple[Instance, ...]

    def pixels(self) -> np.ndarray:
        return decode_image(self.data)

    def visible_masks(self) -> np.ndarray:
        """N x H x W uint8, one visible mask per instance."""
        return self._masks("visible_rle")

    def full_masks(self) -> np.ndarray:
        return self._masks("full_rle")

    def _masks(self, field: str) -> np.ndarray:
        out = np.empty((len(self.instances), self.height, self.width), dtype=np.uint8)
        for k, instance in enumerate(self.instances):
            out[k] = rle.decode(getattr(instance, field), self.height, self.width)
        return out


@dataclass(frozen=True)
class QueryView:
    query_id: int
    model_key: str
    view_index: int
    azimuth: float
    elevation: float
    width: int
    height: int
    image_format: str
    data: bytes
    box: tuple[int, int, int, int]  # the object's COCO box in the crop

    def pixels(self) -> np.ndarray:
        return decode_image(self.data)


def _read_only(path: Path, immutable: bool) -> sqlite3.Connection:
    # immutable=1 skips file locking and change detection. Only for shards: they are
    # published complete by an atomic rename and never written again, whereas
    # index.sqlite may be rebuilt under a running reader.
    uri = path.resolve().as_uri() + ("?mode=ro&immutable=1" if immutable else "?mode=ro")
    return sqlite3.connect(uri, uri=True)


def _check_file(connection: sqlite3.Connection, kind: str, path: Path) -> None:
    application_id = connection.execute("PRAGMA application_id").fetchone()[0]
    user_version = connection.execute("PRAGMA user_version").fetchone()[0]
    if application_id != _APPLICATION_IDS[kind] or user_version != _FORMAT_VERSION:
        raise ValueError(f"{path}: not a solid {kind} file of format version {_FORMAT_VERSION} "
                         f"(application_id {application_id:#x}, user_version {user_version})")


def _resolve_inside(root: Path, relative: object, where: str) -> Path:
    """``root / relative`` for a path read from the dataset's own files, which must lead
    to something inside ``root``: an absolute path, ``..`` or a symbolic link that leaves
    the dataset directory is refused (ValueError naming ``where``)."""
    if not isinstance(relative, str) or not relative or "\0" in relative or os.path.isabs(relative):
        raise ValueError(f"{where}: file {relative!r} is not a path relative to {root}")
    real_root = root.resolve()
    # resolve() follows symbolic links and folds "..", as opening the file would.
    path = (real_root / relative).resolve()
    if real_root not in path.parents:
        raise ValueError(f"{where}: file {relative!r} leads out of {root}")
    return path


class Dataset:
    """A rendered dataset directory: ``manifest.json``, ``index.sqlite``, shards and query shards.

    Needs ``index.sqlite`` (``solid index DIR`` rebuilds it) for the lookups by model and for
    the list of images with instances.
    """

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)
        with open(self.root / "manifest.json", encoding="utf-8") as f:
            self.manifest = json.load(f)
        if self.manifest.get("format") != "solid-dataset" or self.manifest.get("format_version") != _FORMAT_VERSION:
            raise ValueError(f"{self.root}: manifest.json is not a solid dataset of format version {_FORMAT_VERSION}")
        self.shard_size = int(self.manifest["shard_size"])
        index_path = self.root / "index.sqlite"
        if not index_path.exists():
            raise FileNotFoundError(f"{index_path} is missing: run `solid index {self.root}`")
        index = _read_only(index_path, immutable=False)
        try:
            _check_file(index, "index", index_path)
            # Index rows are data: each file must lie inside the dataset directory.
            self._shard_files = {
                k: _resolve_inside(self.root, f, f"{index_path}: shards row {k}")
                for k, f in index.execute("SELECT shard_index, file FROM shards")}
            self._query_shard_files = {
                k: _resolve_inside(self.root, f, f"{index_path}: query_shards row {k}")
                for k, f in index.execute("SELECT shard_index, file FROM query_shards")}
            rows = index.execute(
                "SELECT model_key, query_shard_index, view_count FROM models ORDER BY model_key").fetchall()
            occurrences = index.execute(
                "SELECT image_id, shard_index FROM occurrences GROUP BY image_id ORDER BY image_id").fetchall()
        finally:
            index.close()
        self.model_keys: tuple[str, ...] = tuple(r[0] for r in rows)
        self._model_rows = {key: (shard, views) for key, shard, views in rows}
        # Ordered by image id; the sampler groups them by shard as the reference reads chunks.
        self.annotated_image_ids = np.array([r[0] for r in occurrences], dtype=np.int64)
        self.annotated_image_shards = np.array([r[1] for r in occurrences], dtype=np.int64)
        self._local = threading.local()

    # Pickled into spawned DataLoader workers: paths and tables, never connections.
    def __getstate__(self):
        state = self.__dict__.copy()
        del state["_local"]
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._local = threading.local()

    def _connection(self, kind: str, shard_index: int) -> sqlite3.Connection:
        local = self._local
        if getattr(local, "pid", None) != os.getpid():
            # Connections inherited through fork belong to the parent; never use them.
            local.pid = os.getpid()
            local.connections = {}
        key = (kind, shard_index)
        connection = local.connections.get(key)
        if connection is None:
            files = self._shard_files if kind == "shard" else self._query_shard_files
            if shard_index not in files:
                raise KeyError(f"{kind} shard {shard_index} is not in {self.root / 'index.sqlite'}")
            path = files[shard_index]
            connection = _read_only(path, immutable=True)
            _check_file(connection, kind, path)
            local.connections[key] = connection
        return connection

    def close(self) -> None:
        """Closes this thread's connections (others close with their thread or process)."""
        for connection in getattr(self._local, "connections", {}).values():
            connection.close()
        self._local = threading.local()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- target images -----------------------------------------------------------------------

    def image_ids(self) -> np.ndarray:
        """Ids of every stored image, instances or not, ascending (reads every shard)."""
        ids = []
        for shard_index in sorted(self._shard_files):
            ids.extend(r[0] for r in self._connection("shard", shard_index).execute(
                "SELECT image_id FROM images ORDER BY image_id"))
        return np.array(ids, dtype=np.int64)

    def image(self, image_id: int) -> Image:
        image_id = int(image_id)
        db = self._connection("shard", image_id // self.shard_size)
        row = db.execute("SELECT width, height, image_format, image FROM images WHERE image_id = ?",
                         (image_id,)).fetchone()
        if row is None:
            raise KeyError(f"image {image_id} is not in the dataset")
        return Image(image_id, row[0], row[1], row[2], bytes(row[3]), self._instances(db, image_id))

    def instances(self, image_id: int) -> tuple[Instance, ...]:
        """The image's instances without reading its pixels."""
        image_id = int(image_id)
        return self._instances(self._connection("shard", image_id // self.shard_size), image_id)

    @staticmethod
    def _instances(db: sqlite3.Connection, image_id: int) -> tuple[Instance, ...]:
        rows = db.execute(
            "SELECT instance_id, ordinal, model_key, visible_rle, full_rle, "
            "visible_x, visible_y, visible_w, visible_h, full_x, full_y, full_w, full_h, "
            "visible_area, full_area, occlusion, truncation "
            "FROM instances WHERE image_id = ? ORDER BY ordinal", (image_id,))
        return tuple(Instance(r[0], r[1], r[2], r[3], r[4], tuple(r[5:9]), tuple(r[9:13]), r[13], r[14], r[15],
                              r[16]) for r in rows)

    # -- models and query views --------------------------------------------------------------

    def view_count(self, model_key: str) -> int:
        """Query views of a model; 0 when it has none (or none rendered yet)."""
        shard, views = self._model_rows.get(model_key, (None, 0))
        return 0 if shard is None else int(views)

    def query_views(self, model_key: str) -> list[QueryView]:
        return self._query_views(model_key, "ORDER BY view_index", ())

    def query_view(self, model_key: str, view_index: int) -> QueryView:
        views = self._query_views(model_key, "AND view_index = ?", (int(view_index),))
        if not views:
            raise KeyError(f"model {model_key!r} has no query view {view_index}")
        return views[0]

    def nth_query_view(self, model_key: str, n: int) -> QueryView:
        """The model's n-th view in view_index order, 0 <= n < view_count: failed views leave
        gaps in the view indices, so this is how to pick one of them uniformly."""
        views = self._query_views(model_key, "ORDER BY view_index LIMIT 1 OFFSET ?", (int(n),))
        if not views:
            raise KeyError(f"model {model_key!r} has no query view at position {n}")
        return views[0]

    def _query_views(self, model_key: str, where: str, args: tuple) -> list[QueryView]:
        shard, _ = self._model_rows.get(model_key, (None, 0))
        if shard is None:
            return []
        rows = self._connection("queries", shard).execute(
            "SELECT query_id, model_key, view_index, azimuth, elevation, width, height, image_format, image, "
            "box_x, box_y, box_w, box_h FROM query_views WHERE model_key = ? " + where, (model_key,) + args)
        return [QueryView(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], bytes(r[8]), tuple(r[9:13])) for r in rows]
