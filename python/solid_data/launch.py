"""``torchrun`` that works with Debian 12's torch 1.13 on Python 3.11:
``python3 -m solid_data.launch`` takes torchrun's arguments.

    /usr/bin/python3 -m solid_data.launch --nproc_per_node 2 -m solid_data.pretrain --dataset D --out RUN

torch 1.13 parses ``--redirects`` and ``--tee`` by iterating over its ``Std`` flag enum, and on
Python 3.11 that iteration no longer yields the zero flag ``NONE`` or the composite ``ALL``: the
default "0" parses to None and every torchrun start fails in ``to_map`` with "'NoneType' object
has no attribute 'get'". torch 2.x parses by value; this does the same, then runs torchrun.
"""

from __future__ import annotations

import re

from torch.distributed.elastic.multiprocessing import Std
from torch.distributed.run import main

__all__ = ["parse_std", "main"]


def parse_std(text: str) -> Std | dict[int, Std]:
    """"0" to Std.NONE, "3" to Std.ALL; "0:3,1:0" to a per-local-rank map."""
    if re.fullmatch(r"\d", text):
        return Std(int(text))
    if re.fullmatch(r"\d:\d(,\d:\d)*", text):
        return {int(rank): Std(int(value)) for rank, value in (item.split(":") for item in text.split(","))}
    raise ValueError(f"{text!r}: expected a value 0-3 or a map such as 0:3,1:0")


Std.from_str = staticmethod(parse_std)

if __name__ == "__main__":
    main()
