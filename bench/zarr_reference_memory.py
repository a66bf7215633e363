"""Peak memory of zarr and numcodecs writing one chunk of masks as the reference's
render/rendering/main.py does (one assignment of the chunk's object array), for masks of the
sizes of the first chunk of a store of `solid export zarr`, against the raw chunk's size.

    /usr/bin/python3 bench/zarr_reference_memory.py STORE
"""
import json
import resource
import sys
import tempfile
from pathlib import Path

import numpy as np
import zarr

src = zarr.open(sys.argv[1], "r")
chunk = src["masks"].chunks[0]
about = json.loads((Path(sys.argv[1]) / "solid_export.json").read_text())["dataset"]
h, w = about["height"], about["width"]
sizes = [len(b) // 5 * h * w for b in src["bboxes"][0:chunk]]
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
masks = [np.ones(n, dtype=np.int8) for n in sizes]  # ones: every page touched, as rendered masks are
held = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
dst = zarr.open(tempfile.mkdtemp(), "a")
dst.empty("masks", shape=len(src["masks"]), dtype="array:i1", chunks=chunk)
dst["masks"][0:chunk] = np.array(masks + [None], dtype=object)[:-1]
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
raw = sum(sizes) / 2**20
print(f"raw masks {raw:.1f} MiB; peak RSS {before/1024:.1f} MiB before, {held/1024:.1f} holding them, "
      f"{after/1024:.1f} after writing the chunk: the write takes {(after-before)/1024/raw:.2f} x the chunk")
