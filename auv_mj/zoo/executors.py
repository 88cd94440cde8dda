"""Executors by name, resolved here once: the zoo turns every executor name into a callable and hands it to the task.

`named_executor(name, domain)` gives the executor of a planning task: the S-planes (Eq. 32, and its gains re-tuned
in ocean water; the tasks' own `auv_mj.tasks.executors.CLASSICAL`), the learned execution layers (the paper's DDPG
executor, the TD3 ocean executor, the 6-DOF depth executor) or a trained speed_heading / depth_heading checkpoint
file. The learned ones are also declared in pyproject.toml's entry-point groups `auv_mj.executors` and
`auv_mj.executors_3d`, so that `suite.load(..., task_kwargs={"executor": "ocean-executor"})` finds them without the
tasks naming this layer.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from auv_mj.agents.offpolicy import Policy
from auv_mj.sim.vehicle import actuator_ranges
from auv_mj.tasks import executors as task_executors
from auv_mj.tasks.depth_executor import DepthExecutorMemory
from auv_mj.tasks.depth_executor import executor_options as depth_executor_options
from auv_mj.tasks.domains import DOMAINS
from auv_mj.tasks.speed_heading import ExecutorMemory, executor_options
from auv_mj.zoo.checkpoints import shipped_checkpoint


class LearnedExecutor:
    """A trained speed_heading policy as a planning task's executor: (command, state) -> (tau_u, tau_r).

    Its input is the speed_heading observation it was trained on and its output becomes the actuator command
    exactly as in the speed_heading task (Eq. 28-29; a residual executor's output corrects the S-plane's),
    through the task's own `ExecutorMemory` (integrals, command history, the S-plane), set up from the
    checkpoint's training options. Call it once per executor step, as the tasks do; `reset` starts an episode.
    `three_d`: a depth_heading policy instead, (V, psi, depth), State3D -> (thrust, rudder, stern), through
    `auv_mj.tasks.depth_executor.DepthExecutorMemory`.
    """

    def __init__(self, policy, low: np.ndarray, high: np.ndarray, three_d: bool = False):
        self.policy, self.low, self.high = policy, np.asarray(low), np.asarray(high)
        kwargs = getattr(policy, "metadata", {}).get("run_info", {}).get("task_kwargs", {})
        if three_d:
            self.memory = DepthExecutorMemory(**depth_executor_options(policy.obs_dim, kwargs), low=self.low,
                                              high=self.high)
            self._act = self.memory.controls
        else:
            self.memory = ExecutorMemory(**executor_options(policy.obs_dim, kwargs), low=self.low, high=self.high)
            self._act = self.memory.forces

    def reset(self) -> None:
        """Zeroes the memories (the start of an episode)."""
        self.memory.reset()

    def __call__(self, command, state) -> np.ndarray:
        return self._act(np.clip(self.policy(self.memory.observe(command, state)), -1.0, 1.0))


def learned_executor(path: Path | None = None, domain: str = "auv") -> LearnedExecutor:
    """The shipped (or given) learned execution layer of `domain`'s vehicle as a task executor ("auv3d": a depth
    executor of the 6-DOF vehicle); its output scaled to the vehicle's actuator ranges, read from its MJCF."""
    three_d = domain == "auv3d"
    low, high = actuator_ranges(DOMAINS[domain].vehicle)
    default = shipped_checkpoint("depth-executor" if three_d else "executor")
    return LearnedExecutor(Policy.load(path or default), low, high, three_d=three_d)


def paper_executor() -> LearnedExecutor:
    """The paper's learned execution layer (`executor`), by name in EXECUTORS."""
    return learned_executor(shipped_checkpoint("executor"))


def ocean_executor() -> LearnedExecutor:
    """The learned ocean executor (`ocean-executor`), by name in EXECUTORS."""
    return learned_executor(shipped_checkpoint("ocean-executor"))


def depth_executor() -> LearnedExecutor:
    """The learned depth executor (`depth-executor`), by name in EXECUTORS_3D."""
    return learned_executor(shipped_checkpoint("depth-executor"), "auv3d")


def learned_depth_executor(path: Path) -> LearnedExecutor:
    """A depth_heading checkpoint file as a 6-DOF executor (entry point `checkpoint` of `auv_mj.executors_3d`)."""
    return learned_executor(path, "auv3d")


EXECUTORS: dict[str, dict[str, Callable[[], task_executors.Executor]]] = {
    "auv": {**DOMAINS["auv"].executors, "executor": paper_executor, "ocean-executor": ocean_executor},
    "auv3d": {**DOMAINS["auv3d"].executors, "depth-executor": depth_executor},
}
"""Domain -> executor name -> a function making it: the tasks' S-planes and the learned execution layers."""


def named_executor(name: str | Path, domain: str = "auv") -> task_executors.Executor:
    """The executor `name` of `domain`'s planning tasks (one of EXECUTORS[domain], or a checkpoint path: a
    speed_heading one on the planar tasks, a depth_heading one on the 6-DOF tasks); ValueError naming it, and the
    nearest name, otherwise."""
    table = EXECUTORS[domain]
    if isinstance(name, str) and name in table:
        return table[name]()
    if isinstance(name, str | Path) and Path(name).is_file():
        return learned_executor(Path(name), domain)
    raise task_executors.unknown_executor(name, list(table))
