"""Time limits of the 3-D planning tasks from their routes (issue 52): a tube's from its centreline, a hard goal3d
arena's from the oracle's certificate; a user's time_limit that the route cannot meet is named in a warning."""

from __future__ import annotations

import subprocess
import sys
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import auv_mj  # noqa: F401  (picks the OpenGL backend before dm_control is imported)
from auv_mj.arenas import traps3d, tubes
from auv_mj.tasks import auv3d


def write_long_tube(tmp_path) -> tuple[str, float]:
    """A user's tube of about 420 m (a climbing dog-leg), written by `auv-mj tunnel --tube`; (its path, the length
    of its centreline corners [m])."""
    corners = np.array([[0.0, 0.0, -30.0], [150.0, 0.0, -30.0], [250.0, 60.0, -26.0], [400.0, 60.0, -22.0]])
    csv = tmp_path / "long_xyz.csv"
    csv.write_text("x,y,z\n" + "\n".join(",".join(f"{v:g}" for v in p) for p in corners) + "\n")
    tube = tmp_path / "long_tube.xml"
    built = subprocess.run([sys.executable, "-m", "auv_mj.cli", "tunnel", "--tube", str(csv), "--width", "8",
                            "--smooth", "-o", str(tube)], capture_output=True, text=True, timeout=300)
    assert built.returncode == 0, built.stderr
    return str(tube), float(np.sum(np.linalg.norm(np.diff(corners, axis=0), axis=1)))


def test_route_time_limit_is_the_planar_rule_at_the_planners_speed():
    assert auv3d.route_time_limit(0.0) == 60.0
    assert auv3d.route_time_limit(150.0) == 260.0  # 2 x 100 s + 60 s
    assert auv3d.route_time_limit(421.0) == 630.0  # 2 x 280.7 s + 60 s, up to 10 s
    lengths = np.linspace(0.0, 2000.0, 101)
    limits = np.array([auv3d.route_time_limit(x) for x in lengths])
    assert np.all(limits >= 2.0 * lengths / auv3d.CRUISE_SPEED + 60.0) and np.all(np.diff(limits) >= 0)


def test_a_long_user_tube_gets_a_limit_it_can_meet_and_a_short_given_one_is_named(tmp_path):
    """A 420 m tube timed out at the fixed 250 s under every 3-D policy with nothing to say why; its limit is now
    its centreline's, and a time_limit given too short for it is kept with a warning that names time_limit."""
    path, corners = write_long_tube(tmp_path)
    env = auv3d.tunnel3d(arena=path)
    before_reset = env.time_limit  # a file's tube is known at once (a render's progress bar counts to it)
    env.reset()
    task = env.task
    length = auv3d.path_length(task.path)
    assert length > 0.95 * corners and length > 400.0  # smoothing cuts the corners a little
    assert env.time_limit == before_reset == auv3d.route_time_limit(length) > auv3d.TUNNEL_TIME_LIMIT
    assert env.time_limit >= 2.0 * length / auv3d.CRUISE_SPEED  # twice what the planners' cruise needs
    given = auv3d.tunnel3d(arena=path, time_limit=250.0)
    with pytest.warns(UserWarning, match=r"time_limit=250 s is shorter than the \d+ s this episode's \d+ m route"):
        given.reset()
    assert given.time_limit == 250.0
    enough = auv3d.tunnel3d(arena=path, time_limit=400.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        enough.reset()  # 400 s covers the route at cruise speed: nothing to say
    assert enough.time_limit == 400.0


def test_the_tube_sets_dm_controls_clock_to_its_routes_limit(tmp_path):
    """The environment's step limit (which dm_control's `Environment.step` ends an episode at, as a truncation)
    follows the episode's route: a 24 m tube with the task's floor taken away has route_time_limit(24 m) = 100 s,
    200 planner steps, set at its reset."""
    line = np.column_stack([np.linspace(0.0, 24.0, 7), np.zeros(7), np.full(7, -20.0)])
    path = tmp_path / "short.xml"
    ET.ElementTree(tubes.tube_arena(tubes.Tube(line, 3.0), "short")).write(path)
    env = auv3d.tunnel3d(arena=str(path))
    env.task.time_limit = 0.0
    env.reset()
    assert env.time_limit == auv3d.route_time_limit(24.0) == 100.0
    assert env._step_limit == pytest.approx(100.0 / auv3d.PLANNER_DT)


@pytest.mark.parametrize("seed", [30_000_001, 30_000_002])
def test_the_hard_goal3d_limit_covers_its_certified_route(seed):
    """The hard goal3d arena's route is the oracle's certificate (the same path `traps3d.certify` finds again), and
    its time limit covers it twice at the planners' cruise speed (200 s did not, for 120-150 m routes with climbs)."""
    env = auv3d.goal3d(tier="hard", random=seed)
    env.reset()
    task = env.task
    route = task.route
    assert np.allclose(route[0], env.physics.position(), atol=1e-6)
    assert np.linalg.norm(route[-1] - task.goal) <= auv3d.GOAL_RADIUS + 2.0
    root, start, heading, goal, path = task.draw_arena(np.random.RandomState(seed))
    again = traps3d.certify(traps3d.Arena3D(root, start, heading, goal, path, ""), task.max_pitch, auv3d.MIN_DEPTH,
                            auv3d.GOAL_RADIUS)
    length = auv3d.path_length(route)
    assert length == pytest.approx(auv3d.path_length(np.vstack([start, again])))
    assert length >= np.linalg.norm(goal - start) - auv3d.GOAL_RADIUS
    assert env.time_limit == max(auv3d.GOAL_TIME_LIMIT, auv3d.route_time_limit(length))
    assert env.time_limit * auv3d.CRUISE_SPEED >= 2.0 * length


def test_standard_arenas_keep_at_least_the_v1_limits():
    """A standard goal3d route is the straight line, and no episode's limit is below suite 3d v1's."""
    goal = auv3d.goal3d(random=10_000)
    goal.reset()
    straight = np.linalg.norm(goal.task.goal - goal.physics.position())
    assert auv3d.path_length(goal.task.route) == pytest.approx(straight)
    assert goal.time_limit == max(auv3d.GOAL_TIME_LIMIT, auv3d.route_time_limit(straight))
    tube = auv3d.tunnel3d(random=10_000)
    limits = []
    for _ in range(3):
        tube.reset()
        limits.append(tube.time_limit)
        assert tube.time_limit == max(auv3d.TUNNEL_TIME_LIMIT, auv3d.route_time_limit(
            auv3d.path_length(tube.task.path)))
    assert min(limits) >= auv3d.TUNNEL_TIME_LIMIT
