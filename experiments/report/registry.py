"""The registry of the report's sections: `@section(name)` on a function `(lines, settings) -> None` that appends
its Markdown to `lines`, as `auv-mj bench` registers its sections."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class ReportSettings:
    """What `auv-mj reproduce`'s options give every section."""

    episodes: int
    """Held-out episodes per task and policy on random layouts (random targets, generalisation, ocean)."""
    workers: int
    """Local processes for the held-out episodes (the result is the serial one)."""
    figures: Path
    """Folder of the report's figures."""
    runs: Path
    """Fig. 8's training logs."""
    paper_runs: Path
    """Fig. 8's logs on the paper's observation."""
    peer_runs: Path
    """The training-speed logs (ours and SB3's)."""


Section = Callable[[list[str], ReportSettings], None]
SECTIONS: dict[str, Section] = {}
"""Section name -> its function, in the report's order (the order the section modules register in)."""


def section(name: str) -> Callable[[Section], Section]:
    """Registers a report section under `name`."""

    def register(fn: Section) -> Section:
        if name in SECTIONS:
            raise ValueError(f"report section {name!r} is registered twice")
        SECTIONS[name] = fn
        return fn

    return register
