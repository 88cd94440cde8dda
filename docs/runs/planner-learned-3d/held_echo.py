"""The scratch test of a held echo at deploy time: the shipped 3-D student on the hard validation tubes with each fan
beam held at the nearer of its last two pings (a lost echo, which reads the full range, then shows the last one).

    EXECUTOR=splane-ocean python docs/runs/planner-learned-3d/held_echo.py '"ocean"'
    EXECUTOR=splane-ocean python docs/runs/planner-learned-3d/held_echo.py \
        '{"base": "ideal", "sonar": {"latency": 0, "floor": 0.0, "proportional": 0.0, "dropout": 0.05}}'

The argument is the task's `conditions` option as JSON. Prints the episodes passed of 50 (seeds 28000-28049, tunnel3d
hard) with the held echo. The student was not trained on it; nothing here is in the planner (the record's "What ocean
water costs the student in the hard tubes" says why it was not taken). The episodes are `episodes.py`'s.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.tasks import auv3d

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "map-replan-3d"))
import episodes  # noqa: E402  (the episodes of the map-replan record)

FIRST_BEAM = len(auv3d.PLANNING_OBSERVATION)
"""Where the fan's ranges start in the planning observation."""


def held_echo() -> None:
    """Wraps `PPOPolicy`'s call and reset so that each beam reads the nearer of this ping and the last."""
    call, reset = PPOPolicy.__call__, PPOPolicy.reset

    def held_reset(self) -> None:
        self.last_fan = None
        reset(self)

    def held_call(self, obs):
        obs = {key: np.array(value, copy=True) for key, value in obs.items()}
        fan = obs["observation"][..., FIRST_BEAM:].copy()
        if getattr(self, "last_fan", None) is not None:
            obs["observation"][..., FIRST_BEAM:] = np.minimum(fan, self.last_fan)
        self.last_fan = fan
        return call(self, obs)

    PPOPolicy.__call__, PPOPolicy.reset = held_call, held_reset


def main(conditions: str) -> None:
    held_echo()
    water = json.loads(conditions)
    passed = sum(episodes.run("planner-learned", "tunnel3d", "hard", water, seed)["event"] == "goal"
                 for seed in range(28000, 28050))
    print(f"held echo, conditions {conditions}: {passed} of 50")


if __name__ == "__main__":
    main(sys.argv[1])
