"""What a registered policy is (`PolicySpec`), the registry's tables (`POLICIES`, `RESOLVERS`) and `register`.

The entries themselves are in `auv_mj.zoo.registry`; modules that add forms of name (`auv_mj.zoo.outside`) import
this module, not that one, so the registry has no import cycle.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from auv_mj.episode import Planner
from auv_mj.tasks import domains as suite_domains

ROLES = {"use": "To use", "paper": "The paper's", "reference": "References and ablations",
         "comparison": "Kept for comparison"}
"""What a spec is for (`PolicySpec.role`) -> its heading in `auv-mj policies` and docs/policies.md's tables: the
ones to use, the paper's own, the references and ablations that measure others, and earlier ones kept for
comparison."""
RUNS_ON = ("planning", "executor", "any")
"""What a spec's `tasks` may be: the suite's tasks tagged "planning", those tagged "executor", or every task."""
DOMAINS = {name: domain.title for name, domain in suite_domains.DOMAINS.items()}
"""The suite's domains a spec may run on (`PolicySpec.domains`) -> the word the tables and refusals use: "auv", the
planar vehicle of the paper (surge, sway, yaw), and "auv3d", the 6-DOF REMUS-100 (`auv_mj.tasks.domains`)."""


@dataclass(frozen=True)
class Deployment:
    """What a spec's `build` gets: the environment of the episode, its task and seed, and the checkpoint that
    the name resolved to (the shipped one, NAME=PATH's PATH or a checkpoint path; None for a classical policy)."""

    env: Any
    task: str | None
    seed: int
    checkpoint: Path | None
    spec: PolicySpec
    domain: str = "auv"
    """The environment's domain (`auv_mj.tasks.domains.of_env`), read once when the policy is made."""


def by_domain(**builds: Callable[[Deployment], Planner]) -> Callable[[Deployment], Planner]:
    """A spec's build that differs by domain, e.g. `by_domain(auv=planar_build, auv3d=build_3d)`: the one of the
    deployment's domain, chosen where the policy is made rather than by checks inside each build."""
    unknown = set(builds) - set(DOMAINS)
    if unknown:
        raise ValueError(f"by_domain: {sorted(unknown)} are no domains of {list(DOMAINS)}")

    def build(deployment: Deployment) -> Planner:
        return builds[deployment.domain](deployment)

    build.domains = tuple(builds)  # type: ignore[attr-defined]
    return build


@dataclass(frozen=True)
class PolicySpec:
    """One named policy. Only `description` and `build` are required; the rest say how it is deployed."""

    description: str
    """One line for `--help` and the policy table of docs/policies.md."""
    build: Callable[[Deployment], Planner]
    """Makes the acting policy for one episode's environment."""
    family: str = "classical"
    """"learned", "classical" or "reference" (random, oracle): the column of docs/policies.md's table."""
    tasks: str = "any"
    """The tasks it runs on, one of RUNS_ON."""
    checkpoint: str | None = None
    """Its shipped checkpoint: a file in `agents/checkpoints/`."""
    checkpoint_on: dict[str, str] = field(default_factory=dict)
    """Task -> another shipped checkpoint on that task (the paper trains a planner per environment)."""
    executor: str | None = None
    """The executor it always runs on, on a planning task (one of EXECUTORS); None: the task's S-plane, or the one
    the task options name."""
    default_executor: str | None = None
    """The executor it runs on unless the task options name one."""
    protection: bool | str | None = None
    """Its protection domain (Sec. 3.2.2, `auv_mj.planners.avoidance.PROTECTIONS`). A checkpoint's: None, the one it
    trained with; False, none; True, its own or else the paper's; a name, that one. Any other policy's: a name (or True,
    the paper's) puts its actions through that domain, with the map's geofence where the domain reads it."""
    accepts_path: bool = False
    """Whether `NAME=PATH` runs checkpoint PATH in its place."""
    role: str = "use"
    """What it is for: one of ROLES."""
    domains: tuple[str, ...] = ("auv",)
    """The suite domains whose tasks it runs on (keys of DOMAINS): a policy built for the planar vehicle reads its
    observation, pose and map, which the 6-DOF vehicle's tasks do not have, so a spec names the domains it knows."""

    def __post_init__(self):
        if self.tasks not in RUNS_ON:
            raise ValueError(f"PolicySpec.tasks {self.tasks!r}: not one of {RUNS_ON}")
        if self.role not in ROLES:
            raise ValueError(f"PolicySpec.role {self.role!r}: not one of {list(ROLES)}")
        if isinstance(self.domains, str) or not self.domains or not set(self.domains) <= set(DOMAINS):
            raise ValueError(f"PolicySpec.domains {self.domains!r}: a non-empty tuple of {list(DOMAINS)}")


POLICIES: dict[str, PolicySpec] = {}
"""Name -> spec: every name `--policy` takes besides checkpoint paths and RESOLVERS' forms."""

RESOLVERS: list[Callable[[str], tuple[PolicySpec, Path | None] | None]] = []
"""Turn a name that is no registered name into (spec, checkpoint), or None if the name is not of their form."""


def register(name: str, spec: PolicySpec) -> PolicySpec:
    """Adds `spec` under `name`; a name is registered once."""
    if name in POLICIES:
        raise ValueError(f"policy {name!r} is registered twice")
    POLICIES[name] = spec
    return spec
