"""The protection domain of Sec. 3.2.2 bends the planner's heading away from near echoes only."""

import math

import dm_env
import numpy as np
import pytest

from auv_mj.episode import episode_metrics, record_episode
from auv_mj.planners.avoidance import RepulsiveField, with_repulsion
from auv_mj.planners.guidance import line_of_sight
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.tasks import suite

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


# --- a residual planner on line of sight (issue 15) --------------------------------------------------------


def test_a_residual_planners_zero_action_is_los_avoid_exactly_and_its_correction_bends_the_heading():
    import gymnasium as gym

    from auv_mj.planners.deploy import deploy_env
    from auv_mj.planners.guidance import guided_action, los_avoid

    deployed = deploy_env(gym.make("auv_mj/Planning-v0", tasks=["tunnel"],
                                   per_task_kwargs={"tunnel": {"arena": "random"}}), protection=True, residual=0.5)
    env = deployed.unwrapped
    twin = gym.make("auv_mj/Planning-v0", tasks=["tunnel"],  # los-avoid brings its own protection domain
                    per_task_kwargs={"tunnel": {"arena": "random"}}).unwrapped
    deployed.reset(seed=3)
    observation, _ = twin.reset(seed=3)
    assert deployed.goal_dependent_actions
    classical = los_avoid(twin.active.dm_env)
    for _ in range(60):  # the guided env with zero actions and los-avoid in the plain env: the same run
        expected = classical(dm_env.transition(0.0, observation))
        deployed.step(np.zeros(2))
        observation, *_ = twin.step(expected)
        np.testing.assert_array_equal(env.active.physics.data.qpos, twin.active.physics.data.qpos)
    # a correction adds residual * a1 to line of sight's normalised heading offset, clipped to [-1, 1]
    goal, pose = np.array([10.0, 10.0]), np.array([0.0, 0.0, 0.0])  # bearing 45 deg = 0.5 of the range
    np.testing.assert_allclose(guided_action([0.3, 0.4], goal, pose, 0.5), [0.3, 0.7])
    np.testing.assert_allclose(guided_action([0.3, 1.0], goal, pose, 2.0), [0.3, 1.0])
    np.testing.assert_allclose(guided_action([-0.2, -1.0], goal, pose, 2.0), [-0.2, -1.0])


@pytest.mark.parametrize("residual", [-0.5, 3.0, "some"])
def test_a_bad_planner_residual_is_refused_by_name(residual):
    from auv_mj.planners.deploy import deploy_env
    from auv_mj.tasks.gym_adapter import AUVGymEnv

    with pytest.raises(ValueError, match="residual"):
        deploy_env(AUVGymEnv("goal"), residual=residual)
    with pytest.raises(ValueError, match="residual"):
        deploy_env(AUVGymEnv("speed_heading"), residual=0.5)


def test_a_top_speed_residual_corrects_the_classical_speed_and_bad_speeds_are_refused():
    """speed="top": the speed action is clip(base + a0, -1, 1) about the classical planners' speed; "fixed":
    the base itself."""
    from types import SimpleNamespace

    from auv_mj.planners.deploy import deploy_env
    from auv_mj.planners.guidance import TOP_SPEED_ACTION, approach_speed, guided_action
    from auv_mj.tasks.gym_adapter import AUVGymEnv
    from auv_mj.tasks.planning_step import speed_action
    from auv_mj.tasks.routes import TARGET_SPEED

    goal, pose = np.array([10.0, 10.0]), np.array([0.0, 0.0, 0.0])
    open_water = SimpleNamespace(goals=np.array([[500.0, 500.0]]), goal_radius=12.5)  # top speed all the way
    near_small = SimpleNamespace(goals=np.array([[10.0, 10.0]]), goal_radius=2.0)  # within 30 m of a 2 m goal
    np.testing.assert_allclose(guided_action([-0.25, 0.4], goal, pose, 0.5, "top", open_water),
                               [TOP_SPEED_ACTION - 0.25, 0.7])
    np.testing.assert_allclose(guided_action([0.6, 0.0], goal, pose, 0.5, "top", open_water)[0], 1.0)  # clipped
    np.testing.assert_allclose(guided_action([-0.6, 0.0], goal, pose, 0.5, "top", near_small)[0],
                               speed_action(TARGET_SPEED) - 0.6)
    np.testing.assert_allclose(guided_action([-0.6, 0.4], goal, pose, 0.5, "fixed", open_water),
                               [TOP_SPEED_ACTION, 0.7])  # speed="fixed": the planner steers only
    env = deploy_env(AUVGymEnv("tunnel", {"arena": "random"}), residual=1.0, speed="top").unwrapped
    env.reset(seed=1)
    task, far = env.task, np.array([*env.task.goals[-1] - 500.0, 0.0])
    assert approach_speed(task, far) == TOP_SPEED_ACTION  # the tunnel's 2 m goal: slow only near it
    assert approach_speed(task, np.array([*task.goals[-1] + 1.0, 0.0])) == speed_action(TARGET_SPEED)
    with pytest.raises(ValueError, match="speed must be one of"):
        deploy_env(AUVGymEnv("obstacles"), residual=1.0, speed="fast")
    with pytest.raises(ValueError, match="set residual > 0"):
        deploy_env(AUVGymEnv("obstacles"), speed="top")


# --- the speed-aware protection domain (issue 15) ----------------------------------------------------------


def test_the_speed_aware_domain_is_the_papers_at_or_below_the_reference_speed():
    """The paper's repulsion (with the speed-aware domain's own gain k_2) whenever V_cmd <= V_ref."""
    from dataclasses import replace

    from auv_mj.planners.avoidance import PROTECTIONS, protect
    from auv_mj.tasks.planning_observation import SONAR_SLICE
    from auv_mj.tasks.planning_step import speed_command

    aware = PROTECTIONS["speed-aware"]
    papers_form = replace(PROTECTIONS["paper"], gain=aware.gain)
    rng = np.random.default_rng(0)
    observation = np.zeros(18)
    for _ in range(200):
        observation[SONAR_SLICE] = rng.uniform(0.0, 1.0, 9) ** 3  # many echoes inside the domain
        action = np.array([rng.uniform(-1.0, 0.0), rng.uniform(-1.0, 1.0)])  # V_cmd in [0, 1] m/s
        assert speed_command(action[0]) <= PROTECTIONS["speed-aware"].reference_speed
        np.testing.assert_array_equal(protect(action, observation, aware), protect(action, observation, papers_form))


def test_above_the_reference_speed_echoes_count_in_time_to_contact_and_one_ahead_slows_the_vehicle():
    from dataclasses import replace

    from auv_mj.planners.avoidance import PROTECTIONS, protect
    from auv_mj.tasks.planning_observation import SONAR_SLICE
    from auv_mj.tasks.planning_step import speed_action, speed_command

    aware = PROTECTIONS["speed-aware"]
    paper = replace(PROTECTIONS["paper"], gain=aware.gain)  # the paper's form with the same k_2
    observation = np.zeros(18)
    # An echo to port (outside the cone ahead) at 24 m seen at 2 m/s bends the heading as one at 12 m does at 1 m/s.
    observation[SONAR_SLICE] = ranges(s8=24.0) / SONAR_RANGE
    fast = protect([1.0, 0.2], observation, aware)
    assert fast[0] == 1.0  # nothing ahead: the speed stays
    assert fast[1] < protect([1.0, 0.2], observation, paper)[1]  # bent harder than by the paper's domain
    observation[SONAR_SLICE] = ranges(s8=12.0) / SONAR_RANGE
    assert fast[1] == pytest.approx(protect([0.0, 0.2], observation, paper)[1], abs=1e-12)
    # An echo in the cone ahead nearer than slow_distance brings the command back to the reference speed,
    # where the domain is the paper's; one beyond it does not.
    for beam in ("s4", "s5", "s6"):
        observation[SONAR_SLICE] = ranges(**{beam: aware.slow_distance - 0.1}) / SONAR_RANGE
        slowed = protect([0.6, 0.0], observation, aware)
        assert speed_command(slowed[0]) == pytest.approx(aware.reference_speed)
        assert slowed[0] == speed_action(aware.reference_speed)
        np.testing.assert_array_equal(slowed, protect([slowed[0], 0.0], observation, paper))
    observation[SONAR_SLICE] = ranges(s5=aware.slow_distance + 0.1) / SONAR_RANGE
    assert protect([0.6, 0.0], observation, aware)[0] == 0.6
    observation[SONAR_SLICE] = ranges(s3=aware.slow_distance - 5.0) / SONAR_RANGE  # 45 deg: outside the cone
    assert protect([0.6, 0.0], observation, aware)[0] == 0.6


@pytest.mark.parametrize("value", ["fast", 1, 0.5, [True]])
def test_a_protection_option_that_names_no_domain_is_refused_by_value(value):
    from auv_mj.planners.avoidance import protection_field

    with pytest.raises(ValueError, match="protection must be True, False or one of"):
        protection_field(value)
    assert protection_field(False) is None and protection_field(None) is None
    assert protection_field(True) == RepulsiveField() == protection_field("paper")


# --- the map's edge in the protection domain (a geofence) ---------------------------------------------------


def test_a_field_with_a_fence_reads_the_map_edge_as_echoes_and_one_without_ignores_it():
    from dataclasses import replace

    from auv_mj.planners.avoidance import PROTECTIONS, protect
    from auv_mj.tasks.planning_observation import SONAR_SLICE

    observation = np.zeros(18)
    observation[SONAR_SLICE] = ranges(s2=60.0) / SONAR_RANGE
    edge = ranges(s5=12.0, s6=14.0)
    for field in (PROTECTIONS["paper"], PROTECTIONS["speed-aware"]):
        fenced, unfenced = replace(field, fence=True), replace(field, fence=False)
        echoes = observation.copy()
        echoes[SONAR_SLICE] = np.minimum(ranges(s2=60.0), edge) / SONAR_RANGE
        np.testing.assert_array_equal(protect([0.6, 0.1], observation, fenced, edge),
                                      protect([0.6, 0.1], echoes, fenced))  # the edge is an echo like any
        np.testing.assert_array_equal(protect([0.6, 0.1], observation, unfenced, edge),
                                      protect([0.6, 0.1], observation, unfenced))
        assert protect([0.6, 0.1], observation, fenced, edge)[1] != protect([0.6, 0.1], observation, unfenced)[1]


def test_a_planning_task_measures_its_map_edge_from_the_bow_of_the_vehicle():
    """`map_fence` against the fence computed here from the pose, the bow offset and the arena's bounds."""
    from auv_mj.arenas import arena
    from auv_mj.planners.avoidance import map_fence
    from auv_mj.sim.sonar import fence_ranges

    env = suite.load("auv", "obstacles", task_kwargs={"random": 4})
    env.reset()
    y = env.physics.pose()[1]
    bounds = arena.arena_info(env.physics).bounds
    with env.physics.reset_context():
        env.physics.data.qpos[:3] = bounds[2] - 15.0, y, 0.0  # 15 m from the east edge, facing it
    fence = map_fence(env)
    bow = 0.665  # models/auv.xml's sonar sites
    expected = fence_ranges((bounds[2] - 15.0 + bow, y), 0.0, bounds)
    np.testing.assert_allclose(fence(), expected, atol=1e-9)
    assert fence()[4] == pytest.approx(15.0 - bow)
    assert map_fence(suite.load("auv", "speed_heading", task_kwargs={"random": 0})) is None
