"""The 3-D mapping planner, the 3-D oracle and the hard 3-D arenas: certificates, the voxel map, a trap escaped."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest
from dm_control.rl import control

from auv_mj.arenas import traps3d, voxels
from auv_mj.arenas.arena3d import arena_root, seabed
from auv_mj.control.depth_heading import DepthHeadingGains
from auv_mj.planners.los3d import classical_3d
from auv_mj.planners.map_planner3d import SonarVoxelMap, sonar_voxel_planner, true_voxel_planner, turning_radius
from auv_mj.sim.sensors3d import FAN_AZIMUTHS, sonar_fan
from auv_mj.sim.sonar import SONAR_RANGE
from auv_mj.tasks.auv3d import GOAL_RADIUS, MIN_DEPTH, WATER_DEPTH, Goal3D, Physics3D, Tunnel3D

MAX_PITCH = DepthHeadingGains().max_pitch
SEEDS = (20_000, 20_001, 20_002)
"""Validation seeds (`auv_mj.seeds.VALIDATION`)."""


def _assert_flyable(path: np.ndarray, start, goal, radius: float) -> None:
    """A certificate's path starts at the start's voxel, ends within the goal's radius (and a voxel), and no segment
    climbs or dives more steeply than the pitch limit allows (independent of the lattice)."""
    assert np.linalg.norm(path[0] - start) < 2.0
    assert np.linalg.norm(path[-1] - goal) <= radius + 2.0
    steps = np.diff(path, axis=0)
    slopes = np.abs(steps[:, 2]) / np.maximum(np.hypot(steps[:, 0], steps[:, 1]), 1e-9)
    assert np.all(slopes <= math.tan(MAX_PITCH * voxels.CLIMB_MARGIN) + 1e-9)


def test_hard_goal_arenas_are_certified_by_the_oracle():
    kinds = set()
    for seed in SEEDS:
        task = Goal3D(tier="hard", random=seed)
        root, start, heading, goal, path = task.draw_arena(np.random.RandomState(seed))
        arena = traps3d.Arena3D(root, start, heading, goal, path, "")
        plan = traps3d.certify(arena, task.executor.gains.max_pitch, MIN_DEPTH, GOAL_RADIUS)
        assert plan is not None
        _assert_flyable(plan, start, goal, GOAL_RADIUS)
        names = {g.get("name") for g in root.iter("geom")}
        kinds |= {k for k in traps3d.KINDS if any(k in (n or "") for n in names)} | {"relief" for n in names
                                                                                        if "ridge" in (n or "")}
        # The same seed draws the same arena.
        again = task.draw_arena(np.random.RandomState(seed))[0]
        assert ET.tostring(again) == ET.tostring(root)
    assert kinds, "the hard tier holds traps"


def test_hard_tube_is_certified_inside_the_tube():
    task = Tunnel3D(tier="hard", random=SEEDS[0])
    root, start, _, goal, line = task.draw_arena(np.random.RandomState(SEEDS[0]))
    arena = traps3d.Arena3D(root, start, 0.0, goal, line, "plugs")
    assert any((g.get("name") or "").startswith("plug_") for g in root.iter("geom"))
    plan = traps3d.certify(arena, MAX_PITCH, None, 2.0, corridor=(line, traps3d.HARD_TUBE_RADIUS))
    assert plan is not None
    _assert_flyable(plan, start, goal, 2.0)
    # Independently: every waypoint lies inside the tube, and a plug stands across the centreline.
    distance = np.min(np.linalg.norm(plan[:, None, :] - line[None, :, :], axis=2), axis=1)
    assert np.all(distance < traps3d.HARD_TUBE_RADIUS + 2.0)
    model, data = traps3d.arena_model(root)
    plug = next(g for g in range(model.ngeom) if model.geom(g).name.startswith("plug_"))
    centre = data.geom_xpos[plug]
    near = line[np.argmin(np.linalg.norm(line - centre, axis=1))]
    local = data.geom_xmat[plug].reshape(3, 3).T @ (near - centre)
    assert np.all(np.abs(local[1:]) <= model.geom_size[plug][1:] + 1.0)  # the centreline runs into the plug


def test_true_map_marks_voxels_within_half_a_diagonal_of_a_sphere():
    root = arena_root("sphere", [ET.Element("geom", name="ball", type="sphere", size="4", pos="10.3 0.2 -20.1")])
    model, data = traps3d.arena_model(root)
    space = voxels.VoxelGrid.covering((0, -10, -30), (20, 10, -10), 2.0, 1.0)
    occupied = voxels.geom_occupancy(space, model, data)
    x, y, z = np.meshgrid(*space.centres(), indexing="ij")
    expected = np.sqrt((x - 10.3) ** 2 + (y - 0.2) ** 2 + (z + 20.1) ** 2) <= 4.0 + 0.5 * math.sqrt(2 ** 2 * 2 + 1)
    np.testing.assert_array_equal(occupied, expected)


def _wall_task(depth_below_top: float = 10.0):
    """A wall across the route from the seabed up to `depth_below_top` metres above start and goal (30 m deep)."""

    class WallTask(Goal3D):
        def draw_arena(self, random):
            top = 30.0 - depth_below_top
            half = 0.5 * (WATER_DEPTH - top)
            wall = ET.Element("geom", name="wall", type="box", size=f"1 150 {half}", pos=f"60 0 {-WATER_DEPTH + half}")
            root = arena_root("wall", [seabed(WATER_DEPTH), wall])
            return root, np.array([0.0, 0.0, -30.0]), 0.0, np.array([120.0, 0.0, -30.0]), np.zeros((0, 3))

    task = WallTask(random=0)
    return control.Environment(Physics3D.load(None, "ideal"), task, time_limit=200.0, control_timestep=0.5)


def test_sonar_map_marks_echoes_on_the_wall():
    env = _wall_task()
    env.reset()
    mapper = SonarVoxelMap(env)
    for _ in range(12):  # towards the wall
        env.step([0.0, 0.0, 0.0])
    mapper.start()
    mapper.update()
    marked = np.argwhere(mapper.occupied & ~mapper.surface)
    ahead = 59.0 - env.physics.position()[0]
    reaching = int(np.sum(ahead / np.cos(FAN_AZIMUTHS) < 0.95 * SONAR_RANGE))  # level beams with the wall in range
    assert reaching >= 5
    centres = mapper.grid.centre(marked)
    # Every echo voxel holds a point of the wall's face (x = 59) or of the seabed: its centre is within half a voxel.
    half = 0.5 * mapper.grid.cell
    on_wall = np.abs(centres[:, 0] - 59.0) <= half[0] + 1e-9
    on_bed = np.abs(centres[:, 2] + WATER_DEPTH) <= half[2] + 1e-9
    assert np.all(on_wall | on_bed)
    assert on_wall.sum() >= reaching


def test_map_replan_passes_over_a_wall_that_los_avoid_stalls_at():
    outcomes = {}
    for name, make in (("los-avoid", lambda env: classical_3d(env, avoid=True)), ("map-replan", sonar_voxel_planner)):
        env = _wall_task()
        policy = make(env)
        time_step = env.reset()
        while not time_step.last():
            time_step = env.step(policy(time_step))
        outcomes[name] = (env.task.last_info.get("event"), env.physics.position())
    assert outcomes["map-replan"][0] == "goal"
    assert outcomes["los-avoid"][0] != "goal"
    assert outcomes["los-avoid"][1][0] < 60.0  # it never got past the wall


def _open_task(goal, time_limit: float = 120.0, executor=None, conditions="ideal"):
    """Open water 60 m deep, the vehicle at 30 m heading east (x), the goal at `goal`; `executor` and `conditions`
    the task's."""

    class OpenTask(Goal3D):
        def draw_arena(self, random):
            root = arena_root("open", [seabed(WATER_DEPTH)])
            return root, np.array([0.0, 0.0, -30.0]), 0.0, np.asarray(goal, dtype=float), np.zeros((0, 3))

    task = OpenTask(random=0, executor=executor, conditions=conditions)
    return control.Environment(Physics3D.load(None, conditions), task, time_limit=time_limit, control_timestep=0.5)


def _hard_tube(conditions="ideal"):
    """Hard validation tube SEEDS[0] in `conditions`."""
    return control.Environment(Physics3D.load(None, conditions), Tunnel3D(tier="hard", random=SEEDS[0],
                                                                          conditions=conditions),
                               time_limit=60.0, control_timestep=0.5)


def test_turning_circle_is_wider_than_the_goal():
    env = _open_task((100.0, 0.0, -30.0))
    env.reset()
    before = env.physics.position().copy(), env.physics.data.qvel.copy()
    radius = turning_radius(env.task, env.physics)
    assert 2.0 * GOAL_RADIUS < radius < 20.0  # why the capture is needed: a goal fits inside the circle
    assert np.array_equal(env.physics.position(), before[0])  # measured on a copy: the episode is untouched
    assert np.array_equal(env.physics.data.qvel, before[1])


def test_follower_captures_a_goal_inside_its_turning_circle():
    # 8 m abeam to port, inside the circle a hard left turn flies: pure pursuit circles it for ever
    for make in (true_voxel_planner, sonar_voxel_planner):
        env = _open_task((2.0, 8.0, -30.0))
        policy = make(env)
        time_step = env.reset()
        radius = turning_radius(env.task, env.physics)
        assert np.hypot(2.0, 8.0 - radius) < radius  # the goal lies inside the port turning circle
        while not time_step.last():
            time_step = env.step(policy(time_step))
        assert env.task.last_info.get("event") == "goal", make.__name__


def test_map_replan_and_oracle_fly_on_a_learned_depth_executor():
    """An executor with no S-plane gains of its own (the learned depth executor) flies under both: the search's
    pitch limit is the task's (`Planning3D.max_pitch`), not read off the executor's gains."""
    for make in (true_voxel_planner, sonar_voxel_planner):
        env = _open_task((60.0, 10.0, -26.0), executor="depth-executor")
        assert not hasattr(env.task.executor, "gains")
        policy = make(env)
        time_step = env.reset()
        while not time_step.last():
            time_step = env.step(policy(time_step))
        assert env.task.last_info.get("event") == "goal", make.__name__


def test_oracle_plans_over_a_wall_higher_than_its_search_window():
    # the wall's top is 14 m above start and goal: the way over climbs past the window's 12 m above them
    env = _wall_task(depth_below_top=14.0)
    env.reset()
    oracle = true_voxel_planner(env)
    oracle.start()
    oracle.plan(env.physics.position(), env.task.goal, GOAL_RADIUS)
    assert oracle.path is not None
    assert np.max(oracle.path[:, 2]) > -(30.0 - 14.0)  # over the wall's top
    assert np.linalg.norm(oracle.path[-1] - env.task.goal) <= GOAL_RADIUS


def test_oracle_trusts_its_exact_map_in_a_tube_without_movers(monkeypatch):
    """The protection domain guards a path against what the map does not know: the oracle's map of a tube without
    moving obstacles knows every wall and plug, so it flies its path without the domain there; `map-replan`
    always keeps it, and so does the oracle in open water or among movers."""
    from auv_mj.planners import map_planner3d

    consulted = []
    real = map_planner3d.protect_command
    monkeypatch.setattr(map_planner3d, "protect_command", lambda *a: consulted.append(1) or real(*a))

    def domain_calls(env, make, steps: int = 6) -> int:
        consulted.clear()
        policy, time_step = make(env), env.reset()
        for _ in range(steps):
            time_step = env.step(policy(time_step))
        return len(consulted)

    tube = _hard_tube()
    assert domain_calls(tube, true_voxel_planner) == 0
    assert domain_calls(tube, sonar_voxel_planner) == 6
    assert domain_calls(_open_task((60.0, 10.0, -26.0)), true_voxel_planner) == 6
    oracle = true_voxel_planner(tube)
    assert not oracle.guarded
    tube.task.movers = [(0, None)]  # what the rule reads: the tube's task has a moving obstacle
    assert oracle.guarded


def test_fan_is_cast_from_the_pose_of_its_ping():
    """A sonar that delivers each ping one ping late (ocean water's latency, without its noise): `map-replan` casts
    the ranges it sees now from the sonar's pose when they were taken, so each echo lies where the beam met the
    wall (independent: the fan cast by MuJoCo from that pose), not 0.75 m beyond it."""
    from auv_mj.sim.sonar import SONAR_RATE_HZ
    from auv_mj.tasks.auv3d import PLANNER_DT

    assert PLANNER_DT * SONAR_RATE_HZ == 1.0  # what `beams` counts on: a planner step is one ping
    conditions = {"base": "ideal", "sonar": {"latency": 1, "floor": 0.0, "proportional": 0.0, "dropout": 0.0}}
    env = _hard_tube(conditions)
    env.reset()
    mapper = SonarVoxelMap(env)
    mapper.start()
    physics, site = env.physics, env.physics.model.ptr.site("sonar").id
    for _ in range(3):
        env.step([0.0, 0.0, 0.0])
    then_origin = physics.data.site_xpos[site].copy()
    then_ranges = sonar_fan(physics)
    mapper.beams()  # the ping taken now reaches the planner one step later
    env.step([0.0, 0.0, 0.0])
    origins, directions, ranges = mapper.beams()
    moved = float(np.linalg.norm(physics.data.site_xpos[site] - then_origin))
    assert moved > 0.3  # a cast from the pose of now would differ by this much
    np.testing.assert_allclose(origins[:-1], np.repeat(then_origin[None], len(then_ranges), axis=0), atol=1e-12)
    np.testing.assert_allclose(ranges[:-1], then_ranges, atol=1e-9)
    echo = then_ranges < SONAR_RANGE
    assert echo.sum() >= 5
    model, data = physics.model.ptr, physics.data.ptr

    def wall_beyond(start: np.ndarray, direction: np.ndarray) -> float:
        """Distance [m] from `start` along `direction` to the first surface (the vehicle's own body skipped)."""
        return mujoco.mj_ray(model, data, start, direction, None, 1, model.site_bodyid[site], np.zeros(1, np.int32))

    # 5 cm short of each echo along its beam the wall is 5 cm on: the echo lies on the wall.
    for direction, distance in zip(directions[:-1][echo], then_ranges[echo], strict=True):
        assert wall_beyond(then_origin + (distance - 0.05) * direction, direction) == pytest.approx(0.05, abs=1e-6)


def _cross_track(monkeypatch, compensate: bool) -> float:
    """Mean distance [m] of the vehicle from its planned path over the second half of a 100 m leg across a
    0.4 m/s current (open water, no obstacle), `map-replan` with or without the crab angle."""
    from auv_mj.planners import map_planner3d

    if not compensate:
        monkeypatch.setattr(map_planner3d, "course_command", lambda command, crab: tuple(command))
    conditions = {"base": "ideal", "current": {"mean_speed": 0.4, "speed_sigma": 0.0, "mean_direction": math.pi / 2,
                                               "direction_sigma": 0.0}}
    env = _open_task((120.0, 0.0, -30.0), conditions=conditions)
    planner = SonarVoxelMap(env)
    time_step, gaps = env.reset(), []
    while not time_step.last() and env.physics.position()[0] < 100.0:
        time_step = env.step(planner.act(time_step))
        if env.physics.position()[0] > 50.0:
            gaps.append(map_planner3d._nearest(planner.path, env.physics.position())[0])
    return float(np.mean(gaps))


def test_line_of_sight_flies_its_course_in_a_cross_current(monkeypatch):
    """Heading at the look-ahead point, a vehicle crabbing beta settles LOOKAHEAD tan(beta) off its path (over a
    metre here); commanding the course instead keeps it on the path."""
    uncompensated = _cross_track(monkeypatch, compensate=False)
    monkeypatch.undo()
    compensated = _cross_track(monkeypatch, compensate=True)
    assert uncompensated > 1.0
    assert compensated < 0.3


def test_the_search_takes_unknown_water_between_near_echoes_for_wall_but_keeps_what_a_beam_crossed():
    from auv_mj.planners.map_planner3d import CLOSING

    env = _open_task((60.0, 0.0, -20.0))  # the map reaches the surface
    env.reset()
    mapper = SonarVoxelMap(env)
    mapper.start()
    space = mapper.grid
    assert mapper.surface.any()
    i, k = space.index(np.array([30.0, 0.0, -30.0]))[0][0][[0, 2]]
    gap = int(np.round(CLOSING[1] / space.cell[1]))  # echoes 2 * CLOSING apart in y: the closing fills between them
    j = space.index(np.array([30.0, 0.0, -30.0]))[0][0][1]
    near = [(i, j - gap, k), (i, j + gap, k)]
    far_j = j + 6 * gap  # a second pair, 2 * CLOSING + 2 voxels apart: the closing leaves it open
    far = [(i, far_j, k), (i, far_j + 2 * gap + 2, k)]
    for cell in near + far:
        mapper.occupied[cell] = True
        mapper.odds[cell] = 4
    everything = tuple(slice(0, n) for n in space.shape)
    closed = mapper.search_map(everything) & ~mapper.occupied
    assert closed[i, j - gap + 1:j + gap, k].all()  # the hole between the near echoes
    edge = (slice(i - 3, i + 4), slice(j, j + 2 * gap), slice(k - 3, k + 4))  # a crop whose edge cuts the hole
    np.testing.assert_array_equal(mapper.search_map(edge), mapper.search_map(everything)[edge])
    assert not closed[i, far_j + 1:far_j + 2 * gap + 2, k].any()
    # an echo 8 m below the closed surface water: the water between them stays open (a roof's top and the surface)
    shallow = space.index(np.array([10.0, 0.0, -(MIN_DEPTH + 8.0)]))[0][0]
    mapper.occupied[tuple(shallow)] = True
    above = mapper.search_map(everything)[shallow[0], shallow[1], shallow[2] + 1:]
    assert not above[space.centres()[2][shallow[2] + 1:] < -MIN_DEPTH].any() and above.any()
    mapper.odds[i, j, k] = -1  # a beam crossed the hole's middle: it stays open
    assert not mapper.search_map(everything)[i, j, k]
    assert mapper.search_map(everything)[i, j + 1, k]
    tube = SonarVoxelMap(_hard_tube())
    tube.env.reset()
    tube.start()
    tube.occupied[10, 10, 5] = tube.occupied[10, 12, 5] = True
    assert not tube.search_map(tuple(slice(0, n) for n in tube.grid.shape))[10, 11, 5]  # never in a tube


def test_map_replan_leaves_a_hard_cave_it_would_search_for_holes_without_the_closing(monkeypatch):
    """Validation seed 20006 of the hard goal3d tier: a cave 92 m wide and 41 m high across the route. With unknown
    water free (and its search in its window), `map-replan` flew inside it for 200 s, each hole between its walls'
    echoes a new way through, and timed out; closing those holes, it flies out and over the roof to the goal."""
    from auv_mj.planners.map_planner3d import VoxelFollower
    from auv_mj.tasks import auv3d, suite

    def outcome() -> str:
        env = suite.load(auv3d.DOMAIN, "goal3d", task_kwargs={"arena": "random", "tier": "hard", "random": 20_006,
                                                              "executor": "splane-ocean"})
        policy, time_step = sonar_voxel_planner(env), env.reset()
        while not time_step.last():
            time_step = env.step(policy(time_step))
        return env.task.last_info.get("event") or "timeout"

    assert outcome() == "goal"
    monkeypatch.setattr(SonarVoxelMap, "search_map", VoxelFollower.search_map)
    monkeypatch.setattr(SonarVoxelMap, "whole_map_fallback", False)
    assert outcome() == "timeout"


def _tube_episode(seed: int, conditions: str) -> tuple[str, list[str]]:
    """`map-replan` on hard tube `seed` (`splane-ocean`): how the episode ended and the geoms touching at its end."""
    from auv_mj.tasks import auv3d, suite

    env = suite.load(auv3d.DOMAIN, "tunnel3d", task_kwargs={"arena": "random", "tier": "hard", "random": seed,
                                                            "conditions": conditions, "executor": "splane-ocean"})
    policy, time_step = sonar_voxel_planner(env), env.reset()
    while not time_step.last():
        time_step = env.step(policy(time_step))
    model, data = env.physics.model.ptr, env.physics.data.ptr
    touched = [model.geom(int(g)).name for c in data.contact[:data.ncon] for g in (c.geom1, c.geom2)]
    return env.task.last_info.get("event") or "timeout", touched


def test_map_replan_follows_its_detour_round_a_plug_that_the_8_m_look_ahead_cut_into(monkeypatch):
    """Validation seed 20002 of the hard tubes (ideal water): `map-replan`'s path goes round the first plug's edge
    from 7.7 m before it. Aimed 8 m along the path (TUBE_LOOKAHEAD), line of sight looks past the detour's end,
    cuts its corner and flies into the plug; aimed MAP_TUBE_LOOKAHEAD (5 m) along it, it flies the detour, and
    the episode ends at the goal."""
    from auv_mj.planners.map_planner3d import MAP_TUBE_LOOKAHEAD, TUBE_LOOKAHEAD

    assert MAP_TUBE_LOOKAHEAD < TUBE_LOOKAHEAD
    assert _tube_episode(20_002, "ideal")[0] == "goal"
    monkeypatch.setattr(SonarVoxelMap, "tube_lookahead", TUBE_LOOKAHEAD)
    event, touched = _tube_episode(20_002, "ideal")
    assert event == "collision" and "plug_0" in touched


def test_map_replan_in_a_tube_leaves_the_echoes_its_path_was_planned_round_to_the_path(monkeypatch):
    """Validation seed 20076 of the hard tubes (ocean water): `map-replan`'s path passes the first plug 1-1.5 m
    from its edge. With the domain guarding against every echo, the plug's echoes bend the heading away from the
    plug, and past it the vehicle cannot turn back within its turning circle: it strikes the far wall. Guarding
    only against the echoes the path was not planned round, it flies its path to the goal."""
    from auv_mj.planners.map_planner3d import VoxelFollower

    assert _tube_episode(20_076, "ocean")[0] == "goal"
    monkeypatch.setattr(SonarVoxelMap, "unplanned_echoes", VoxelFollower.unplanned_echoes)
    event, touched = _tube_episode(20_076, "ocean")
    assert event == "collision" and any(name.startswith("wall_") for name in touched)


def test_a_tube_leaves_planned_echoes_out_of_the_domain_and_open_water_keeps_every_echo():
    """In open water (goal3d) every echo stays in the domain's reading. In a tube, a beam whose echo lies on a voxel
    the last search kept clear of reads the range limit, and one whose echo lies in open water a metre ahead keeps
    its range."""
    from auv_mj.tasks import auv3d, suite

    for task, tier in (("goal3d", "standard"), ("tunnel3d", "hard")):
        env = suite.load(auv3d.DOMAIN, task, task_kwargs={"arena": "random", "tier": tier, "random": 20_001})
        planner, time_step = sonar_voxel_planner(env), env.reset()
        for _ in range(6):
            time_step = env.step(planner(time_step))
        ranges = np.full(27, SONAR_RANGE)
        if task == "goal3d":
            assert planner.planned_map is None
            ranges[:] = 10.0
            np.testing.assert_array_equal(planner.unplanned_echoes(ranges), ranges)
            continue
        origin, fan = planner.poses[0]
        walls = planner.grid.centre(np.argwhere(planner.planned_map))
        wall = walls[np.argmin(np.abs(np.linalg.norm(walls - origin, axis=1) - 6.0))]
        ahead = fan[13] / np.linalg.norm(fan[13])  # the level row's middle beam: dead ahead
        fan = fan.copy()
        fan[0] = (wall - origin) / np.linalg.norm(wall - origin)
        planner.poses[0] = (origin, fan)
        ranges[0], ranges[13] = float(np.linalg.norm(wall - origin)), 1.0
        assert np.min(np.linalg.norm(walls - (origin + ahead), axis=1)) > 2.0  # open water a metre ahead
        seen = planner.unplanned_echoes(ranges)
        assert seen[0] == SONAR_RANGE and seen[13] == 1.0
