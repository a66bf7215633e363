"""The pretraining wrapper and command on the tiny fixture dataset: its loss terms, learning on
a fixed batch, momentum and bank, resume, export, and two gloo ranks against one."""

from __future__ import annotations

import math
import tempfile
import unittest
from pathlib import Path

try:
    import torch
    import torchvision  # noqa: F401

    from solid_data.dataset import Dataset
    import torch.distributed as dist
    import torch.multiprocessing as mp

    from solid_data.detection.config import build_detector, load_config
    from solid_data.detection.wrapper import PREDICTOR_PREFIXES, SolidWrapper, export_state_dict
    from solid_data.pretrain import PretrainOptions, pretrain
    from solid_data.torch import PretrainBatchSampler, PretrainDataset
except ImportError as error:
    raise unittest.SkipTest(f"PyTorch or torchvision is not importable: {error}")

import fixture

TINY = {"min_size": fixture.HEIGHT, "max_size": fixture.WIDTH, "query_size": 48, "queries_per_batch": 8,
        "targets_per_batch": 2}
# Everything in a step made independent of how the batch is split over ranks: frozen
# normalisation (no batch statistics), every anchor and every proposal sampled (no random
# subset), and a fixed image size (equal anchor sets).
SPLIT_INVARIANT = {**TINY, "norm": "frozen", "flip_probability": 0.0, "queries_per_batch": fixture.MODELS,
                   "rpn_batch_size_per_image": 1 << 20, "rpn_positive_fraction": 1.0,
                   "box_batch_size_per_image": 1 << 20, "box_positive_fraction": 1.0}


def _rank_batch(batch: dict, image: int, queries: list[int]) -> dict:
    """The union batch's ``image``-th target with the union's ``queries`` (indices), as one
    rank of a split batch holds them: query indices renumbered into the rank's own queries."""
    position = {q: i for i, q in enumerate(queries)}
    target = dict(batch["targets"][image])
    target["query_index"] = torch.tensor([position[int(q)] for q in target["query_index"]], dtype=torch.int64)
    chosen = torch.tensor(queries, dtype=torch.int64)
    return {**batch, "targets": [target], "query_images": batch["query_images"][chosen],
            "query_sizes": batch["query_sizes"][chosen], "query_model_ids": batch["query_model_ids"][chosen]}


def _split_over_ranks(batch: dict) -> list[dict]:
    """Two ranks' batches whose union is ``batch``: rank r holds image r with every query its
    boxes need (a model both images show is on both ranks, which the bank must de-duplicate)
    and every other rank-r-th remaining query."""
    needed = [sorted({int(q) for q in t["query_index"]}) for t in batch["targets"]]
    rest = [q for q in range(len(batch["query_model_keys"])) if q not in set(needed[0]) | set(needed[1])]
    return [_rank_batch(batch, r, sorted(set(needed[r]) | set(rest[r::2]))) for r in range(2)]


def _two_gloo_ranks(rank: int, store: str, config: dict, num_models: int, batch: dict, out: str) -> None:
    dist.init_process_group("gloo", init_method=f"file://{store}", rank=rank, world_size=2)
    try:
        torch.manual_seed(0)
        wrapper = SolidWrapper(config, num_models).train()
        part = _split_over_ranks(batch)[rank]
        losses = wrapper(part, part["query_model_ids"])
        torch.save({"losses": {k: float(v) for k, v in losses.items()}, "bank": wrapper.bank}, f"{out}/rank{rank}.pt")
    finally:
        dist.destroy_process_group()


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

    def test_forty_iterations_on_one_batch_halve_the_contrastive_loss(self):
        torch.manual_seed(0)
        wrapper = SolidWrapper(self.config, len(self.dataset.model_keys)).train()
        batch = self.batches[self.sampler.batches(0)[0]]
        optimizer = torch.optim.SGD(wrapper.target.parameters(), lr=0.02, momentum=0.9)
        con = []
        for _ in range(40):
            losses = wrapper(batch, batch["query_model_ids"])
            con.append(float(losses["loss_con"]))
            optimizer.zero_grad()
            sum(losses.values()).backward()
            optimizer.step()
        self.assertLess(min(con[-5:]), con[0] / 2, con)

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


class DistributedTest(unittest.TestCase):
    def test_two_gloo_ranks_give_one_rank_on_the_union_batch(self):
        dataset = Dataset(fixture.dataset_dir())
        config = load_config("small", SPLIT_INVARIANT)
        batches = PretrainDataset(dataset, queries_per_batch=fixture.MODELS, query_long_side=48,
                                  target_short_sides=(fixture.HEIGHT,), target_max_size=fixture.WIDTH,
                                  flip_probability=0.0)
        # A batch whose two images show a common model, so that both ranks write its entry.
        for spec in PretrainBatchSampler(dataset, targets_per_batch=2, seed=5).batches(0):
            batch = batches[spec]
            shown = [set(map(int, t["query_index"])) for t in batch["targets"]]
            if shown[0] & shown[1]:
                break
        else:
            self.fail("no batch of the fixture shows one model in both images")

        torch.manual_seed(0)
        single = SolidWrapper(config, len(dataset.model_keys)).train()
        union_losses = {k: float(v) for k, v in single(batch, batch["query_model_ids"]).items()}

        with tempfile.TemporaryDirectory(prefix="solid-gloo-") as scratch:
            mp.spawn(_two_gloo_ranks, args=(f"{scratch}/store", config, len(dataset.model_keys), batch, scratch),
                     nprocs=2, join=True)
            ranks = [torch.load(f"{scratch}/rank{r}.pt") for r in range(2)]
        for rank in ranks:
            torch.testing.assert_close(rank["bank"], single.bank, rtol=0, atol=1e-6)
        # DDP averages the ranks' gradients, so the ranks' mean is the union batch's loss.
        for name, value in union_losses.items():
            mean = (ranks[0]["losses"][name] + ranks[1]["losses"][name]) / 2
            self.assertAlmostEqual(mean, value, delta=1e-5 * max(1.0, abs(value)), msg=name)


class ResumeTest(unittest.TestCase):
    def test_a_resumed_run_continues_as_an_uninterrupted_one(self):
        dataset = fixture.dataset_dir()
        overrides = {**TINY, "iterations": 4, "checkpoint_period": 100, "num_workers": 0, "threads": 1}
        with tempfile.TemporaryDirectory(prefix="solid-resume-") as scratch:
            whole = pretrain(PretrainOptions(dataset, Path(scratch) / "whole", overrides=overrides, log=None))
            first = pretrain(PretrainOptions(dataset, Path(scratch) / "split", overrides={**overrides, "stop_at": 2},
                                             log=None))
            rest = pretrain(PretrainOptions(dataset, Path(scratch) / "split", overrides=overrides, log=None))
        self.assertEqual((first.iterations, rest.start_iteration, rest.iterations), (2, 2, 4))
        self.assertEqual(first.losses + rest.losses, whole.losses)


if __name__ == "__main__":
    unittest.main()
