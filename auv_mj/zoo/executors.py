"""Executors by name, resolved here once: the zoo turns every executor name into a callable and hands it to the task.

`named_executor(name, three_d)` gives the executor of a planning task: the S-planes (Eq. 32, and its gains re-tuned
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


def learned_executor(path: Path | None = None, three_d: bool = False) -> LearnedExecutor:
    """The shipped (or given) learned execution layer as a task executor (`three_d`: a depth executor of the
    6-DOF vehicle)."""
    if three_d:
        low, high = actuator_ranges("auv3d.xml")
        return LearnedExecutor(Policy.load(path or shipped_checkpoint("depth-executor")), low, high, three_d=True)
    low, high = actuator_ranges("auv.xml")
    return LearnedExecutor(Policy.load(path or shipped_checkpoint("executor")), low, high)


def paper_executor() -> LearnedExecutor:
    """The paper's learned execution layer (`executor`), by name in EXECUTORS."""
    return learned_executor(shipped_checkpoint("executor"))


def ocean_executor() -> LearnedExecutor:
    """The learned ocean executor (`ocean-executor`), by name in EXECUTORS."""
    return learned_executor(shipped_checkpoint("ocean-executor"))


def depth_executor() -> LearnedExecutor:
    """The learned depth executor (`depth-executor`), by name in EXECUTORS_3D."""
    return learned_executor(shipped_checkpoint("depth-executor"), three_d=True)


def learned_depth_executor(path: Path) -> LearnedExecutor:
    """A depth_heading checkpoint file as a 6-DOF executor (entry point `checkpoint` of `auv_mj.executors_3d`)."""
    return learned_executor(path, three_d=True)


EXECUTORS: dict[str, Callable[[], task_executors.Executor]] = {
    **task_executors.CLASSICAL, "executor": paper_executor, "ocean-executor": ocean_executor}
"""Executor name -> a function making it, on the planar planning tasks."""
EXECUTORS_3D: dict[str, Callable[[], task_executors.Executor]] = {
    **task_executors.CLASSICAL_3D, "depth-executor": depth_executor}
"""The same on the 6-DOF planning tasks (goal3d, tunnel3d)."""


def named_executor(name: str | Path, three_d: bool = False) -> task_executors.Executor:
    """The executor `name` (one of EXECUTORS, or a speed_heading checkpoint path; with `three_d`, of a 6-DOF task,
    one of EXECUTORS_3D or a depth_heading checkpoint path); ValueError naming it, and the nearest name, otherwise."""
    table = EXECUTORS_3D if three_d else EXECUTORS
    if isinstance(name, str) and name in table:
        return table[name]()
    if isinstance(name, str | Path) and Path(name).is_file():
        return learned_executor(Path(name), three_d=three_d)
    raise task_executors.unknown_executor(name, list(table))
