#!/usr/bin/python3
"""Throughput of the Python reader (python/solid_data) against plain PNG files.

    PYTHONPATH=python /usr/bin/python3 bench/python_reader.py DATASET [--workers 2] [--epochs 1]

Exports the dataset's target images and query views once as PNG files under a scratch
directory, then times DataLoaders with the same batch specs (16 targets, 128 queries):

  batches, paper      solid_data.torch as the pretraining reader uses it (RLE decode, short side
                      640-800, flip, boxes from masks, queries resized to 224)
  batches, stored     the same at the stored image size (no target resize)
  images, sqlite      only read and decode the batch's images (targets, and queries resized to
                      224) from the shards (through Dataset.image, so with the targets' instance rows)
  images, files       the same from the exported files

Both image rows read the same bytes and decode them the same way, so their ratio is what
reading out of SQLite shards costs against a directory of files. Every loader reads one epoch
(each annotated image twice); the first batch, which includes the workers' start, is not timed.
Never run by ctest: it takes minutes.
"""

from __future__ import annotations

import argparse
import io
import os
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
import torch.utils.data
from PIL import Image as PILImage

from solid_data import Dataset
from solid_data.torch import PretrainBatchSampler, PretrainDataset


def _query_long_side(data: bytes, side: int) -> np.ndarray:
    with PILImage.open(io.BytesIO(data)) as pil:
        pil = pil.convert("RGB")
        scale = side / max(pil.size)
        return np.array(pil.resize((max(1, round(pil.width * scale)), max(1, round(pil.height * scale))),
                                     PILImage.BILINEAR))


def _decode(data: bytes) -> np.ndarray:
    with PILImage.open(io.BytesIO(data)) as pil:
        return np.array(pil.convert("RGB"))


class ImagesOnly(torch.utils.data.Dataset):
    """A batch's target images and one view of each of ``queries`` models (drawn from the spec's seed), decoded,
    read either from the shards or from the exported files."""

    def __init__(self, dataset: Dataset, files: Path | None, queries: int):
        self.dataset, self.files, self.queries = dataset, files, queries
        self.models = [key for key in dataset.model_keys if dataset.view_count(key) > 0]

    def __getitem__(self, spec):
        rng = np.random.default_rng([spec.seed, spec.epoch, spec.index])
        # As many queries as PretrainDataset takes: one view of each of up to `queries` models.
        picks = rng.choice(len(self.models), size=min(self.queries, len(self.models)), replace=False)
        targets, queries = [], []
        for image_id in spec.image_ids:
            if self.files is None:
                data = self.dataset.image(image_id).data
            else:
                data = (self.files / "targets" / f"{image_id}.png").read_bytes()
            targets.append(torch.from_numpy(_decode(data)))
        for p in picks:
            key = self.models[p]
            n = int(rng.integers(self.dataset.view_count(key)))
            if self.files is None:
                data = self.dataset.nth_query_view(key, n).data
            else:
                data = (self.files / "queries" / key.replace("/", "__") / f"{n}.png").read_bytes()
            queries.append(torch.from_numpy(_query_long_side(data, 224)))
        return {"targets": targets, "queries": queries}


def export(dataset: Dataset, out: Path) -> None:
    (out / "targets").mkdir(parents=True)
    for image_id in dataset.annotated_image_ids:
        (out / "targets" / f"{image_id}.png").write_bytes(dataset.image(int(image_id)).data)
    for key in dataset.model_keys:
        folder = out / "queries" / key.replace("/", "__")
        folder.mkdir(parents=True)
        for n, view in enumerate(dataset.query_views(key)):
            (folder / f"{n}.png").write_bytes(view.data)


def measure(data: torch.utils.data.Dataset, sampler: PretrainBatchSampler, workers: int, epochs: int):
    loader = torch.utils.data.DataLoader(data, sampler=sampler, batch_size=None, num_workers=workers,
                                         persistent_workers=workers > 0)
    batches = targets = 0
    start = None
    for epoch in range(epochs):
        sampler.set_epoch(epoch)
        for batch in loader:
            if start is None:
                start = time.perf_counter()
                continue
            batches += 1
            targets += len(batch["targets"])
    seconds = time.perf_counter() - start
    return targets / seconds, batches / seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--epochs", type=int, default=1)
    parser.add_argument("--targets", type=int, default=16)
    parser.add_argument("--queries", type=int, default=128)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    dataset = Dataset(args.dataset)
    sampler = PretrainBatchSampler(dataset, targets_per_batch=args.targets, seed=args.seed)
    print(f"{args.dataset}: {dataset.annotated_image_ids.size} annotated images, {len(dataset.model_keys)} models, "
          f"{len(sampler)} batches of {args.targets} targets + {args.queries} queries per epoch, "
          f"{args.workers} workers, {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory(prefix="solid-bench-files-") as scratch:
        files = Path(scratch)
        export(dataset, files)
        rows = [
            ("batches, paper", PretrainDataset(dataset, queries_per_batch=args.queries)),
            ("batches, stored", PretrainDataset(dataset, queries_per_batch=args.queries, target_short_sides=None)),
            ("images, sqlite", ImagesOnly(dataset, None, args.queries)),
            ("images, files", ImagesOnly(dataset, files, args.queries)),
        ]
        results = {name: measure(data, sampler, args.workers, args.epochs) for name, data in rows}
    baseline = results["images, files"][0]
    print(f"{'loader':<18}{'targets/s':>12}{'batches/s':>12}{'vs files':>10}")
    for name, (targets_per_s, batches_per_s) in results.items():
        print(f"{name:<18}{targets_per_s:>12.1f}{batches_per_s:>12.2f}{targets_per_s / baseline:>10.2f}")


if __name__ == "__main__":
    main()
