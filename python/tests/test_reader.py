import json
import multiprocessing
import pickle
import re
import shutil
import sqlite3
import tempfile
import unittest
from pathlib import Path

import numpy as np

import fixture
from solid_data import Dataset, dataset, rle

SCHEMAS = Path(__file__).resolve().parents[2] / "schemas"


class SchemaConstantsTest(unittest.TestCase):
    def test_application_ids_are_the_schemas(self):
        for kind, file in (("shard", "shard.sql"), ("queries", "queries.sql"), ("index", "index.sql")):
            text = (SCHEMAS / file).read_text()
            self.assertEqual(dataset._APPLICATION_IDS[kind],
                             int(re.search(r"PRAGMA application_id = (\d+);", text).group(1)), file)
            self.assertEqual(dataset._FORMAT_VERSION, int(re.search(r"PRAGMA user_version = (\d+);", text).group(1)))


def _last_image_checksum() -> int:
    # Runs in forked children that inherit a Dataset which has already read in the parent.
    image = _shared_dataset.image(int(_shared_dataset.annotated_image_ids[-1]))
    return int(np.asarray(image.pixels(), dtype=np.int64).sum())


_shared_dataset: Dataset | None = None


class ReaderTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.root = fixture.dataset_dir()
        cls.ds = Dataset(cls.root)

    @classmethod
    def tearDownClass(cls):
        cls.ds.close()

    def stored_rows(self, sql):
        rows = []
        for shard in sorted((self.root / "shards").glob("shard-*.sqlite")):
            with sqlite3.connect(f"file:{shard}?mode=ro", uri=True) as db:
                rows.extend(db.execute(sql).fetchall())
        return rows

    def test_images_and_their_ids(self):
        manifest = json.loads((self.root / "manifest.json").read_text())
        ids = self.ds.image_ids()
        self.assertEqual(ids.tolist(), sorted(r[0] for r in self.stored_rows("SELECT image_id FROM images")))
        self.assertGreater(ids.size, fixture.IMAGES // 2)
        with_instances = sorted({r[0] for r in self.stored_rows("SELECT image_id FROM instances")})
        self.assertEqual(self.ds.annotated_image_ids.tolist(), with_instances)
        self.assertTrue(np.all(self.ds.annotated_image_shards == self.ds.annotated_image_ids // fixture.SHARD_SIZE))
        image = self.ds.image(int(ids[0]))
        self.assertEqual(image.pixels().shape, (manifest["height"], manifest["width"], 3))
        with self.assertRaises(KeyError):
            self.ds.image(fixture.IMAGES + 5)

    def test_masks_agree_with_stored_areas_and_boxes(self):
        checked = 0
        for image_id in self.ds.annotated_image_ids:
            image = self.ds.image(int(image_id))
            self.assertGreater(len(image.instances), 0)
            self.assertEqual([i.ordinal for i in image.instances], sorted(i.ordinal for i in image.instances))
            visible, full = image.visible_masks(), image.full_masks()
            for inst, v, f in zip(image.instances, visible, full):
                self.assertEqual(int(v.sum()), inst.visible_area)
                self.assertEqual(int(f.sum()), inst.full_area)
                self.assertEqual(rle.bbox(v), inst.visible_box)
                self.assertEqual(rle.bbox(f), inst.full_box)
                self.assertFalse(np.any(v & ~f), "the visible mask leaves the full mask")
                checked += 1
        self.assertGreater(checked, fixture.IMAGES)

    def test_query_views_by_model(self):
        with_views = [k for k in self.ds.model_keys if self.ds.view_count(k) > 0]
        self.assertGreater(len(with_views), 0)
        used = {r[0] for r in self.stored_rows("SELECT DISTINCT model_key FROM instances")}
        self.assertEqual(set(self.ds.model_keys), used)
        for key in with_views:
            views = self.ds.query_views(key)
            self.assertEqual(len(views), self.ds.view_count(key))
            self.assertTrue(all(v.model_key == key for v in views))
            for n, view in enumerate(views):
                self.assertEqual(self.ds.nth_query_view(key, n).query_id, view.query_id)
                self.assertEqual(self.ds.query_view(key, view.view_index).query_id, view.query_id)
                pixels = view.pixels()
                self.assertEqual(pixels.shape, (view.height, view.width, 3))
                x, y, w, h = view.box
                self.assertTrue(0 <= x and 0 <= y and x + w <= view.width and y + h <= view.height)
        self.assertEqual(self.ds.view_count("no/such-model"), 0)
        self.assertEqual(self.ds.query_views("no/such-model"), [])

    def test_forked_child_opens_its_own_connections(self):
        global _shared_dataset
        _shared_dataset = Dataset(self.root)
        expected = _last_image_checksum()  # opens the shard in this process first
        with multiprocessing.get_context("fork").Pool(2) as pool:
            results = pool.starmap(_last_image_checksum, [()] * 4)
        self.assertEqual(results, [expected] * 4)
        _shared_dataset.close()

    def test_pickles_without_its_connections(self):
        # What a spawned DataLoader worker receives.
        image_id = int(self.ds.annotated_image_ids[0])
        self.ds.image(image_id)
        copy = pickle.loads(pickle.dumps(self.ds))
        self.assertEqual(copy.image(image_id).data, self.ds.image(image_id).data)
        copy.close()

    def test_refuses_index_rows_that_lead_out_of_the_dataset(self):
        outside = Path(self.root).parent / "elsewhere.sqlite"
        cases = {"absolute": str(outside), "dotdot": "shards/../../elsewhere.sqlite", "symlink": "shards/link.sqlite"}
        for name, file in cases.items():
            with self.subTest(name), tempfile.TemporaryDirectory() as scratch:
                copy = Path(scratch) / "ds"
                shutil.copytree(self.root, copy, symlinks=True)
                if name == "symlink":
                    (copy / "shards" / "link.sqlite").symlink_to(outside)
                with sqlite3.connect(copy / "index.sqlite") as index:
                    row = index.execute("SELECT MIN(shard_index) FROM shards").fetchone()[0]
                    index.execute("UPDATE shards SET file = ? WHERE shard_index = ?", (file, row))
                index.close()
                with self.assertRaisesRegex(ValueError, rf"index.sqlite: shards row {row}: file .* leads out of|"
                                                        rf"index.sqlite: shards row {row}: file .* is not a path"):
                    Dataset(copy)

    def test_rejects_what_is_not_a_dataset(self):
        with self.assertRaises(FileNotFoundError):
            Dataset(self.root / "shards")


if __name__ == "__main__":
    unittest.main()
