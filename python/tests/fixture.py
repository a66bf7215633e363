"""A tiny dataset rendered by the `solid` binary named in $SOLID_BINARY, once per process."""

from __future__ import annotations

import os
import subprocess
import tempfile
import unittest
from pathlib import Path

IMAGES = 16
SHARD_SIZE = 8
WIDTH, HEIGHT = 96, 72
MODELS = 16

_dir: tempfile.TemporaryDirectory | None = None


def dataset_dir() -> Path:
    """The rendered dataset's root; raises SkipTest when no binary is given."""
    global _dir
    binary = os.environ.get("SOLID_BINARY")
    if not binary:
        raise unittest.SkipTest("SOLID_BINARY is not set: no solid binary to render the test dataset with")
    if _dir is None:
        scratch = tempfile.TemporaryDirectory(prefix="solid-python-")
        root = Path(scratch.name)
        for args in (["convert", "procedural", str(root / "assets"), "--models", str(MODELS), "--rooms", "3",
                      "--seed", "7"],
                     ["render", "--preset", "random-placement", "--resolution", f"{WIDTH}x{HEIGHT}",
                      "--assets", str(root / "assets"), "--out", str(root / "ds"), "--images", str(IMAGES),
                      "--shard-size", str(SHARD_SIZE), "--spp", "1", "--query-size", "48"]):
            done = subprocess.run([binary, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            if done.returncode != 0:
                raise RuntimeError(f"solid {args[0]} exited with {done.returncode}:\n{done.stderr}")
        _dir = scratch  # only once complete, so that a failed render is not reused
    return Path(_dir.name) / "ds"
