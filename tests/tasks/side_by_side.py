"""The batched env beside one single env per sub-environment, on the same actions: the identity check that both
domains' batches (`AUVVectorEnv`, `AUV3DVectorEnv`) must pass, written once."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from gymnasium.vector import AutoresetMode

TOLERANCE = 1e-9
"""Largest difference allowed between a batched and a single value."""


def assert_close(vector_value, single_value, what: str) -> None:
    """Equal strings, or arrays of one shape within TOLERANCE."""
    if isinstance(single_value, str):
        assert vector_value == single_value, what
        return
    a, b = np.asarray(vector_value, dtype=float), np.asarray(single_value, dtype=float)
    assert a.shape == b.shape, what
    np.testing.assert_allclose(a, b, rtol=0, atol=TOLERANCE, err_msg=what)


def run_side_by_side(vector, singles: Sequence, seeds: Sequence[int], mode: AutoresetMode,
                     policy: Callable[[np.ndarray, np.random.Generator], np.ndarray], steps: int,
                     after_step: Callable[[np.ndarray], None] | None = None) -> dict:
    """Steps `vector` and `singles` (one single env per sub-environment, reset with `seeds`) on `policy`'s actions for
    `steps` steps, comparing observations, rewards, endings and every info entry, across autoresets in `mode`;
    `after_step(pending)` checks more after each step. Closes `vector`; returns counts of the endings and events."""
    num = len(seeds)
    observation, info = vector.reset(seed=list(seeds))
    for i, (single, seed) in enumerate(zip(singles, seeds, strict=True)):
        expected, expected_info = single.reset(seed=seed)
        for key in expected:
            assert_close(observation[key][i], expected[key], f"reset {i} {key}")
        for key, value in expected_info.items():  # is_success, and info["privileged"] of the planner observation
            assert info["_" + key][i], f"reset {i} info {key}"
            assert_close(info[key][i], value, f"reset {i} info {key}")
    rng = np.random.default_rng(0)
    pending = np.zeros(num, dtype=bool)
    seen = {"terminated": 0, "truncated": 0, "autoresets": 0}
    for t in range(steps):
        actions = policy(observation["observation"], rng)
        observation, reward, terminated, truncated, info = vector.step(actions)
        for i, single in enumerate(singles):
            where = f"step {t} env {i}"
            if pending[i]:  # next-step autoreset: this step is the sub-environment's reset
                expected, expected_info = single.reset()
                expected_reward, expected_terminated, expected_truncated = 0.0, False, False
                seen["autoresets"] += 1
            else:
                expected, expected_reward, expected_terminated, expected_truncated, expected_info = \
                    single.step(actions[i])
            final = mode == AutoresetMode.SAME_STEP and (expected_terminated or expected_truncated)
            assert_close(reward[i], expected_reward, f"{where} reward")
            assert terminated[i] == expected_terminated and truncated[i] == expected_truncated, where
            step_obs = {key: info["final_obs"][i][key] for key in expected} if final else \
                {key: observation[key][i] for key in expected}
            step_info = {key: info["final_info"][key][i] for key in info["final_info"]
                         if not key.startswith("_") and info["final_info"]["_" + key][i]} if final else \
                {key: info[key][i] for key in info if not key.startswith("_") and key not in ("final_obs", "final_info")
                 and info["_" + key][i]}
            for key in expected:
                assert_close(step_obs[key], expected[key], f"{where} {key}")
            assert set(step_info) == set(expected_info), where
            for key, value in expected_info.items():
                assert_close(step_info[key], value, f"{where} info {key}")
            if final:  # same-step autoreset: the observation is already the next episode's first
                expected, _ = single.reset()
                seen["autoresets"] += 1
                for key in expected:
                    assert_close(observation[key][i], expected[key], f"{where} reset {key}")
            event = expected_info.get("event", "")
            if event:
                seen[event] = seen.get(event, 0) + 1
        if after_step is not None:
            after_step(pending)
        seen["terminated"] += int(terminated.sum())
        seen["truncated"] += int(truncated.sum())
        pending = (terminated | truncated) if mode == AutoresetMode.NEXT_STEP else np.zeros(num, dtype=bool)
    vector.close()
    return seen
