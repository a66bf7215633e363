"""COCO-format folders for fine-tuning and evaluation: an annotations json and its images
directory, such as ``solid export coco DATASET OUT`` writes (``OUT/annotations.json``,
``OUT/images/``), or any COCO instances json.

`CocoDetection` yields what torchvision's detectors train on; `evaluate` scores a detector
with pycocotools' COCOeval, the reference implementation every COCO number is computed with.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import torch
import torch.utils.data
from PIL import Image as PILImage

__all__ = ["CocoError", "CocoDetection", "STAT_NAMES", "evaluate", "collate", "import_pycocotools"]

# COCOeval.stats in its order (COCOeval.summarize).
STAT_NAMES = ("AP", "AP50", "AP75", "APs", "APm", "APl", "AR1", "AR10", "AR100", "ARs", "ARm", "ARl")

# Appended to the seed material so that the flips never share a Generator state with another
# stream drawn from the same (seed, epoch, index).
_FLIP_STREAM = 0x666C6970


class CocoError(ValueError):
    """A COCO folder that cannot be read: a missing file, a json that is not COCO instances."""


def import_pycocotools():
    """(COCO, COCOeval), or ImportError saying how to build them here."""
    try:
        from pycocotools.coco import COCO
        from pycocotools.cocoeval import COCOeval
    except ImportError as error:
        raise ImportError(
            f"pycocotools is not importable ({error}); Debian packages none: build it with "
            "`scripts/build-pycocotools.sh` and put the directory it prints on PYTHONPATH, e.g. "
            'export PYTHONPATH="$(scripts/build-pycocotools.sh):$PYTHONPATH"') from None
    return COCO, COCOeval


def _read_json(path: Path) -> dict[str, Any]:
    if not path.is_file():
        raise CocoError(f"{path}: no such annotations file")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise CocoError(f"{path}: not JSON ({e})") from None
    if not isinstance(data, dict) or not isinstance(data.get("images"), list):
        raise CocoError(f"{path}: not a COCO annotations file (no 'images' list)")
    if not isinstance(data.get("annotations", []), list):
        raise CocoError(f"{path}: 'annotations' is not a list")
    categories = data.get("categories")
    if not isinstance(categories, list) or not categories:
        raise CocoError(f"{path}: no categories; a detection json lists its categories (`solid export coco` "
                        "writes them)")
    if any(not isinstance(c, dict) or not isinstance(c.get("id"), int) for c in categories):
        raise CocoError(f"{path}: every category needs an integer 'id'")
    if len({c["id"] for c in categories}) != len(categories):
        raise CocoError(f"{path}: category ids repeat")
    return data


class CocoDetection(torch.utils.data.Dataset):
    """Item i: (image, target) with the image a uint8 3 x H x W tensor and the target
    {"boxes": N x 4 float32 x1 y1 x2 y2 pixels, "labels": N int64, "image_id": int}.

    Labels are contiguous, 1..K in the order of category id (0 is torchvision's background);
    ``category_ids[label - 1]`` is the json's id. Crowd annotations and boxes without area are
    left out of the targets (COCOeval still sees them in the json).

    ``flip_probability`` > 0 (training) flips image and boxes horizontally, decided by a NumPy
    Generator seeded with (seed, epoch, index): the same for any DataLoader workers and order.
    ``skip_empty`` drops images without a box, as torchvision's and Detectron2's training do.
    """

    def __init__(self, annotations: str | os.PathLike, images: str | os.PathLike, *, flip_probability: float = 0.0,
                 seed: int = 0, skip_empty: bool = False):
        self.annotations_path = Path(annotations)
        self.images_dir = Path(images)
        if not self.images_dir.is_dir():
            raise CocoError(f"{self.images_dir}: no such images directory")
        data = _read_json(self.annotations_path)
        self.categories = sorted(data["categories"], key=lambda c: c["id"])
        self.category_ids = tuple(c["id"] for c in self.categories)
        label_of = {cid: k + 1 for k, cid in enumerate(self.category_ids)}
        boxes: dict[int, list] = {}
        for a in data.get("annotations", []):
            x, y, w, h = a["bbox"]
            if a.get("iscrowd", 0) or w <= 0 or h <= 0:
                continue
            if a["category_id"] not in label_of:
                raise CocoError(f"{self.annotations_path}: annotation {a.get('id')} has category "
                                f"{a['category_id']}, which is not among the categories")
            boxes.setdefault(a["image_id"], []).append((x, y, x + w, y + h, label_of[a["category_id"]]))
        self.images = [im for im in sorted(data["images"], key=lambda im: im["id"])
                       if not skip_empty or im["id"] in boxes]
        self._boxes = boxes
        self.flip_probability = float(flip_probability)
        self.seed = int(seed)
        self.epoch = 0

    @property
    def num_categories(self) -> int:
        return len(self.categories)

    def set_epoch(self, epoch: int) -> None:
        self.epoch = int(epoch)

    def __len__(self) -> int:
        return len(self.images)

    def __getitem__(self, index: int) -> tuple[torch.Tensor, dict[str, Any]]:
        info = self.images[index]
        path = self.images_dir / info["file_name"]
        try:
            with PILImage.open(path) as pil:
                pixels = np.asarray(pil.convert("RGB"))
        except OSError as e:
            raise CocoError(f"{path}: cannot read image {info['id']} ({e})") from None
        rows = self._boxes.get(info["id"], [])
        boxes = np.array([r[:4] for r in rows], dtype=np.float32).reshape(-1, 4)
        labels = np.array([r[4] for r in rows], dtype=np.int64)
        if self.flip_probability > 0:
            rng = np.random.default_rng([self.seed, self.epoch, index, _FLIP_STREAM])
            if rng.random() < self.flip_probability:
                pixels = pixels[:, ::-1]
                width = pixels.shape[1]
                boxes = np.stack([width - boxes[:, 2], boxes[:, 1], width - boxes[:, 0], boxes[:, 3]], axis=1)
        image = torch.from_numpy(np.ascontiguousarray(pixels.transpose(2, 0, 1)))
        return image, {"boxes": torch.from_numpy(boxes), "labels": torch.from_numpy(labels), "image_id": info["id"]}


def collate(items: Sequence[tuple[torch.Tensor, dict]]) -> tuple[list[torch.Tensor], list[dict]]:
    """Images differ in size: a batch is a list of each, as torchvision's detectors take them."""
    return [i for i, _ in items], [t for _, t in items]


def _detections(model: torch.nn.Module, dataset: CocoDetection, batch: int, num_workers: int) -> list[dict]:
    loader = torch.utils.data.DataLoader(dataset, batch_size=batch, shuffle=False, num_workers=num_workers,
                                         collate_fn=collate)
    results = []
    was_training = model.training
    model.eval()
    try:
        with torch.no_grad():
            for images, targets in loader:
                outputs = model([i.float().div_(255) for i in images])
                for target, out in zip(targets, outputs):
                    boxes = out["boxes"].tolist()
                    for (x1, y1, x2, y2), score, label in zip(boxes, out["scores"].tolist(), out["labels"].tolist()):
                        results.append({"image_id": target["image_id"], "category_id": dataset.category_ids[label - 1],
                                        "bbox": [x1, y1, x2 - x1, y2 - y1], "score": score})
    finally:
        model.train(was_training)
    return results


def evaluate(model: torch.nn.Module, annotations: str | os.PathLike, images: str | os.PathLike, *, batch: int = 4,
             num_workers: int = 0, summary: Any = None) -> dict[str, float]:
    """COCOeval bbox over every image of the json: {"AP": .., "AP50": .., ..., "ARl": ..} in
    [0, 1], -1 where the json has no ground truth of that kind (COCOeval's convention). The
    model's labels are the contiguous ones of `CocoDetection`. COCOeval's summary table goes
    to the file ``summary`` (None: nowhere)."""
    COCO, COCOeval = import_pycocotools()
    dataset = CocoDetection(annotations, images)
    results = _detections(model, dataset, batch, num_workers)
    # COCOeval prints as it goes; its lines belong where the caller wants the summary.
    with open(os.devnull, "w") if summary is None else contextlib.nullcontext(summary) as sink, \
            contextlib.redirect_stdout(sink):
        truth = COCO()
        truth.dataset = _read_json(dataset.annotations_path)
        truth.createIndex()
        if results:
            detected = truth.loadRes(results)
        else:
            # loadRes refuses an empty list; no detections is a valid result (AP 0).
            detected = COCO()
            detected.dataset = {"images": truth.dataset["images"], "categories": truth.dataset["categories"],
                                "annotations": []}
            detected.createIndex()
        scoring = COCOeval(truth, detected, iouType="bbox")
        scoring.evaluate()
        try:
            scoring.accumulate()
        except AttributeError as error:
            raise ImportError(f"this pycocotools ({sys.modules['pycocotools'].__file__}) fails under NumPy "
                              f"{np.__version__} ({error}); rebuild it with `scripts/build-pycocotools.sh`, "
                              "which adapts it") from None
        scoring.summarize()
    return {name: float(v) for name, v in zip(STAT_NAMES, scoring.stats)}
