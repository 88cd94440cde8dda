"""How fast the suite's tasks run (`auv-mj bench --sections tasks,ocean`): environment steps per second of every
planar task under random actions, and of a few under "ocean" conditions beside "ideal" ones, stepped alternately.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from auv_mj.speed.sections import BenchSettings, Measurement, interleaved_times, median_ratio, section
from auv_mj.tasks import suite

TASK_STEPS = 2000
"""Environment steps per task in the "tasks" section (uniform random actions, resets included)."""
OCEAN_TASKS = ("goal", "obstacles", "speed_heading")
"""Tasks whose ocean-conditions speed the "ocean" section sets beside their ideal speed."""
OCEAN_STEPS = 25
"""Environment steps per timed call in the "ocean" section (one of each conditions, alternating)."""


@section("tasks")
def tasks_section(settings: BenchSettings) -> list[Measurement]:
    """Environment steps per second of every suite task, and how many times faster than real time."""
    measurements = []
    for domain, name in suite.PLANAR_TASKS:
        env = suite.load(domain, name)
        rates = [suite.steps_per_second(name, settings.calls(TASK_STEPS), settings.seed)
                 for _ in range(max(1, settings.repeats // 3))]
        rate = float(np.median(rates))
        measurements.append(Measurement(f"{name} env steps/s", rate, "steps/s",
                                        f"{rate * env.control_timestep():.0f}x real time, "
                                        f"step {env.control_timestep():g} s"))
    return measurements


def random_stepper(name: str, conditions: str, seed: int) -> Callable[[], None]:
    """`OCEAN_STEPS` environment steps of `name` under uniform random actions per call (resets included)."""
    env = suite.load("auv", name, task_kwargs={"random": seed, "conditions": conditions})
    spec = env.action_spec()
    actions = np.random.RandomState(seed)
    state = {"step": env.reset()}

    def steps() -> None:
        for _ in range(OCEAN_STEPS):
            if state["step"].last():
                state["step"] = env.reset()
            else:
                state["step"] = env.step(actions.uniform(spec.minimum, spec.maximum, spec.shape))

    return steps


@section("ocean")
def ocean_section(settings: BenchSettings) -> list[Measurement]:
    """Environment steps per second under "ocean" conditions (current, thruster lag, sonar noise, model
    uncertainty) against "ideal" ones, the two environments stepped alternately in every repeat."""
    measurements = []
    for name in OCEAN_TASKS:
        workloads = [random_stepper(name, conditions, settings.seed) for conditions in ("ideal", "ocean")]
        calls = settings.calls(40)
        times = interleaved_times(workloads, [calls, calls], settings.repeats) / OCEAN_STEPS
        ideal, rough = 1.0 / np.median(times, axis=0)
        measurements.append(Measurement(f"{name} ideal env steps/s", ideal, "steps/s"))
        measurements.append(Measurement(f"{name} ocean env steps/s", rough, "steps/s"))
        measurements.append(Measurement(f"{name} ocean / ideal steps/s", median_ratio(times, 0, 1), "x",
                                        "goal >= 0.8"))
    return measurements
