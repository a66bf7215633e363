import io
import unittest

import numpy as np

import fixture
from solid_data import Dataset, rle

try:
    import torch
    from PIL import Image as PILImage

    from solid_data.torch import PretrainBatchSampler, pretrain_loader
except ImportError as error:  # the reader tests still run without PyTorch
    raise unittest.SkipTest(f"PyTorch is not importable: {error}")

TARGETS = 4
QUERIES = 8


def batches(root, seed, num_workers, **options):
    loader = pretrain_loader(root, seed=seed, num_workers=num_workers, targets_per_batch=TARGETS,
                             cache_images=fixture.SHARD_SIZE, queries_per_batch=QUERIES, **options)
    return list(loader)


def box_of(mask):
    """Half-open [x1, y1, x2, y2] by a route independent of the reader's."""
    ys, xs = np.nonzero(mask)
    return [xs.min(), ys.min(), xs.max() + 1, ys.max() + 1]


class PretrainBatchesTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.root = fixture.dataset_dir()
        cls.ds = Dataset(cls.root)
        cls.epoch0 = batches(cls.root, seed=5, num_workers=2, target_short_sides=None)

    def test_every_annotated_image_twice_per_epoch(self):
        annotated = self.ds.annotated_image_ids.tolist()
        self.assertEqual(len(self.epoch0), 2 * len(annotated) // TARGETS)
        seen = [t["image_id"] for b in self.epoch0 for t in b["targets"]]
        self.assertTrue(all(len(b["targets"]) == TARGETS for b in self.epoch0))
        if 2 * len(annotated) % TARGETS == 0:
            self.assertEqual(sorted(seen), sorted(annotated * 2))
        # One shard fills the cache (cache_images = shard size): its images come first, twice.
        sampler = PretrainBatchSampler(self.ds, targets_per_batch=1, cache_images=fixture.SHARD_SIZE, seed=5)
        stream = [spec.image_ids[0] for spec in sampler.batches(0)]
        first_shard = stream[0] // fixture.SHARD_SIZE
        in_first = [i for i in annotated if i // fixture.SHARD_SIZE == first_shard]
        self.assertEqual(sorted(stream[:2 * len(in_first)]), sorted(in_first * 2))

    def test_targets_carry_the_stored_masks_and_boxes(self):
        dropped_small = kept = 0
        for batch in self.epoch0:
            keys = batch["query_model_keys"]
            for target in batch["targets"]:
                image = self.ds.image(target["image_id"])
                expected_pixels = image.pixels()[:, ::-1] if target["flipped"] else image.pixels()
                np.testing.assert_array_equal(target["image"].permute(1, 2, 0).numpy(), expected_pixels)
                expected = []
                for inst in image.instances:
                    x, y, w, h = inst.visible_box
                    if inst.visible_area == 0 or inst.model_key not in keys:
                        continue
                    if w <= 8 or h <= 8:
                        dropped_small += 1
                        continue
                    if target["flipped"]:
                        x = image.width - (x + w)
                    expected.append((inst.ordinal, inst.model_key, [x, y, x + w, y + h]))
                self.assertEqual(target["ordinals"].tolist(), [e[0] for e in expected])
                self.assertEqual(target["boxes"].tolist(), [e[2] for e in expected])
                for k, (ordinal, key, box) in enumerate(expected):
                    mask = target["masks"][k].numpy()
                    self.assertEqual(box_of(mask), box)
                    stored = rle.decode(next(i.visible_rle for i in image.instances if i.ordinal == ordinal),
                                        image.height, image.width)
                    np.testing.assert_array_equal(mask, stored[:, ::-1] if target["flipped"] else stored)
                    self.assertEqual(keys[target["query_index"][k]], key)
                    kept += 1
        self.assertGreater(kept, 0)
        self.assertGreater(dropped_small, 0, "no box of 8 px or less in the test data: the filter went untested")

    def check_queries(self, batches_, queries):
        """Checks each batch's queries; returns how many batches had more present models than
        queries, and how many had room for negatives."""
        with_views = {k for k in self.ds.model_keys if self.ds.view_count(k) > 0}
        truncated = with_negatives = 0
        for batch in batches_:
            keys = batch["query_model_keys"]
            self.assertEqual(len(keys), min(queries, len(with_views)))
            self.assertEqual(len(set(keys)), len(keys))
            present = {i.model_key for t in batch["targets"] for i in self.ds.image(t["image_id"]).instances
                       if i.visible_area > 0} & with_views
            positives = batch["positive_queries"]
            self.assertEqual(positives, min(len(present), queries))
            self.assertTrue(set(keys[:positives]) <= present)
            self.assertFalse(set(keys[positives:]) & present)
            truncated += len(present) > queries
            with_negatives += positives < len(keys)
            for q, key in enumerate(keys):
                view = self.ds.query_view(key, int(batch["query_view_indices"][q]))
                h, w = batch["query_sizes"][q].tolist()
                self.assertEqual(max(h, w), 224)
                self.assertEqual((h, w), (round(view.height * 224 / max(view.height, view.width)),
                                          round(view.width * 224 / max(view.height, view.width))))
                with PILImage.open(io.BytesIO(view.data)) as pil:
                    resized = np.asarray(pil.convert("RGB").resize((w, h), PILImage.BILINEAR))
                image = batch["query_images"][q]
                np.testing.assert_array_equal(image[:, :h, :w].permute(1, 2, 0).numpy(), resized)
                self.assertEqual(int(image[:, h:, :].sum() + image[:, :, w:].sum()), 0)
        return truncated, with_negatives

    def test_queries_present_models_first_one_view_each(self):
        truncated, _ = self.check_queries(self.epoch0, QUERIES)
        self.assertGreater(truncated, 0, "no batch with more models than queries: the cut went untested")
        # One target per batch and more queries than it has models: negatives follow the positives.
        loader = pretrain_loader(self.root, seed=5, num_workers=0, targets_per_batch=1, cache_images=1,
                                 queries_per_batch=12, target_short_sides=None)
        single = [batch for _, batch in zip(range(6), loader)]
        _, with_negatives = self.check_queries(single, 12)
        self.assertEqual(with_negatives, len(single))

    def test_same_seed_same_batches_whatever_the_workers(self):
        again = batches(self.root, seed=5, num_workers=0, target_short_sides=None)
        self.assertEqual(len(again), len(self.epoch0))
        for a, b in zip(self.epoch0, again):
            self.assertEqual(a["query_model_keys"], b["query_model_keys"])
            self.assertTrue(torch.equal(a["query_images"], b["query_images"]))
            for ta, tb in zip(a["targets"], b["targets"]):
                self.assertEqual(ta["image_id"], tb["image_id"])
                self.assertTrue(torch.equal(ta["image"], tb["image"]))
                self.assertTrue(torch.equal(ta["masks"], tb["masks"]))
                self.assertTrue(torch.equal(ta["query_index"], tb["query_index"]))
        order = [tuple(t["image_id"] for t in b["targets"]) for b in self.epoch0]

        def sampled(seed, epoch):
            sampler = PretrainBatchSampler(self.ds, targets_per_batch=TARGETS, cache_images=fixture.SHARD_SIZE,
                                           seed=seed)
            return [spec.image_ids for spec in sampler.batches(epoch)]

        self.assertEqual(order, sampled(5, 0))
        self.assertNotEqual(order, sampled(6, 0))
        self.assertNotEqual(order, sampled(5, 1))
        sampler = PretrainBatchSampler(self.ds, targets_per_batch=TARGETS, cache_images=fixture.SHARD_SIZE, seed=5)
        sampler.set_epoch(1)
        self.assertEqual([spec.image_ids for spec in sampler], sampled(5, 1))

    def test_resized_targets(self):
        resized = batches(self.root, seed=5, num_workers=0, target_short_sides=(144,), flip_probability=0.0)
        for batch in resized:
            for target in batch["targets"]:
                self.assertEqual(tuple(target["image"].shape), (3, 144, 192))
                self.assertEqual(target["scale"], 2.0)
                image = self.ds.image(target["image_id"])
                by_ordinal = {i.ordinal: i for i in image.instances}
                for box, mask, ordinal in zip(target["boxes"].tolist(), target["masks"].numpy(),
                                              target["ordinals"].tolist()):
                    self.assertEqual(box_of(mask), box)
                    self.assertTrue(box[2] - box[0] > 8 and box[3] - box[1] > 8)
                    x, y, w, h = by_ordinal[ordinal].visible_box
                    self.assertEqual(box, [2 * x, 2 * y, 2 * (x + w), 2 * (y + h)])


if __name__ == "__main__":
    unittest.main()
