"""COCO compressed RLE (the ``counts`` strings pycocotools writes), in pure NumPy.

A mask of ``height`` x ``width`` is flattened in column-major order and stored as
alternating run lengths, starting with a run of unset pixels (possibly empty).
Each run length, from the fourth on, is stored as the difference to the run two
places before it; every value is then written as little-endian groups of 5 bits,
one character (``48 + group``) per group, 0x20 marking "more groups follow" and
0x10 of the last group giving the sign.
"""

from __future__ import annotations

import numpy as np

__all__ = ["decode", "encode", "runs", "area", "bbox"]


def runs(counts: str | bytes) -> np.ndarray:
    """The run lengths (int64) that a compressed counts string stands for."""
    raw = counts.encode("ascii") if isinstance(counts, str) else bytes(counts)
    chars = np.frombuffer(raw, dtype=np.uint8).astype(np.int64) - 48
    if chars.size == 0:
        return np.zeros(0, dtype=np.int64)
    if chars.min() < 0 or chars.max() > 63:
        raise ValueError("RLE counts contain a character outside '0'..'o'")
    more = (chars & 0x20) != 0
    if more[-1]:
        raise ValueError("RLE counts end inside a value")
    ends = np.flatnonzero(~more)
    starts = np.concatenate(([0], ends[:-1] + 1))
    lengths = ends - starts + 1
    if lengths.max() > 12:
        raise ValueError("RLE counts hold a value longer than 60 bits")
    # Position of each character inside its value, to shift its 5 bits into place.
    value_of_char = np.repeat(np.arange(starts.size), lengths)
    shift = 5 * (np.arange(chars.size) - starts[value_of_char])
    values = np.add.reduceat((chars & 0x1F) << shift, starts)
    negative = (chars[ends] & 0x10) != 0
    values[negative] -= np.left_shift(1, 5 * lengths[negative])
    # Undo the delta coding: runs[i] = values[i] + runs[i - 2] for i > 2, i.e. two
    # interleaved prefix sums, one over the odd places and one over the even places from 2.
    out = values.copy()
    out[1::2] = np.cumsum(values[1::2])
    out[2::2] = np.cumsum(values[2::2])
    if out.size and out.min() < 0:
        raise ValueError("RLE counts decode to a negative run length")
    return out


def decode(counts: str | bytes, height: int, width: int) -> np.ndarray:
    """The mask as a C-ordered ``height`` x ``width`` uint8 array of 0 and 1."""
    lengths = runs(counts)
    if int(lengths.sum()) != height * width:
        raise ValueError(f"RLE runs cover {int(lengths.sum())} pixels, the mask has {height * width}")
    values = np.arange(lengths.size, dtype=np.uint8) & 1
    column_major = np.repeat(values, lengths)
    return np.ascontiguousarray(column_major.reshape(width, height).T)


def area(counts: str | bytes) -> int:
    """Set pixels, without decoding the mask."""
    return int(runs(counts)[1::2].sum())


def bbox(mask: np.ndarray) -> tuple[int, int, int, int]:
    """COCO ``(x, y, w, h)`` of the set pixels; all zero for an empty mask."""
    columns = np.flatnonzero(mask.any(axis=0))
    if columns.size == 0:
        return (0, 0, 0, 0)
    rows = np.flatnonzero(mask.any(axis=1))
    return (int(columns[0]), int(rows[0]), int(columns[-1] - columns[0] + 1), int(rows[-1] - rows[0] + 1))


def encode(mask: np.ndarray) -> str:
    """The compressed counts string of a 2-D mask (non-zero = set)."""
    if mask.ndim != 2:
        raise ValueError("encode takes a 2-D mask")
    flat = (np.asarray(mask) != 0).ravel(order="F").astype(np.int8)
    flips = np.flatnonzero(np.diff(flat)) + 1
    # The first run is of unset pixels, so a set first pixel starts with an empty run.
    edges = np.concatenate(([0], flips, [flat.size]))
    lengths = np.diff(edges).tolist()
    if flat.size and flat[0]:
        lengths.insert(0, 0)
    out = bytearray()
    for i, length in enumerate(lengths):
        x = length - lengths[i - 2] if i > 2 else length
        while True:
            group = x & 0x1F
            x >>= 5
            more = x != -1 if group & 0x10 else x != 0
            out.append(48 + (group | 0x20 if more else group))
            if not more:
                break
    return out.decode("ascii")
