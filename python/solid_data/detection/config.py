"""Configs are data: one JSON file each (``configs/``), every key known, every value checked.

A config names a torchvision detection builder; `build_detector` makes that detector from
``weights=None`` (nothing is ever downloaded) with the config's sizes and samplers, so that a
pretrained state_dict and the fine-tuning model share every key but the predictor's.
"""

from __future__ import annotations

import json
import os
import math
from pathlib import Path
from typing import Any

import torch
import torchvision
from torchvision.ops import misc as misc_ops

__all__ = ["CONFIG_DIR", "ConfigError", "load_config", "parse_override", "short_sides", "build_detector",
           "warmup_cosine", "DETECTORS"]

CONFIG_DIR = Path(__file__).with_name("configs")

# The torchvision builders a config may name, and whether they carry a mask head.
DETECTORS = {
    "fasterrcnn_mobilenet_v3_large_fpn": False,
    "fasterrcnn_mobilenet_v3_large_320_fpn": False,
    "fasterrcnn_resnet50_fpn": False,
    "maskrcnn_resnet50_fpn": True,
}

# Every key a config may hold, with the type its value must have ("size" is an int or a list
# of ints; "int?" may also be null).
_SCHEMA = {
    "detector": "str", "norm": "str", "query_norm": "str", "min_size": "size", "max_size": "int",
    "embedding_dim": "int", "temperature": "float", "momentum": "float",
    "targets_per_batch": "int", "queries_per_batch": "int", "query_size": "int",
    "flip_probability": "float", "min_box_size": "int", "cache_images": "int",
    "rpn_batch_size_per_image": "int", "rpn_positive_fraction": "float",
    "box_batch_size_per_image": "int", "box_positive_fraction": "float",
    "optimizer": "str", "lr": "float", "sgd_momentum": "float", "weight_decay": "float",
    "warmup_iterations": "int", "schedule": "str", "iterations": "int", "stop_at": "int?",
    "checkpoint_period": "int", "seed": "int", "num_workers": "int", "threads": "int",
    "sync_batchnorm": "bool",
}
_CHOICES = {"norm": ("batch", "frozen"), "query_norm": ("batch", "eman"), "optimizer": ("sgd",), "schedule": ("cosine", "constant"),
            "detector": tuple(DETECTORS)}


class ConfigError(ValueError):
    """A config file or override that names an unknown key or holds a wrong value."""


def _check_value(where: str, key: str, value: Any) -> Any:
    kind = _SCHEMA[key]
    if kind == "int?" and value is None:
        return None
    if kind in ("int", "int?"):
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif kind == "float":
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        value = float(value) if ok else value
    elif kind == "size":
        ok = (isinstance(value, int) and not isinstance(value, bool)) or (
            isinstance(value, list) and value and all(isinstance(v, int) and not isinstance(v, bool) for v in value))
    elif kind == "bool":
        ok = isinstance(value, bool)
    else:
        ok = isinstance(value, str)
    if not ok:
        raise ConfigError(f"{where}: '{key}' must be {kind.rstrip('?')}{' or null' if kind == 'int?' else ''}, "
                          f"not {json.dumps(value)}")
    if key in _CHOICES and value not in _CHOICES[key]:
        raise ConfigError(f"{where}: '{key}' is {json.dumps(value)}; one of {', '.join(_CHOICES[key])}")
    return value


def parse_override(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` with VALUE in JSON (a bare word is taken as a string)."""
    key, sep, raw = text.partition("=")
    if not sep or not key:
        raise ConfigError(f"--set {text!r}: expected KEY=VALUE")
    try:
        value = json.loads(raw)
    except json.JSONDecodeError:
        value = raw
    return key.strip(), value


def load_config(name_or_path: str | os.PathLike, overrides: dict[str, Any] | None = None) -> dict[str, Any]:
    """The config of a shipped name (``small``, ``paper``) or a JSON file, with ``overrides``
    applied; every key of the result is known and checked. Keys starting with ``_`` are notes."""
    path = Path(name_or_path)
    if not path.suffix and not path.exists():
        path = CONFIG_DIR / f"{name_or_path}.json"
    if not path.is_file():
        shipped = ", ".join(sorted(p.stem for p in CONFIG_DIR.glob("*.json")))
        raise ConfigError(f"{name_or_path}: no such config file (shipped configs: {shipped})")
    try:
        raw = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as e:
        raise ConfigError(f"{path}:{e.lineno}: not JSON: {e.msg}") from None
    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: a config is a JSON object")
    config: dict[str, Any] = {}
    for where, entries in ((str(path), raw), ("--set", overrides or {})):
        for key, value in entries.items():
            if key.startswith("_"):
                continue
            if key not in _SCHEMA:
                raise ConfigError(f"{where}: unknown config key '{key}' (known: {', '.join(_SCHEMA)})")
            config[key] = _check_value(where, key, value)
    missing = [k for k in _SCHEMA if k not in config]
    if missing:
        raise ConfigError(f"{path}: missing config keys {', '.join(missing)}")
    for key in ("targets_per_batch", "queries_per_batch", "query_size", "iterations", "checkpoint_period",
                "embedding_dim"):
        if config[key] < 1:
            raise ConfigError(f"{path}: '{key}' must be at least 1, not {config[key]}")
    if not 0.0 <= config["momentum"] < 1.0:
        raise ConfigError(f"{path}: 'momentum' must be in [0, 1), not {config['momentum']}")
    if config["temperature"] <= 0.0:
        raise ConfigError(f"{path}: 'temperature' must be positive, not {config['temperature']}")
    return config


def short_sides(config: dict[str, Any]) -> tuple[int, ...]:
    size = config["min_size"]
    return tuple(size) if isinstance(size, list) else (size,)


def _freeze_batchnorm(module: torch.nn.Module) -> torch.nn.Module:
    """BatchNorm2d layers replaced by FrozenBatchNorm2d with their statistics (Detectron2's
    FrozenBN): the normalisation no longer depends on the batch."""
    for name, child in module.named_children():
        if isinstance(child, torch.nn.BatchNorm2d):
            frozen = misc_ops.FrozenBatchNorm2d(child.num_features, eps=child.eps)
            for buffer in ("weight", "bias", "running_mean", "running_var"):
                source = getattr(child, buffer)
                getattr(frozen, buffer).copy_(source.detach() if source is not None else getattr(frozen, buffer))
            setattr(module, name, frozen)
        else:
            _freeze_batchnorm(child)
    return module


def build_detector(config: dict[str, Any], num_classes: int) -> torch.nn.Module:
    """The config's torchvision detector with ``num_classes`` (background included), from
    ``weights=None`` and ``weights_backbone=None``: the model that fine-tuning starts from, and
    the one whose backbone, RPN and heads the pretraining wrapper trains."""
    builder = getattr(torchvision.models.detection, config["detector"])
    model = builder(
        weights=None, weights_backbone=None, num_classes=num_classes,
        min_size=short_sides(config), max_size=config["max_size"],
        rpn_batch_size_per_image=config["rpn_batch_size_per_image"],
        rpn_positive_fraction=config["rpn_positive_fraction"],
        box_batch_size_per_image=config["box_batch_size_per_image"],
        box_positive_fraction=config["box_positive_fraction"])
    if config["norm"] == "frozen":
        _freeze_batchnorm(model)
    return model


def warmup_cosine(base: float, iteration: int, warmup: int, iterations: int, *,
                  warmup_factor: float, final_fraction: float, cosine: bool = True) -> float:
    """The learning rate of both commands: linear warm-up from ``warmup_factor`` of ``base``
    over ``warmup`` iterations, then (unless ``cosine`` is off, a constant rate) a half cosine
    from ``base`` to ``final_fraction`` of it at ``iterations``."""
    if iteration < warmup:
        return base * (warmup_factor + (1 - warmup_factor) * iteration / warmup)
    if not cosine:
        return base
    progress = min(1.0, (iteration - warmup) / max(1, iterations - warmup))
    return base * (final_fraction + (1 - final_fraction) * 0.5 * (1.0 + math.cos(math.pi * progress)))
