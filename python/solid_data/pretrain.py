"""Label-free pretraining on a solid dataset: ``python3 -m solid_data.pretrain``.

    /usr/bin/python3 -m solid_data.pretrain --dataset out/default/dataset --config small --out runs/small
    /usr/bin/python3 -m solid_data.launch --nproc_per_node 2 -m solid_data.pretrain --dataset D --config paper --out RUN

(``solid_data.launch`` is torchrun, fixed for Debian 12; elsewhere ``torchrun`` itself works.)

A run directory holds ``config.json`` (the resolved config), ``run.json`` (dataset, its
manifest digest, package versions), ``log.jsonl`` (one line per iteration), ``checkpoint.pt``
(everything a resume needs, written atomically every ``checkpoint_period`` iterations, at the
end and on SIGTERM or SIGINT) and ``detector.pth`` (the exported target detector that
``python3 -m solid_data.finetune --init`` loads). Rerunning the same command resumes from the
checkpoint; the next iteration's loss equals an uninterrupted run's.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import signal
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import torch
import torch.distributed as dist
import torch.utils.data
import torchvision

from .dataset import Dataset
from .detection.config import ConfigError, load_config, parse_override, short_sides, warmup_cosine
from .detection.wrapper import SolidWrapper, export_state_dict, world
from .torch import BatchSpec, PretrainBatchSampler, PretrainDataset

__all__ = ["PretrainOptions", "PretrainReport", "PretrainError", "pretrain", "learning_rate", "main"]

# Config keys that end or pace a run without changing its numbers: a resume may change them.
_PACING_KEYS = ("stop_at", "checkpoint_period", "num_workers", "threads")


class PretrainError(RuntimeError):
    """A problem with the inputs of a run (its dataset, config or run directory)."""


@dataclass
class PretrainOptions:
    dataset: str | os.PathLike
    out: str | os.PathLike
    config: str | os.PathLike = "small"
    overrides: dict[str, Any] = field(default_factory=dict)
    log_every: int = 10
    log: Any = sys.stdout  # where progress lines go (rank 0 only); None for silence


@dataclass
class PretrainReport:
    run: Path
    start_iteration: int  # 0, or where the run resumed
    iterations: int  # the iteration it stopped after
    losses: list[dict[str, float]]  # one per iteration run now
    seconds: float
    images_per_second: float
    interrupted: bool  # stopped by a signal before its last iteration


def learning_rate(config: dict[str, Any], iteration: int) -> float:
    """The reference's schedule: warm-up from 1e-4 of the rate, then constant or cosine from
    the rate to 0.01 of it over ``iterations``."""
    return warmup_cosine(config["lr"], iteration, config["warmup_iterations"], config["iterations"],
                         warmup_factor=1e-4, final_fraction=0.01, cosine=config["schedule"] == "cosine")


class _SpecStream(torch.utils.data.Sampler):
    """Batch specs from iteration ``start`` on, epoch after epoch: iteration i is batch
    i mod len of epoch i // len, whatever the run was interrupted at."""

    def __init__(self, sampler: PretrainBatchSampler, start: int):
        self.sampler = sampler
        self.start = start

    def __iter__(self) -> Iterator[BatchSpec]:
        per_epoch = len(self.sampler)
        epoch, index = divmod(self.start, per_epoch)
        while True:
            yield from self.sampler.batches(epoch)[index:]
            epoch, index = epoch + 1, 0


def _open_dataset(path: str | os.PathLike) -> Dataset:
    root = Path(path)
    if not (root / "manifest.json").is_file():
        raise PretrainError(f"{root}: not a solid dataset (no manifest.json); render one with `solid render`")
    try:
        dataset = Dataset(root)
    except (ValueError, FileNotFoundError) as e:
        raise PretrainError(str(e)) from None
    if not any(dataset.view_count(k) > 0 for k in dataset.model_keys):
        raise PretrainError(f"{root}: the dataset has no query views, which pretraining needs for its memory bank; "
                            "render it with query views (`solid render`, without --no-query-views)")
    if dataset.annotated_image_ids.size == 0:
        raise PretrainError(f"{root}: the dataset has no image with a visible instance")
    return dataset


def _manifest_digest(root: Path) -> str:
    return hashlib.sha256((root / "manifest.json").read_bytes()).hexdigest()


def _resolve_config(options: PretrainOptions, run: Path) -> dict[str, Any]:
    try:
        config = load_config(options.config, options.overrides)
    except ConfigError as e:
        raise PretrainError(str(e)) from None
    recorded = run / "config.json"
    if recorded.exists():
        before = json.loads(recorded.read_text(encoding="utf-8"))
        changed = sorted(k for k in set(before) | set(config)
                         if k not in _PACING_KEYS and before.get(k) != config.get(k))
        if changed:
            raise PretrainError(f"{run}: the run was started with another config ({', '.join(changed)} differ: "
                                f"{', '.join(f'{k}={json.dumps(before.get(k))}' for k in changed)}); "
                                "resume with the same config or start a new --out")
    return config


def _atomic_save(obj: Any, path: Path) -> None:
    partial = path.with_name(path.name + ".partial")
    torch.save(obj, partial)
    os.replace(partial, path)


def _write_json(path: Path, value: Any) -> None:
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(value, indent=2) + "\n", encoding="utf-8")
    os.replace(partial, path)


def _init_distributed() -> torch.device:
    """The rank's device, after joining torchrun's process group (NCCL across GPUs, gloo on
    CPUs); one GPU per rank, picked by LOCAL_RANK."""
    if torch.cuda.is_available():
        device = torch.device("cuda", int(os.environ.get("LOCAL_RANK", "0")))
        torch.cuda.set_device(device)
    else:
        device = torch.device("cpu")
    if int(os.environ.get("WORLD_SIZE", "1")) > 1 and not dist.is_initialized():
        dist.init_process_group("nccl" if device.type == "cuda" else "gloo")
    return device


def _to_device(batch: dict, device: torch.device) -> dict:
    if device.type == "cpu":
        return batch
    moved = {k: v.to(device, non_blocking=True) if isinstance(v, torch.Tensor) else v for k, v in batch.items()}
    moved["targets"] = [{k: v.to(device, non_blocking=True) if isinstance(v, torch.Tensor) else v
                         for k, v in t.items()} for t in batch["targets"]]
    return moved


def _rng_state(device: torch.device) -> dict[str, torch.Tensor]:
    state = {"cpu": torch.get_rng_state()}
    if device.type == "cuda":
        state["cuda"] = torch.cuda.get_rng_state(device)
    return state


def _set_rng_state(state: dict[str, torch.Tensor], device: torch.device) -> None:
    torch.set_rng_state(state["cpu"])
    if device.type == "cuda" and "cuda" in state:
        torch.cuda.set_rng_state(state["cuda"], device)


class _Stop:
    """SIGTERM (Slurm's preemption and time limit) and SIGINT end the run after the current
    iteration, with a checkpoint."""

    def __init__(self):
        self.requested = False
        self._previous = {}

    def __enter__(self):
        for sig in (signal.SIGTERM, signal.SIGINT):
            self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def _handle(self, signum, frame):
        self.requested = True

    def requested_anywhere(self, device: torch.device) -> bool:
        """Whether any rank got the signal: every rank must stop after the same iteration, or
        the checkpoint's collectives would wait forever for a rank that went on."""
        if world()[1] == 1:
            return self.requested
        flag = torch.tensor([int(self.requested)], device=device)
        dist.all_reduce(flag, op=dist.ReduceOp.MAX)
        return bool(flag.item())

    def __exit__(self, *exc):
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)


def _format_seconds(seconds: float) -> str:
    seconds = int(seconds)
    return f"{seconds // 3600}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


def pretrain(options: PretrainOptions) -> PretrainReport:
    device = _init_distributed()
    rank, size = world()
    run = Path(options.out)
    dataset = _open_dataset(options.dataset)
    config = _resolve_config(options, run)
    threads = config["threads"] or max(1, (os.cpu_count() or 1) // int(os.environ.get("LOCAL_WORLD_SIZE", "1")))
    torch.set_num_threads(threads)
    # One initialisation on every rank: DDP would broadcast rank 0's target detector, but the
    # query encoder is copied from it before and must match on every rank too.
    torch.manual_seed(config["seed"])
    wrapper = SolidWrapper(config, num_models=len(dataset.model_keys))
    torch.manual_seed(config["seed"] * 1000 + rank)
    if size > 1 and config["sync_batchnorm"] and device.type == "cuda":
        wrapper.target = torch.nn.SyncBatchNorm.convert_sync_batchnorm(wrapper.target)
    wrapper.to(device)
    target = wrapper.target
    ddp = None
    if size > 1:
        ddp = torch.nn.parallel.DistributedDataParallel(target, device_ids=[device] if device.type == "cuda" else None)
    parameters = [p for p in target.parameters() if p.requires_grad]
    optimizer = torch.optim.SGD(parameters, lr=config["lr"], momentum=config["sgd_momentum"],
                                weight_decay=config["weight_decay"])

    checkpoint_path = run / "checkpoint.pt"
    start = 0
    if checkpoint_path.exists():
        state = torch.load(checkpoint_path, map_location=device)
        if state["world_size"] != size:
            raise PretrainError(f"{checkpoint_path}: written by {state['world_size']} ranks, resumed by {size}; "
                                "resume with the same number of ranks")
        wrapper.load_state_dict(state["wrapper"])
        optimizer.load_state_dict(state["optimizer"])
        start = int(state["iteration"])
        _set_rng_state({k: v.cpu() for k, v in state["rng"][rank].items()}, device)
    elif rank == 0:
        run.mkdir(parents=True, exist_ok=True)
    if rank == 0:
        _write_json(run / "config.json", config)
        _write_json(run / "run.json", {
            "dataset": str(Path(options.dataset).resolve()),
            "manifest_sha256": _manifest_digest(Path(options.dataset)),
            "models": len(dataset.model_keys), "annotated_images": int(dataset.annotated_image_ids.size),
            "world_size": size, "threads_per_rank": threads,
            "versions": {"python": sys.version.split()[0], "torch": torch.__version__,
                         "torchvision": torchvision.__version__},
        })

    stop = config["stop_at"] if config["stop_at"] is not None else config["iterations"]
    stop = min(stop, config["iterations"])
    batches = PretrainDataset(dataset, queries_per_batch=config["queries_per_batch"],
                              query_long_side=config["query_size"], target_short_sides=short_sides(config),
                              target_max_size=config["max_size"], flip_probability=config["flip_probability"],
                              min_box_size=config["min_box_size"])
    sampler = PretrainBatchSampler(dataset, targets_per_batch=config["targets_per_batch"],
                                   cache_images=config["cache_images"], seed=config["seed"], rank=rank,
                                   world_size=size)
    if len(sampler) == 0:
        raise PretrainError(f"{options.dataset}: {dataset.annotated_image_ids.size} annotated images make no batch "
                            f"of {config['targets_per_batch']} targets on each of {size} ranks")
    # A generator of its own: the loader's worker seeds must not draw from the training RNG,
    # which a resume restores.
    loader = torch.utils.data.DataLoader(batches, sampler=_SpecStream(sampler, start), batch_size=None,
                                         num_workers=config["num_workers"], generator=torch.Generator())

    def save(iteration: int) -> None:
        own = _rng_state(device)
        rngs = [own]
        if size > 1:
            # Collectives move device tensors (NCCL takes no CPU tensor): gathered there, stored on the CPU.
            rngs = [{} for _ in range(size)]
            for name, value in own.items():
                parts = [torch.empty_like(value.to(device)) for _ in range(size)]
                dist.all_gather(parts, value.to(device))
                for gathered, part in zip(rngs, parts):
                    gathered[name] = part.cpu()
        if rank == 0:
            _atomic_save({"wrapper": wrapper.state_dict(), "optimizer": optimizer.state_dict(),
                          "iteration": iteration, "rng": rngs, "world_size": size}, checkpoint_path)
            _atomic_save(export_state_dict(wrapper), run / "detector.pth")

    log = open(run / "log.jsonl", "a", encoding="utf-8") if rank == 0 else None
    losses_run: list[dict[str, float]] = []
    begun = time.monotonic()
    images_done = 0
    iteration = start
    interrupted = False
    wrapper.train()
    try:
        with _Stop() as stop_signal:
            for batch in loader:
                if iteration >= stop:
                    break
                lr = learning_rate(config, iteration)
                for group in optimizer.param_groups:
                    group["lr"] = lr
                batch = _to_device(batch, device)
                losses = wrapper(batch, batch["query_model_ids"], ddp)
                total = sum(losses.values())
                optimizer.zero_grad(set_to_none=True)
                total.backward()
                optimizer.step()
                iteration += 1
                values = torch.stack([v.detach() for v in losses.values()]).double()
                if size > 1:
                    dist.all_reduce(values)
                    values /= size
                record = {"iteration": iteration, "lr": lr, "loss": float(values.sum())}
                record.update({k: float(v) for k, v in zip(losses, values)})
                losses_run.append(record)
                images_done += len(batch["targets"]) * size
                if not all(math.isfinite(v) for v in record.values()):
                    raise PretrainError(f"iteration {iteration}: a loss is not finite ({record}); "
                                        "lower lr or lengthen warmup_iterations")
                if log is not None:
                    log.write(json.dumps(record) + "\n")
                    log.flush()
                elapsed = time.monotonic() - begun
                if rank == 0 and options.log is not None and (
                        iteration % options.log_every == 0 or iteration == stop or iteration == start + 1):
                    rate = images_done / elapsed
                    eta = (stop - iteration) * len(batch["targets"]) * size / max(rate, 1e-9)
                    terms = "  ".join(f"{k.removeprefix('loss_')} {v:.4f}" for k, v in record.items()
                                      if k.startswith("loss_"))
                    print(f"iter {iteration}/{stop}  loss {record['loss']:.4f} ({terms})  lr {lr:.4g}  "
                          f"{rate:.2f} images/s  ETA {_format_seconds(eta)}", file=options.log, flush=True)
                if iteration % config["checkpoint_period"] == 0 or iteration == stop:
                    save(iteration)
                if stop_signal.requested_anywhere(device):
                    interrupted = iteration < stop
                    if iteration % config["checkpoint_period"] != 0 and iteration != stop:
                        save(iteration)
                    break
    finally:
        if log is not None:
            log.close()
    seconds = time.monotonic() - begun
    return PretrainReport(run, start, iteration, losses_run, seconds, images_done / max(seconds, 1e-9), interrupted)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python3 -m solid_data.pretrain",
        description="SOLID's label-free detection pretraining on a solid dataset (docs/pretrain.md). "
                    "Rerun the same command to resume from the run's checkpoint.")
    parser.add_argument("--dataset", required=True, help="a dataset rendered by `solid render` with query views")
    parser.add_argument("--out", required=True, help="the run directory (created; resumed when it holds a checkpoint)")
    parser.add_argument("--config", default="small",
                        help="a shipped config (small, paper) or a JSON file; default small")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a config key (VALUE in JSON), e.g. --set iterations=2000; repeatable")
    parser.add_argument("--log-every", type=int, default=10, metavar="N", help="a progress line every N iterations")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        overrides = dict(parse_override(text) for text in args.set)
        report = pretrain(PretrainOptions(dataset=args.dataset, out=args.out, config=args.config,
                                          overrides=overrides, log_every=max(1, args.log_every)))
    except (PretrainError, ConfigError) as e:
        print(f"pretrain: {e}", file=sys.stderr)
        return 2
    if world()[0] == 0:
        state = "interrupted; rerun to resume" if report.interrupted else "done"
        print(f"pretrain: {state}: iterations {report.start_iteration}-{report.iterations} in "
              f"{_format_seconds(report.seconds)} ({report.images_per_second:.2f} images/s); "
              f"checkpoint {report.run / 'checkpoint.pt'}, detector {report.run / 'detector.pth'}")
    if dist.is_initialized():
        dist.destroy_process_group()
    return 130 if report.interrupted else 0


if __name__ == "__main__":
    sys.exit(main())
