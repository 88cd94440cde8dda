"""The protection domain of Sec. 3.2.2 bends the planner's heading away from near echoes only."""

import math

import numpy as np
import pytest

from auv_mj.episode import episode_metrics, record_episode
from auv_mj.sonar import SONAR_RANGE
from tasks import suite
from tasks.avoidance import RepulsiveField, with_repulsion
from tasks.guidance import line_of_sight

FIELD = RepulsiveField()


def ranges(**echoes: float) -> np.ndarray:
    """Nine sonar ranges, 120 m except the beams given as s1=..., s9=... (S1 starboard ... S9 port)."""
    values = np.full(9, SONAR_RANGE)
    for name, distance in echoes.items():
        values[int(name[1:]) - 1] = distance
    return values


def test_no_echo_in_the_domain_leaves_the_heading_alone():
    assert FIELD.heading_offset(ranges(), 0.3) == 0.3
    assert FIELD.heading_offset(ranges(s5=FIELD.influence + 1), -0.2) == -0.2


def test_echoes_push_the_heading_away_and_harder_when_nearer():
    port_far = FIELD.heading_offset(ranges(s7=20.0), 0.0)
    port_near = FIELD.heading_offset(ranges(s7=8.0), 0.0)
    starboard = FIELD.heading_offset(ranges(s3=8.0), 0.0)
    assert port_near < port_far < 0  # obstacle to port: turn to starboard (negative yaw)
    assert starboard == pytest.approx(-port_near)  # mirror image
    assert abs(port_near) <= math.pi / 2


def test_an_echo_dead_ahead_turns_towards_the_freer_side():
    assert FIELD.heading_offset(ranges(s5=10.0, s2=15.0), 0.0) > 0  # starboard cluttered: go to port
    assert FIELD.heading_offset(ranges(s5=10.0, s8=15.0), 0.0) < 0


def test_line_of_sight_with_the_domain_clears_the_table_7_obstacles():
    env = suite.load("auv", "obstacles", task_kwargs={"random": 0, "scenario": "a"})
    bare = episode_metrics(record_episode(env, line_of_sight(env)))
    env = suite.load("auv", "obstacles", task_kwargs={"random": 0, "scenario": "a"})
    guarded = episode_metrics(record_episode(env, with_repulsion(line_of_sight(env))))
    assert bare["collision"] and not bare["success"]
    assert guarded["success"] and not guarded["collision"] and guarded["min_clearance"] > 5.0
