"""Console helpers shared by every layer: one progress bar for long work (training, evaluation, rendering)."""

from __future__ import annotations

import sys
from typing import Any


def progress_bar(**kwargs: Any):
    """A tqdm bar on stderr; off a terminal (CI logs, pipes) it redraws every 10 s, not every 0.1 s,
    since there each redraw is a new write."""
    from tqdm import tqdm

    return tqdm(file=sys.stderr, mininterval=0.1 if sys.stderr.isatty() else 10.0, **kwargs)


def complete(bar) -> None:
    """Ends a bar whose work finished before its total (an episode that ends before its time limit, runs that need
    not be made): the total becomes what was done, so that the bar closes at 100 %."""
    if bar.total is None or bar.n < bar.total:
        bar.total = bar.n
        bar.refresh()


def counted(count: int, noun: str, plural: str | None = None) -> str:
    """`count` and `noun` as a reader says them: "1 mover", "2 movers", "0 unknown obstacles"; `plural` where adding
    an s is wrong ("1 path site" needs none, "1 box" gives `plural="boxes"`)."""
    return f"{count} {noun if count == 1 else plural or noun + 's'}"
