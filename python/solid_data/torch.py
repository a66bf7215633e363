"""PyTorch batches the way SOLID's pretraining reader forms them (docs/solid-method.md 5.2).

`PretrainBatchSampler` decides which target images make up each batch (cheap, in the main
process); `PretrainDataset` turns one such `BatchSpec` into a whole batch (targets and
queries, in a DataLoader worker). A batch depends only on its spec, whose random choices come
from a NumPy Generator seeded with (seed, epoch, batch index): the batches are the same for
any ``num_workers``.
"""

from __future__ import annotations

import io
import os
from typing import NamedTuple, Sequence

import numpy as np
import torch
import torch.utils.data
from PIL import Image as PILImage

from . import rle
from .dataset import Dataset, decode_image

__all__ = ["BatchSpec", "PretrainBatchSampler", "PretrainDataset", "pretrain_loader"]

# Appended to the seed material so that the target stream of an epoch and the per-batch
# choices never share a Generator state.
_TARGET_STREAM = 0x7461726765
_BATCH_STREAM = 0x6261746368

PAPER_SHORT_SIDES = (640, 672, 704, 736, 768, 800)


class BatchSpec(NamedTuple):
    seed: int
    epoch: int
    index: int
    image_ids: tuple[int, ...]


class PretrainBatchSampler(torch.utils.data.Sampler):
    """The target stream: whole shards in shuffled order fill a cache of at least
    ``cache_images`` annotated images; each full cache is yielded as two independent
    permutations; the stream is cut into batches of ``targets_per_batch`` (an incomplete last
    batch is dropped). An epoch thus uses every image with instances twice.

    Images without instances are skipped, as the reference skips images without boxes.

    Distributed (``world_size`` > 1): the stream is cut into global batches of
    ``targets_per_batch * world_size`` and rank ``rank`` takes its slice of each; the spec of
    global batch b on rank r has index ``b * world_size + r``, so every rank's queries and
    augmentations are drawn independently.
    """

    def __init__(self, dataset: Dataset, *, targets_per_batch: int = 16, cache_images: int = 1250, seed: int = 0,
                 rank: int = 0, world_size: int = 1):
        if targets_per_batch < 1 or cache_images < 1:
            raise ValueError("targets_per_batch and cache_images must be >= 1")
        if world_size < 1 or not 0 <= rank < world_size:
            raise ValueError(f"rank {rank} is not in a world of {world_size}")
        self.targets_per_batch = targets_per_batch
        self.cache_images = cache_images
        self.seed = int(seed)
        self.rank = rank
        self.world_size = world_size
        self.epoch = 0
        ids, shards = dataset.annotated_image_ids, dataset.annotated_image_shards
        self._shards = [ids[shards == s] for s in np.unique(shards)]
        self._images = int(ids.size)

    def set_epoch(self, epoch: int) -> None:
        self.epoch = int(epoch)

    def batches(self, epoch: int) -> list[BatchSpec]:
        rng = np.random.default_rng([self.seed, epoch, _TARGET_STREAM])
        stream: list[np.ndarray] = []
        cache: list[np.ndarray] = []
        cached = 0
        for s in rng.permutation(len(self._shards)):
            cache.append(self._shards[s])
            cached += self._shards[s].size
            if cached >= self.cache_images:
                stream.extend(self._twice(rng, cache))
                cache, cached = [], 0
        if cache:
            stream.extend(self._twice(rng, cache))
        flat = np.concatenate(stream) if stream else np.zeros(0, dtype=np.int64)
        t, r, w = self.targets_per_batch, self.rank, self.world_size
        return [BatchSpec(self.seed, epoch, b * w + r, tuple(int(i) for i in flat[(b * w + r) * t:(b * w + r + 1) * t]))
                for b in range(flat.size // (t * w))]

    @staticmethod
    def _twice(rng: np.random.Generator, cache: list[np.ndarray]) -> list[np.ndarray]:
        images = np.concatenate(cache)
        return [images[rng.permutation(images.size)], images[rng.permutation(images.size)]]

    def __iter__(self):
        return iter(self.batches(self.epoch))

    def __len__(self) -> int:
        return 2 * self._images // (self.targets_per_batch * self.world_size)


class PretrainDataset(torch.utils.data.Dataset):
    """Builds the batch of a `BatchSpec`.

    Queries: the models of every stored (visible) instance of the batch's targets are the
    positives, all other models the negatives; both are shuffled and visited positives first,
    skipping models without views, taking one random view of each, until
    ``queries_per_batch``. Each view is resized (bilinear) so that its long side is
    ``query_long_side``.

    Targets: the image is resized so that its short side is a random choice of
    ``target_short_sides`` (long side at most ``target_max_size``; None keeps the stored
    size), flipped horizontally with probability ``flip_probability``; masks follow
    (nearest neighbour) and boxes are recomputed from them. An instance is dropped when its
    box is ``min_box_size`` px or less in width or height, or when its model is not among the
    queries (more positives than ``queries_per_batch``).
    """

    def __init__(self, dataset: Dataset | str | os.PathLike, *, queries_per_batch: int = 128,
                 query_long_side: int = 224, target_short_sides: Sequence[int] | None = PAPER_SHORT_SIDES,
                 target_max_size: int = 1333, flip_probability: float = 0.5, min_box_size: int = 8):
        self.dataset = dataset if isinstance(dataset, Dataset) else Dataset(dataset)
        self.queries_per_batch = queries_per_batch
        self.query_long_side = query_long_side
        self.target_short_sides = tuple(target_short_sides) if target_short_sides else None
        self.target_max_size = target_max_size
        self.flip_probability = flip_probability
        self.min_box_size = min_box_size
        keys = self.dataset.model_keys
        self._model_position = {key: i for i, key in enumerate(keys)}
        self._viewable = np.array([self.dataset.view_count(key) > 0 for key in keys], dtype=bool)

    def __getitem__(self, spec: BatchSpec) -> dict:
        rng = np.random.default_rng([spec.seed, spec.epoch, spec.index, _BATCH_STREAM])
        images = [self.dataset.image(i) for i in spec.image_ids]
        query_models, positives = self._select_models(rng, images)
        query_of_model = {key: q for q, key in enumerate(query_models)}
        query_images, query_sizes, query_views = self._queries(rng, query_models)
        targets = [self._target(rng, image, query_of_model) for image in images]
        return {
            "epoch": spec.epoch,
            "index": spec.index,
            "targets": targets,
            "query_images": query_images,
            "query_sizes": query_sizes,
            "query_model_keys": query_models,
            # Each query's position in ``dataset.model_keys``: the model's entry in a memory bank.
            "query_model_ids": torch.tensor([self._model_position[k] for k in query_models], dtype=torch.int64),
            "query_view_indices": torch.tensor(query_views, dtype=torch.int64),
            "positive_queries": positives,
        }

    def _select_models(self, rng: np.random.Generator, images) -> tuple[list[str], int]:
        keys = self.dataset.model_keys
        present = sorted({inst.model_key for image in images for inst in image.instances if inst.visible_area > 0})
        positions = np.array([self._model_position[k] for k in present], dtype=np.int64)
        is_positive = np.zeros(len(keys), dtype=bool)
        is_positive[positions] = True
        positive_order = rng.permutation(positions)
        positive_order = positive_order[self._viewable[positive_order]][:self.queries_per_batch]
        negatives = np.flatnonzero(self._viewable & ~is_positive)
        wanted = self.queries_per_batch - positive_order.size
        negative_order = rng.permutation(negatives)[:wanted]
        chosen = [keys[i] for i in positive_order] + [keys[i] for i in negative_order]
        return chosen, int(positive_order.size)

    def _queries(self, rng: np.random.Generator, models: list[str]):
        side = self.query_long_side
        out = torch.zeros((len(models), 3, side, side), dtype=torch.uint8)
        sizes = torch.zeros((len(models), 2), dtype=torch.int64)
        view_indices = []
        for q, key in enumerate(models):
            view = self.dataset.nth_query_view(key, int(rng.integers(self.dataset.view_count(key))))
            view_indices.append(view.view_index)
            with PILImage.open(io.BytesIO(view.data)) as pil:
                pil = pil.convert("RGB")
                scale = side / max(pil.width, pil.height)
                w = max(1, round(pil.width * scale))
                h = max(1, round(pil.height * scale))
                pixels = np.asarray(pil.resize((w, h), PILImage.BILINEAR))
            out[q, :, :h, :w] = torch.from_numpy(pixels.transpose(2, 0, 1).copy())
            sizes[q, 0], sizes[q, 1] = h, w
        return out, sizes, view_indices

    def _target(self, rng: np.random.Generator, image, query_of_model: dict[str, int]) -> dict:
        pixels = decode_image(image.data)
        kept = [inst for inst in image.instances if inst.visible_area > 0 and inst.model_key in query_of_model]
        masks = np.empty((len(kept), image.height, image.width), dtype=bool)
        for k, inst in enumerate(kept):
            masks[k] = rle.decode(inst.visible_rle, image.height, image.width)
        # Masks are resized and flipped by gathering, for each output row and column, its source
        # row and column (nearest neighbour): boxes come from the per-row and per-column
        # occupancy gathered the same way, so only the masks that are kept are ever resized.
        rows = np.arange(image.height)
        columns = np.arange(image.width)
        scale = 1.0
        if self.target_short_sides is not None:
            short = self.target_short_sides[int(rng.integers(len(self.target_short_sides)))]
            scale = min(short / min(image.height, image.width), self.target_max_size / max(image.height, image.width))
            height, width = round(image.height * scale), round(image.width * scale)
            pixels = np.asarray(PILImage.fromarray(pixels).resize((width, height), PILImage.BILINEAR))
            rows, columns = _nearest(image.height, height), _nearest(image.width, width)
        flipped = bool(rng.random() < self.flip_probability)
        if flipped:
            pixels = pixels[:, ::-1]
            columns = columns[::-1]
        boxes = _boxes(masks.any(axis=1)[:, columns], masks.any(axis=2)[:, rows])
        size_ok = ((boxes[:, 2] - boxes[:, 0]) > self.min_box_size) & ((boxes[:, 3] - boxes[:, 1]) > self.min_box_size)
        keep = np.flatnonzero(size_ok)
        return {
            "image_id": image.image_id,
            "image": torch.from_numpy(np.ascontiguousarray(pixels.transpose(2, 0, 1))),
            "boxes": torch.from_numpy(boxes[keep].astype(np.float32)),
            # Columns first, at the stored height, then whole rows: far cheaper than one 3-D gather.
            "masks": torch.from_numpy(np.take(masks[keep][:, :, columns], rows, axis=1)),
            "query_index": torch.tensor([query_of_model[kept[k].model_key] for k in keep], dtype=torch.int64),
            "ordinals": torch.tensor([kept[k].ordinal for k in keep], dtype=torch.int64),
            "scale": scale,
            "flipped": flipped,
        }


def _nearest(source: int, target: int) -> np.ndarray:
    """Source row (or column) of each target one when resizing by nearest neighbour."""
    return np.minimum(((np.arange(target) + 0.5) * (source / target)).astype(np.int64), source - 1)


def _boxes(columns: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Half-open [x1, y1, x2, y2] of each mask (x2, y2 one past the last set column, row) from
    whether each of its columns (N x W) and rows (N x H) holds a set pixel; zero when empty."""
    width, height = columns.shape[1], rows.shape[1]
    x1 = columns.argmax(axis=1)
    x2 = width - columns[:, ::-1].argmax(axis=1)
    y1 = rows.argmax(axis=1)
    y2 = height - rows[:, ::-1].argmax(axis=1)
    boxes = np.stack([x1, y1, x2, y2], axis=1)
    boxes[~columns.any(axis=1)] = 0
    return boxes


def pretrain_loader(dataset: Dataset | str | os.PathLike, *, seed: int = 0, num_workers: int = 0,
                    targets_per_batch: int = 16, cache_images: int = 1250, **batch_options) -> torch.utils.data.DataLoader:
    """A DataLoader of pretraining batches; ``loader.sampler.set_epoch(e)`` picks the epoch.
    ``batch_options`` go to `PretrainDataset`."""
    batches = PretrainDataset(dataset, **batch_options)
    sampler = PretrainBatchSampler(batches.dataset, targets_per_batch=targets_per_batch,
                                   cache_images=cache_images, seed=seed)
    # batch_size=None: each sampled item is a BatchSpec that the dataset turns into a whole batch.
    return torch.utils.data.DataLoader(batches, sampler=sampler, batch_size=None, num_workers=num_workers)
