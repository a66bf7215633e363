"""The pretraining wrapper on the tiny fixture dataset: its loss terms, momentum and bank."""

from __future__ import annotations

import math
import unittest

try:
    import torch
    import torchvision  # noqa: F401

    from solid_data.dataset import Dataset
    from solid_data.detection.config import load_config
    from solid_data.detection.wrapper import PREDICTOR_PREFIXES, SolidWrapper, export_state_dict
    from solid_data.detection.config import build_detector
    from solid_data.torch import PretrainBatchSampler, PretrainDataset
except ImportError as error:
    raise unittest.SkipTest(f"PyTorch or torchvision is not importable: {error}")

import fixture

TINY = {"min_size": fixture.HEIGHT, "max_size": fixture.WIDTH, "query_size": 48, "queries_per_batch": 8,
        "targets_per_batch": 2}


class WrapperTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        torch.manual_seed(0)
        cls.dataset = Dataset(fixture.dataset_dir())
        cls.config = load_config("small", TINY)
        cls.batches = PretrainDataset(cls.dataset, queries_per_batch=8, query_long_side=48,
                                      target_short_sides=(fixture.HEIGHT,), target_max_size=fixture.WIDTH)
        cls.sampler = PretrainBatchSampler(cls.dataset, targets_per_batch=2, seed=3)

    def test_every_loss_term_is_finite_on_one_iteration(self):
        wrapper = SolidWrapper(self.config, len(self.dataset.model_keys)).train()
        batch = self.batches[self.sampler.batches(0)[0]]
        losses = wrapper(batch, batch["query_model_ids"])
        self.assertEqual(set(losses), {"loss_con", "loss_box_reg", "loss_objectness", "loss_rpn_box_reg"})
        for name, value in losses.items():
            self.assertTrue(math.isfinite(float(value)), name)
        sum(losses.values()).backward()

    def test_momentum_update_is_its_formula(self):
        wrapper = SolidWrapper(self.config, len(self.dataset.model_keys))
        with torch.no_grad():
            for p in wrapper.target.parameters():
                p.add_(torch.randn_like(p))
        before = [p.clone() for p in wrapper.query.parameters()]
        wrapper.momentum_update()
        m = self.config["momentum"]
        sources = (list(wrapper.target.backbone.parameters()) + list(wrapper.target.roi_heads.box_head.parameters())
                   + list(wrapper.target.roi_heads.box_predictor.embed.parameters()))
        for old, source, new in zip(before, sources, wrapper.query.parameters()):
            torch.testing.assert_close(new, m * old + (1 - m) * source)

    def test_bank_keeps_the_first_embedding_of_a_repeated_model(self):
        wrapper = SolidWrapper(self.config, 5)
        embeddings = torch.eye(4, self.config["embedding_dim"])
        untouched = wrapper.bank[[0, 4]].clone()
        written = wrapper.update_bank(embeddings, torch.tensor([3, 1, 3, 2]))
        self.assertEqual(sorted(written.tolist()), [1, 2, 3])
        torch.testing.assert_close(wrapper.bank[3], embeddings[0])
        torch.testing.assert_close(wrapper.bank[1], embeddings[1])
        torch.testing.assert_close(wrapper.bank[2], embeddings[3])
        torch.testing.assert_close(wrapper.bank[[0, 4]], untouched)

    def test_export_loads_with_only_the_predictor_missing(self):
        wrapper = SolidWrapper(self.config, len(self.dataset.model_keys))
        model = build_detector(self.config, num_classes=7)
        result = model.load_state_dict(export_state_dict(wrapper), strict=False)
        self.assertEqual(result.unexpected_keys, [])
        self.assertTrue(result.missing_keys)
        self.assertTrue(all(k.startswith(PREDICTOR_PREFIXES) for k in result.missing_keys), result.missing_keys)


if __name__ == "__main__":
    unittest.main()
