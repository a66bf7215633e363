"""Fine-tuning a detector on a COCO-format folder and scoring it with COCOeval:
``python3 -m solid_data.finetune``.

    /usr/bin/python3 -m solid_data.finetune --config small --init runs/small/detector.pth \\
        --train-json coco/train.json --train-images coco/images \\
        --val-json coco/val.json --val-images coco/images --iterations 500 --out runs/finetune

The model is the config's torchvision detector (`build_detector`) with one class per category
of the training json; ``--init`` is a pretraining run's ``detector.pth`` (every key but the
predictor's), without it the detector starts from random init. OUT receives ``metrics.json``
(COCOeval bbox stats, iterations, init, seed), ``log.jsonl`` (one line per iteration) and
``model.pth`` (the fine-tuned state_dict). The same options and seed give the same numbers.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import torch
import torch.utils.data

from .detection.coco import CocoDetection, CocoError, STAT_NAMES, collate, evaluate, import_pycocotools
from .detection.config import ConfigError, build_detector, load_config, parse_override, warmup_cosine

__all__ = ["FinetuneOptions", "FinetuneReport", "FinetuneError", "finetune", "load_init", "learning_rate", "main"]

# The keys a pretrained detector.pth lacks: the classifier and box regressor, whose shapes
# depend on the number of categories (and the mask predictor's last layer, for Mask R-CNN).
PREDICTOR_PREFIXES = ("roi_heads.box_predictor.", "roi_heads.mask_predictor.mask_fcn_logits.")

# torchvision's detection references: SGD with this momentum and weight decay, warm-up from
# this fraction of the rate.
_MOMENTUM = 0.9
_WEIGHT_DECAY = 1e-4
_WARMUP_FACTOR = 1e-3


class FinetuneError(RuntimeError):
    """A problem with the inputs of a fine-tuning run (paths, jsons, config, checkpoint)."""


@dataclass
class FinetuneOptions:
    train_json: str | os.PathLike
    train_images: str | os.PathLike
    val_json: str | os.PathLike
    val_images: str | os.PathLike
    out: str | os.PathLike
    iterations: int
    config: str | os.PathLike = "small"
    overrides: dict[str, Any] = field(default_factory=dict)
    init: str | os.PathLike | None = None
    batch: int = 4
    lr: float = 0.02
    warmup: int = 50
    seed: int = 0
    threads: int | None = None  # None: the config's ``threads``, 0 there meaning every core
    log_every: int = 10
    log: Any = sys.stdout  # progress lines and COCOeval's summary; None for silence


@dataclass
class FinetuneReport:
    out: Path
    metrics: dict[str, Any]  # as written to metrics.json
    losses: list[dict[str, float]]  # one per iteration
    seconds: float  # training only
    images_per_second: float


def learning_rate(base: float, warmup: int, iterations: int, iteration: int) -> float:
    """torchvision's references: warm-up from 1e-3 of ``base``, then cosine to 0 at ``iterations``."""
    return warmup_cosine(base, iteration, warmup, iterations, warmup_factor=_WARMUP_FACTOR, final_fraction=0.0)


def load_init(model: torch.nn.Module, path: str | os.PathLike) -> None:
    """Loads a state_dict that holds every key of ``model`` but the predictor's, refusing any
    other: a checkpoint of another config would otherwise load partly and silently."""
    path = Path(path)
    if not path.is_file():
        raise FinetuneError(f"--init {path}: no such file (a pretraining run writes RUN/detector.pth)")
    try:
        state = torch.load(path, map_location="cpu")
    except Exception as e:  # torch.load raises whatever its unpickler meets in a foreign file
        raise FinetuneError(f"--init {path}: not a torch.save file ({type(e).__name__}: {e})") from None
    if not isinstance(state, dict) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        raise FinetuneError(f"--init {path}: not a state_dict of tensors (a pretraining run's checkpoint.pt "
                            "is not one; its detector.pth is)")
    predictor = {k for k in model.state_dict() if k.startswith(PREDICTOR_PREFIXES)}
    try:
        result = model.load_state_dict(state, strict=False)
    except RuntimeError as e:
        raise FinetuneError(f"--init {path}: does not fit this config's detector, wrong config for this "
                            f"checkpoint? ({str(e).strip().splitlines()[-1].strip()})") from None
    missing, unexpected = set(result.missing_keys), set(result.unexpected_keys)
    if missing != predictor or unexpected:
        problems = []
        if unexpected:
            problems.append(f"{len(unexpected)} keys the detector lacks (e.g. {sorted(unexpected)[0]})")
        if missing - predictor:
            problems.append(f"{len(missing - predictor)} of its keys missing (e.g. {sorted(missing - predictor)[0]})")
        if predictor - missing:
            problems.append("a predictor, which depends on the categories (an exported detector.pth has none)")
        raise FinetuneError(f"--init {path}: wrong config for this checkpoint: it holds {'; '.join(problems)}")


def _open(json_path, images, what: str, **options) -> CocoDetection:
    try:
        return CocoDetection(json_path, images, **options)
    except CocoError as e:
        raise FinetuneError(f"--{what}: {e}") from None


def _stream(loader: torch.utils.data.DataLoader, dataset: CocoDetection) -> Iterator:
    """Batches epoch after epoch; each epoch draws its own flips."""
    epoch = 0
    while True:
        dataset.set_epoch(epoch)
        yield from loader
        epoch += 1


def _format_seconds(seconds: float) -> str:
    seconds = int(seconds)
    return f"{seconds // 3600}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


def _write_json(path: Path, value: Any) -> None:
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(value, indent=2) + "\n", encoding="utf-8")
    os.replace(partial, path)


def finetune(options: FinetuneOptions) -> FinetuneReport:
    if options.iterations < 1 or options.batch < 1 or options.warmup < 0 or options.lr <= 0:
        raise FinetuneError("--iterations and --batch must be at least 1, --warmup at least 0, --lr positive")
    try:
        config = load_config(options.config, options.overrides)
    except ConfigError as e:
        raise FinetuneError(str(e)) from None
    # Before any training: a run that cannot be scored is a run wasted.
    try:
        import_pycocotools()
    except ImportError as e:
        raise FinetuneError(str(e)) from None
    train = _open(options.train_json, options.train_images, "train-json/--train-images",
                  flip_probability=config["flip_probability"], seed=options.seed, skip_empty=True)
    val = _open(options.val_json, options.val_images, "val-json/--val-images")
    if [(c["id"], c.get("name")) for c in val.categories] != [(c["id"], c.get("name")) for c in train.categories]:
        raise FinetuneError(f"{options.val_json} and {options.train_json} list different categories; "
                            "the detector's classes are the training json's")
    if len(train) == 0:
        raise FinetuneError(f"{options.train_json}: no image with a box to train on")

    threads = options.threads if options.threads is not None else config["threads"]
    torch.set_num_threads(threads or os.cpu_count() or 1)
    torch.manual_seed(options.seed)
    model = build_detector(config, num_classes=train.num_categories + 1)
    if options.init is not None:
        load_init(model, options.init)
    out = Path(options.out)
    out.mkdir(parents=True, exist_ok=True)

    parameters = [p for p in model.parameters() if p.requires_grad]
    optimizer = torch.optim.SGD(parameters, lr=options.lr, momentum=_MOMENTUM, weight_decay=_WEIGHT_DECAY)
    # A generator of its own: the shuffling must not depend on how much the model's
    # initialisation drew from the global RNG.
    order = torch.Generator()
    order.manual_seed(options.seed)
    loader = torch.utils.data.DataLoader(train, batch_size=options.batch, shuffle=True, generator=order,
                                         drop_last=len(train) >= options.batch, collate_fn=collate,
                                         num_workers=config["num_workers"])
    losses: list[dict[str, float]] = []
    images_done = 0
    begun = time.monotonic()
    model.train()
    with open(out / "log.jsonl", "w", encoding="utf-8") as log:
        for iteration, (images, targets) in zip(range(options.iterations), _stream(loader, train)):
            lr = learning_rate(options.lr, options.warmup, options.iterations, iteration)
            for group in optimizer.param_groups:
                group["lr"] = lr
            terms = model([i.float().div_(255) for i in images],
                          [{"boxes": t["boxes"], "labels": t["labels"]} for t in targets])
            total = sum(terms.values())
            record = {"iteration": iteration + 1, "lr": lr, "loss": float(total)}
            record.update({k: float(v) for k, v in terms.items()})
            if not all(math.isfinite(v) for v in record.values()):
                raise FinetuneError(f"iteration {iteration + 1}: a loss is not finite ({record}); "
                                    "lower --lr or lengthen --warmup")
            optimizer.zero_grad(set_to_none=True)
            total.backward()
            optimizer.step()
            losses.append(record)
            images_done += len(images)
            log.write(json.dumps(record) + "\n")
            done = iteration + 1
            if options.log is not None and (done % options.log_every == 0 or done in (1, options.iterations)):
                rate = images_done / (time.monotonic() - begun)
                eta = (options.iterations - done) * options.batch / max(rate, 1e-9)
                parts = "  ".join(f"{k.removeprefix('loss_')} {v:.4f}" for k, v in record.items()
                                  if k.startswith("loss_"))
                print(f"iter {done}/{options.iterations}  loss {record['loss']:.4f} ({parts})  lr {lr:.4g}  "
                      f"{rate:.2f} images/s  ETA {_format_seconds(eta)}", file=options.log, flush=True)
    seconds = time.monotonic() - begun
    torch.save(model.state_dict(), out / "model.pth")

    if options.log is not None:
        print(f"finetune: evaluating on {len(val)} images of {options.val_json}", file=options.log, flush=True)
    try:
        stats = evaluate(model, options.val_json, options.val_images, batch=options.batch,
                         num_workers=config["num_workers"], summary=options.log)
    except CocoError as e:
        raise FinetuneError(f"--val-json/--val-images: {e}") from None
    metrics: dict[str, Any] = {name: stats[name] for name in STAT_NAMES}
    metrics.update({"iterations": options.iterations, "init": str(options.init) if options.init else None,
                    "seed": options.seed, "config": config, "train_images": len(train), "val_images": len(val),
                    "categories": train.num_categories, "train_seconds": seconds})
    _write_json(out / "metrics.json", metrics)
    return FinetuneReport(out, metrics, losses, seconds, images_done / max(seconds, 1e-9))


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python3 -m solid_data.finetune",
        description="Fine-tune a torchvision detector on a COCO-format folder (e.g. `solid export coco`), from a "
                    "pretraining run's detector.pth or from random init, and score it with COCOeval (bbox).")
    parser.add_argument("--config", default="small", help="a shipped config (small, paper) or a JSON file, e.g. "
                        "RUN/config.json of the pretraining run; default small")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a config key (VALUE in JSON), e.g. --set min_size=480; repeatable")
    parser.add_argument("--train-json", required=True, help="COCO annotations to train on")
    parser.add_argument("--train-images", required=True, help="the directory of their images")
    parser.add_argument("--val-json", required=True, help="COCO annotations to evaluate on")
    parser.add_argument("--val-images", required=True, help="the directory of their images")
    parser.add_argument("--init", help="RUN/detector.pth of a pretraining run (default: random init)")
    parser.add_argument("--iterations", type=int, required=True, help="training iterations (batches)")
    parser.add_argument("--batch", type=int, default=4, help="images per iteration; default 4")
    parser.add_argument("--lr", type=float, default=0.02, help="peak learning rate; default 0.02")
    parser.add_argument("--warmup", type=int, default=50, help="linear warm-up iterations; default 50")
    parser.add_argument("--seed", type=int, default=0, help="initialisation, order and flips; default 0")
    parser.add_argument("--threads", type=int, help="torch threads (default: the config's; 0 = every core)")
    parser.add_argument("--log-every", type=int, default=10, metavar="N", help="a progress line every N iterations")
    parser.add_argument("--out", required=True, help="directory for metrics.json, log.jsonl and model.pth")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        overrides = dict(parse_override(text) for text in args.set)
        report = finetune(FinetuneOptions(
            train_json=args.train_json, train_images=args.train_images, val_json=args.val_json,
            val_images=args.val_images, out=args.out, iterations=args.iterations, config=args.config,
            overrides=overrides, init=args.init, batch=args.batch, lr=args.lr, warmup=args.warmup, seed=args.seed,
            threads=args.threads, log_every=max(1, args.log_every)))
    except (FinetuneError, ConfigError) as e:
        print(f"finetune: {e}", file=sys.stderr)
        return 2
    m = report.metrics
    print(f"finetune: {m['iterations']} iterations in {_format_seconds(report.seconds)} "
          f"({report.images_per_second:.2f} images/s); AP {m['AP']:.4f} AP50 {m['AP50']:.4f}; "
          f"{report.out / 'metrics.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
