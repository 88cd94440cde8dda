"""The held-out benchmark's definitions: suite v1, one table of cells (`SUITE_V1`), and its fingerprint; the 3-D
suites of the 6-DOF vehicle (`SUITE_3D_V1` to `SUITE_3D_V3`, `auv-mj benchmark --domain auv3d`) with their own.
`VERSIONS` names every version of each domain's suite, `SUITES` the newest of each.

Each row (a `Cell`) is a task with its options (a procedural arena of a tier in a water), a block of held-out TEST
seeds (`auv_mj.seeds.TEST`) and its default number of episodes. Episode i of a cell runs with seed `cell.seeds[i]`.
Changing what the suite measures (a row, its seeds, options, episodes or the metrics) is a new version:
`SUITE_VERSION` goes up and `FINGERPRINTS` gets the new definition's hash, which a test pins.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace

from auv_mj import seeds

SUITE_NAME = "suite v1"
SUITE_VERSION = 1
TIERS = ("standard", "hard")
"""The `tier` task option: the standard arenas, and the hard ones (traps, narrow gaps, crowded movers)."""
WATERS = ("ideal", "ocean")
"""The `conditions` task option: the paper's water, and current, lag and noise (`auv_mj.sim.ocean`)."""
SEED_BLOCK = 1000
"""Held-out seeds per set: set k uses TEST seeds [TEST.start + k * SEED_BLOCK, ... + SEED_BLOCK)."""
EPISODES = 50
"""Episodes per cell by default: the whole suite in <= 30 min with two workers on a 2-core machine."""


@dataclass(frozen=True)
class Cell:
    """One row of the suite: a task and its options, on a block of held-out seeds."""

    task: str
    tier: str
    water: str
    first_seed: int
    """Episode i runs with seed first_seed + i (inside `auv_mj.seeds.TEST`)."""
    episodes: int = EPISODES
    executor: str | None = None
    """The execution layer every policy runs on in this cell (a name of `auv_mj.zoo.executors.EXECUTORS`), unless
    the policy brings its own (a registered policy's fixed executor, e.g. `two-layer-3d`'s learned depth executor);
    None: the task's own S-plane. Part of the definition only where set, so the cells of the suites that predate it
    keep their fingerprints."""

    @property
    def name(self) -> str:
        return f"{self.task}/{self.tier}/{self.water}"

    @property
    def task_kwargs(self) -> dict:
        """The task's options: a procedural arena of the cell's tier, in the cell's water (on the cell's executor
        where it names one)."""
        options = {"arena": "random", "tier": self.tier, "conditions": self.water}
        return options if self.executor is None else {**options, "executor": self.executor}

    def seeds(self, episodes: int | None = None) -> range:
        return range(self.first_seed, self.first_seed + (episodes or self.episodes))


def _block(k: int) -> int:
    return seeds.TEST.start + k * SEED_BLOCK


SUITE_V1: tuple[Cell, ...] = (
    Cell("obstacles", "standard", "ideal", _block(0)),
    Cell("obstacles", "standard", "ocean", _block(0)),
    Cell("obstacles", "hard", "ideal", _block(0)),
    Cell("obstacles", "hard", "ocean", _block(0)),
    Cell("moving_obstacles", "standard", "ideal", _block(1)),
    Cell("moving_obstacles", "standard", "ocean", _block(1)),
    Cell("moving_obstacles", "hard", "ideal", _block(1)),
    Cell("moving_obstacles", "hard", "ocean", _block(1)),
    Cell("tunnel", "standard", "ideal", _block(2)),
    Cell("tunnel", "standard", "ocean", _block(2)),
    Cell("tunnel", "hard", "ideal", _block(2)),
    Cell("tunnel", "hard", "ocean", _block(2)),
)
"""The benchmark, version 1: random obstacles, random moving obstacles and random tunnels, each in both tiers and
both waters; the tiers and waters of a set share its seeds (paired comparisons)."""
METRICS = ("success_rate", "success_ci95", "outcomes", "time_to_goal", "min_clearance", "median_min_clearance",
           "time_efficiency")
"""What each cell reports (part of the definition, and of its fingerprint)."""
FINGERPRINTS = {1: "4592ab23994f2ac5"}
"""Version -> the first 16 hex digits of `fingerprint()` of that version's definition."""
ORACLE = "oracle"
"""The policy whose times are the reference of time efficiency."""

SUITE_3D_V1: tuple[Cell, ...] = (
    Cell("goal3d", "standard", "ideal", _block(3)),
    Cell("goal3d", "standard", "ocean", _block(3)),
    Cell("goal3d", "hard", "ideal", _block(3)),
    Cell("goal3d", "hard", "ocean", _block(3)),
    Cell("tunnel3d", "standard", "ideal", _block(4)),
    Cell("tunnel3d", "standard", "ocean", _block(4)),
    Cell("tunnel3d", "hard", "ideal", _block(4)),
    Cell("tunnel3d", "hard", "ocean", _block(4)),
)
"""The 3-D benchmark, version 1: the 6-DOF vehicle's goal3d (obstacles over a seabed; hard: walls to pass over or
under, caves, seabed relief) and tunnel3d (tubes; hard: wide tubes with plugs), each in both tiers and both waters
(`auv_mj.sim.ocean3d`), on their own TEST seed blocks; the same metrics as suite v1. Its board (`leaderboard3d.json`)
was measured at commit 8b10ff2, before the tube-sized protection domain and the route time limits: that commit
reproduces it; today's code runs its cells under version 2's rules."""
SUITE_3D_V2: tuple[Cell, ...] = SUITE_3D_V1
"""The 3-D benchmark, version 2: version 1's cells and seeds (so that the two pair by seed), measured under the rules
version 1 lacked: the protection domain sized to the tube (`auv_mj.planners.los3d.tube_field`), time limits from
the route (`auv_mj.tasks.auv3d.route_time_limit`) and the oracle's goal capture and tube clearance
(`auv_mj.planners.map_planner3d`). Its board is `leaderboard3d_v2.json` (docs/benchmark.md, "suite 3d v2")."""
SUITE_3D_V3: tuple[Cell, ...] = tuple(replace(cell, executor="splane-ocean") for cell in SUITE_3D_V2)
"""The 3-D benchmark, version 3: version 2's cells, seeds and rules, every policy on the depth-heading S-plane re-tuned
in ocean water (`splane-ocean`, `auv_mj.control.splane.OCEAN_DEPTH_GAINS`) instead of the task's hand-set one, unless
it brings its own executor. On version 2's hard tubes the re-tuned S-plane lifted the oracle from 47 and 38 to 48
and 45 of 50 and `map-replan` from 22 and 14 to 44 and 26 (docs/executors.md): the hand-set S-plane's tracking, not
the planners, failed there, and a benchmark of planners should measure them on the best classical execution layer.
Its board is `leaderboard3d_v3.json` (docs/benchmark.md, "suite 3d v3")."""
FINGERPRINTS_3D = {1: "80981134ec738137", 2: "f8d702707f88071c", 3: "d835f10a7865ba36"}
"""Version -> the first 16 hex digits of the 3-D suite's fingerprint."""


def definition(suite: Sequence[Cell] = SUITE_V1, name: str = SUITE_NAME, version: int = SUITE_VERSION) -> dict:
    """The suite's definition as plain data: what its fingerprint hashes and its JSON names."""
    return {"name": name, "version": version, "metrics": list(METRICS),
            "cells": [{**_fields(c), "name": c.name, "task_kwargs": c.task_kwargs} for c in suite]}


def _fields(cell: Cell) -> dict:
    """A cell's fields as plain data, without an unset executor (the suites before it hash as they did)."""
    fields = asdict(cell)
    if fields["executor"] is None:
        del fields["executor"]
    return fields


def fingerprint(suite: Sequence[Cell] = SUITE_V1, name: str = SUITE_NAME) -> str:
    """SHA-256 (first 16 hex digits) of the definition: any change to what the suite measures changes it."""
    text = json.dumps({k: v for k, v in definition(suite, name).items() if k != "version"}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class Suite:
    """A versioned benchmark: its name, version, cells and the fingerprints of its versions."""

    name: str
    version: int
    cells: tuple[Cell, ...]
    fingerprints: dict
    board: str
    """File name of its leaderboard in the package data (`auv_mj.benchmark.leaderboard.board_path`)."""

    def fingerprint(self) -> str:
        return fingerprint(self.cells, self.name)


VERSIONS: dict[str, tuple[Suite, ...]] = {
    "auv": (Suite(SUITE_NAME, SUITE_VERSION, SUITE_V1, FINGERPRINTS, "leaderboard.json"),),
    "auv3d": (Suite("suite 3d v1", 1, SUITE_3D_V1, FINGERPRINTS_3D, "leaderboard3d.json"),
              Suite("suite 3d v2", 2, SUITE_3D_V2, FINGERPRINTS_3D, "leaderboard3d_v2.json"),
              Suite("suite 3d v3", 3, SUITE_3D_V3, FINGERPRINTS_3D, "leaderboard3d_v3.json")),
}
"""Domain (`auv-mj benchmark --domain`) -> every version of its suite, oldest first; each keeps its board."""
SUITES = {domain: versions[-1] for domain, versions in VERSIONS.items()}
"""Domain -> its current suite: the planar vehicle's suite v1, the 6-DOF vehicle's suite 3d v3."""


def suite_for(domain: str, version: int | None = None) -> Suite:
    """The `domain`'s suite of `version` (its newest by default); ValueError naming both if there is none."""
    if domain not in VERSIONS:
        raise ValueError(f"no benchmark domain {domain!r}; the domains are {list(VERSIONS)}")
    if version is None:
        return SUITES[domain]
    for suite in VERSIONS[domain]:
        if suite.version == version:
            return suite
    raise ValueError(f"the {domain} suite has no version {version}; its versions are "
                     f"{[s.version for s in VERSIONS[domain]]}")


def suite_named(name: str) -> Suite:
    """The suite of SUITES called `name` (a results dict's "suite"); ValueError naming it if there is none."""
    every = [suite for versions in VERSIONS.values() for suite in versions]
    for suite in every:
        if suite.name == name:
            return suite
    raise ValueError(f"no benchmark suite is called {name!r}; the suites are {[s.name for s in every]}")
