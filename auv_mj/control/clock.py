"""The executor layer's clock, one definition for the planar and the 6-DOF tasks' physics.

A task's low-level controller (the S-plane or a learned executor, Sec. 4.2 of Lyu et al. 2023) acts every
EXECUTOR_DT of simulated time while the planner's step lasts several of them. `ExecutorClock` makes that a
property of the physics: `set_tick(callback)` has `callback(physics)` called before the first physics step and
then every period of stepping, so `step(n)` stays one call and `dm_control.rl.control.Environment` keeps owning
the sub-steps and the time limits.
"""

from __future__ import annotations

from collections.abc import Callable

from dm_control.rl import control


class ExecutorClock:
    """Mixin of a dm_control `Physics` (put it first among the bases) that calls a tick callback while stepping.

    `TICK_PERIOD` [s], the default period of `set_tick`, is the subclass's: its executor's EXECUTOR_DT, which lives
    beside that executor.
    """

    TICK_PERIOD: float
    _tick: Callable | None = None
    _tick_steps = 1
    _steps_to_tick = 0

    @property
    def tick_steps(self) -> int | None:
        """Physics steps per tick, None without a callback."""
        return self._tick_steps if self._tick is not None else None

    @property
    def at_tick(self) -> bool:
        """Whether the next step begins with a tick."""
        return self._steps_to_tick == 0

    def set_tick(self, callback: Callable | None, period: float | None = None) -> None:
        """Calls `callback(physics)` before the first step and then every `period` s (`TICK_PERIOD` by default)
        of stepping; None removes it."""
        self._tick = callback
        self._tick_steps = control.compute_n_steps(self.TICK_PERIOD if period is None else period,
                                                   self.timestep())
        self._steps_to_tick = 0

    def step(self, nstep: int = 1) -> None:
        """Advances `nstep` physics steps, calling the tick callback whenever one is due."""
        tick = self._tick
        if tick is None:
            super().step(nstep)
            return
        while nstep > 0:
            if self._steps_to_tick == 0:
                tick(self)
                self._steps_to_tick = self._tick_steps
            n = min(nstep, self._steps_to_tick)
            super().step(n)
            nstep -= n
            self._steps_to_tick -= n

    def reset(self, keyframe_id=None) -> None:
        """Resets the simulation; the next step begins with a tick."""
        super().reset(keyframe_id)
        self._steps_to_tick = 0

    def copy(self, share_model: bool = False):
        """A copy with the same tick callback and clock."""
        new = super().copy(share_model=share_model)
        new._tick, new._tick_steps, new._steps_to_tick = self._tick, self._tick_steps, self._steps_to_tick
        return new
