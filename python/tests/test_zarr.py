"""`solid export zarr` read back by the ecosystem's own reader: Debian's zarr 2.13 and
numcodecs 0.11 open the store, and every exported image, box, mask, statistic and query view
equals what solid_data reads from the dataset. The reference pretraining reader's rules
(princeton-vl/SOLID detection/pretrain/dataset.py) are checked as it reads: whole chunks,
views in every slot of every class, query_ids = arange."""

from __future__ import annotations

import json
import os
import sqlite3
import subprocess
import tempfile
import unittest
from pathlib import Path

import numpy as np

import fixture
from solid_data import Dataset

try:
    import numcodecs
    import zarr
except ImportError:  # the test skips below
    zarr = None

CHUNK = 8


def _blender_euler_xyz(m: np.ndarray) -> np.ndarray:
    """mathutils' Matrix.to_euler('XYZ') of the reference's get_angles: columns normalised, then
    of the two solutions the one with the smaller sum of magnitudes."""
    m = m / np.linalg.norm(m, axis=0, keepdims=True)
    cy = np.hypot(m[0, 0], m[1, 0])
    if cy <= 16 * np.finfo(np.float32).eps:
        return np.array([np.arctan2(-m[1, 2], m[1, 1]), np.arctan2(-m[2, 0], cy), 0.0])
    a = np.array([np.arctan2(m[2, 1], m[2, 2]), np.arctan2(-m[2, 0], cy), np.arctan2(m[1, 0], m[0, 0])])
    b = np.array([np.arctan2(-m[2, 1], -m[2, 2]), np.arctan2(-m[2, 0], -cy), np.arctan2(-m[1, 0], -m[0, 0])])
    return b if np.abs(a).sum() > np.abs(b).sum() else a


def _rotation(blob: bytes) -> np.ndarray:
    return np.frombuffer(blob, dtype="<f8").reshape(3, 4)[:, :3]


@unittest.skipIf(zarr is None, "zarr and numcodecs are not importable (apt-get install python3-zarr python3-numcodecs)")
class ZarrExportTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.root = fixture.dataset_dir()
        cls.scratch = tempfile.TemporaryDirectory(prefix="solid-zarr-")
        cls.store = Path(cls.scratch.name) / "store"
        done = subprocess.run([os.environ["SOLID_BINARY"], "export", "zarr", str(cls.root), str(cls.store),
                               "--chunk", str(CHUNK)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"solid export zarr exited with {done.returncode}:\n{done.stderr}")
        cls.z = zarr.open(str(cls.store), "r")
        cls.ds = Dataset(cls.root)

    @classmethod
    def tearDownClass(cls):
        cls.ds.close()
        cls.scratch.cleanup()

    def exported_ids(self) -> list[int]:
        """Images with at least one visible instance, in id order."""
        return [int(i) for i in self.ds.image_ids() if any(x.visible_area > 0 for x in self.ds.instances(i))]

    def poses(self, image_id: int) -> tuple[np.ndarray, dict[int, np.ndarray]]:
        shard = self.root / "shards" / f"shard-{image_id // self.ds.shard_size:06d}.sqlite"
        with sqlite3.connect(f"file:{shard}?mode=ro", uri=True) as db:
            camera = db.execute("SELECT world_from_camera FROM images WHERE image_id = ?", (image_id,)).fetchone()[0]
            objects = dict(db.execute("SELECT ordinal, world_from_object FROM instances WHERE image_id = ?",
                                      (image_id,)).fetchall())
        return _rotation(camera), {k: _rotation(v) for k, v in objects.items()}

    def test_every_row_is_the_dataset(self):
        ids = self.exported_ids()
        z = self.z
        self.assertEqual(len(z["images"]), len(ids))
        self.assertEqual(z["solid_image_ids"][:].tolist(), ids)
        classes = {key: k for k, key in enumerate(self.ds.model_keys)}
        images, bboxes, masks = z["images"][:], z["bboxes"][:], z["masks"][:]
        visibilities, ratios, angles = z["visibilities"][:], z["mask_bbox_ratios"][:], z["angles"][:]
        for row, image_id in enumerate(ids):
            with self.subTest(image=image_id, row=row):
                image = self.ds.image(image_id)
                visible = [x for x in image.instances if x.visible_area > 0]
                self.assertEqual(images[row].dtype, np.int8)
                self.assertEqual(images[row].tobytes(), image.data)
                want_boxes = [[x, y, x + w, y + h, classes[i.model_key]] for i in visible for x, y, w, h in [i.visible_box]]
                self.assertEqual(bboxes[row].dtype, np.int32)
                self.assertEqual(bboxes[row].reshape(-1, 5).tolist(), want_boxes)
                by_ordinal = {i.ordinal: k for k, i in enumerate(image.instances)}
                want_masks = image.visible_masks()[[by_ordinal[i.ordinal] for i in visible]]
                np.testing.assert_array_equal(masks[row].reshape(-1, image.height, image.width), want_masks)
                np.testing.assert_array_equal(
                    visibilities[row], np.array([i.visible_area / i.full_area for i in visible], dtype=np.float32))
                np.testing.assert_array_equal(
                    ratios[row], np.array([i.visible_area / (i.visible_box[2] * i.visible_box[3]) for i in visible],
                                          dtype=np.float32))
                camera, objects = self.poses(image_id)
                want_angles = [_blender_euler_xyz(camera.T @ objects[i.ordinal]) for i in visible]
                np.testing.assert_allclose(angles[row].reshape(-1, 3), np.array(want_angles), atol=1e-5)

    def test_queries_cycle_the_views_of_every_class(self):
        queries = self.z["queries"][:]
        self.assertEqual(queries.shape, (len(self.ds.model_keys), 8))
        for k, key in enumerate(self.ds.model_keys):
            n = self.ds.view_count(key)
            self.assertGreater(n, 0, key)
            for j in range(8):
                self.assertEqual(queries[k, j].tobytes(), self.ds.nth_query_view(key, j % n).data, (key, j))

    def test_the_reference_readers_rules(self):
        z = self.z
        images = z["images"]
        n, chunk = len(images), images.chunks[0]
        self.assertEqual(chunk, CHUNK)
        for key in ("images", "bboxes", "masks", "visibilities", "mask_bbox_ratios", "angles"):
            self.assertEqual(z[key].nchunks_initialized, z[key].nchunks, f"{key}: a chunk is missing")
        # load_data: whole chunks [sid, eid), each image with boxes and masks.
        for sid in range(0, n, chunk):
            eid = min(sid + chunk, n)
            for boxes, mask in zip(z["bboxes"][sid:eid], z["masks"][sid:eid]):
                self.assertGreater(len(boxes), 0)
                self.assertGreater(len(mask), 0)
        # _load_queries skips None only; an empty view would crash the decoder when sampled.
        query_ids = z["query_ids"][:]
        np.testing.assert_array_equal(query_ids, np.arange(z["queries"].shape[0]))
        for row, query_id in zip(z["queries"][:], query_ids):
            self.assertEqual(sum(q is not None and len(q) > 0 for q in row), 8, query_id)
        # The class of every box has a query row: ZarrDataset's id_map covers both.
        cls_ids = {int(c) for b in z["bboxes"][:] for c in b.reshape(-1, 5)[:, 4]}
        self.assertTrue(cls_ids <= set(query_ids.tolist()))
        self.assertTrue(z["valids"][:].all())
        about = json.loads((self.store / "solid_export.json").read_text())
        self.assertEqual(about["classes"], list(self.ds.model_keys))

    def test_metadata_and_chunks_are_what_zarr_itself_writes(self):
        """The reference's create_zarr.py calls and its writes of the same values give the
        same .zarray files and the same chunk bytes (numcodecs' VLenArray and Blosc)."""
        z = self.z
        n, classes = len(z["images"]), z["queries"].shape[0]
        # Blosc's threads write a chunk's blocks in the order they finish, so a threaded
        # write of a chunk over one block (131072 bytes here) has bytes that vary from run
        # to run; one thread writes them in order, as the export does.
        numcodecs.blosc.use_threads = False
        ref = zarr.open(str(Path(self.scratch.name) / "reference"), "a")
        ref.zeros("valids", shape=n, dtype=bool)
        ref.empty("images", shape=n, dtype="array:i1", chunks=CHUNK, compressor=None)
        ref.empty("bboxes", shape=n, dtype="array:i4", chunks=CHUNK)
        ref.empty("masks", shape=n, dtype="array:i1", chunks=CHUNK)
        ref.empty("queries", shape=(classes, 8), dtype="array:i1", chunks=CHUNK, compressor=None)
        ref.zeros("query_ids", shape=classes, dtype=int)
        ref.empty("scenenet_models", shape=n, dtype="S128")
        for key in ("visibilities", "mask_bbox_ratios", "angles"):
            ref.empty(key, shape=n, dtype="array:f4", chunks=CHUNK)
        self.assertIsInstance(ref["masks"].compressor, numcodecs.Blosc)
        for key in ref.array_keys():
            ours = (self.store / key / ".zarray").read_text()
            theirs = (Path(ref.store.path) / key / ".zarray").read_text()
            self.assertEqual(ours, theirs, key)
        for key in ("images", "bboxes", "masks", "visibilities", "mask_bbox_ratios", "angles"):
            ref[key][:] = np.array(list(z[key][:]) + [None], dtype=object)[:-1]
        ref["queries"][:] = z["queries"][:]
        ref["query_ids"][:] = np.arange(classes)
        ref["valids"][:] = True
        for key in ("images", "bboxes", "masks", "visibilities", "mask_bbox_ratios", "angles", "queries",
                    "query_ids", "valids"):
            chunks = sorted(p.name for p in (Path(ref.store.path) / key).iterdir() if not p.name.startswith("."))
            self.assertEqual(sorted(p.name for p in (self.store / key).iterdir() if not p.name.startswith(".")),
                             chunks, key)
            for name in chunks:
                self.assertEqual((self.store / key / name).read_bytes(),
                                 (Path(ref.store.path) / key / name).read_bytes(), f"{key}/{name}")


if __name__ == "__main__":
    unittest.main()
