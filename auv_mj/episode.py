"""The one episode loop, its record, and the one definition of each episode metric.

`EpisodeRecorder.run` is the only loop that steps an environment for evaluation, videos, plots, the
reproduction report and the S-plane tuning. It sees the environment through dm_env alone (plus the
task's `last_info` dict, the suite's convention), so it lives in the simulator core.

Per recorded instant (the reset and every control step): time, pose (x, y, psi), body velocity (u, v, r),
sonar ranges, actuator forces, desired goal and moving-obstacle positions; per step: action, command
(V_cmd, psi_cmd), reward, event, success and every numeric or string entry of the task's `last_info`.
The arena (bounds, start, goal, global path, obstacle footprints) is recorded once. An `EpisodeRecord`
saves to and loads from a single .npz file.
"""

from __future__ import annotations

import zipfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import dm_env
import mujoco
import numpy as np

from auv_mj import inputs
from auv_mj.arenas import arena as arena_lib
from auv_mj.sim.vehicle_physics import VehiclePhysics

VEHICLE_BODY = "auv"
CIRCLE_SEGMENTS = 32
"""Vertices of the polygon standing for a round footprint (sphere, cylinder, capsule end)."""



# --- the planner protocol -------------------------------------------------------------------------


@runtime_checkable
class Planner(Protocol):
    """What the episode loop runs, every policy of auv-mj, classical or learned (nav2's planner interface in small):
    `reset()` at the start of each episode, then `act(time_step) -> action` at every control step."""

    def reset(self) -> None: ...

    def act(self, time_step: dm_env.TimeStep) -> np.ndarray: ...


class PlannerBase:
    """A Planner with nothing to reset unless a subclass says so; calling it is `act`."""

    def reset(self) -> None:
        """Forgets the last episode (nothing, unless the planner keeps state)."""

    def act(self, time_step: dm_env.TimeStep) -> np.ndarray:
        raise NotImplementedError

    def __call__(self, time_step: dm_env.TimeStep) -> np.ndarray:
        return self.act(time_step)


class FunctionPlanner(PlannerBase):
    """A Planner made of a function `act(time_step) -> action` and, where it keeps state, its `reset()`."""

    def __init__(self, act: Callable[[dm_env.TimeStep], Any], reset: Callable[[], None] | None = None):
        self._act, self._reset = act, reset

    def reset(self) -> None:
        if self._reset is not None:
            self._reset()

    def act(self, time_step: dm_env.TimeStep) -> np.ndarray:
        return self._act(time_step)


def as_planner(policy: Planner | Callable[[dm_env.TimeStep], Any]) -> Planner:
    """`policy` itself if it is a Planner; a plain function `policy(time_step) -> action` (a user's factory's, an
    outside library's) as a Planner with nothing to reset. TypeError naming it otherwise."""
    if isinstance(policy, Planner):
        return policy
    if callable(policy):
        return FunctionPlanner(policy)
    raise TypeError(f"a policy is a Planner (reset, act) or a function time_step -> action, got {policy!r:.80}")


Policy = Planner | Callable[[dm_env.TimeStep], Any]
"""What the episode loop takes: a Planner, or a plain function of the time step (`as_planner`)."""


# --- arena geometry -------------------------------------------------------------------------------


def geom_footprint(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> np.ndarray | None:
    """Outline (k, 2) in the world x-y plane of one geom seen from above; None for planes and unknowns."""
    kind = mujoco.mjtGeom(int(model.geom_type[geom]))  # an enum: `in` with numpy ints would not match
    size = model.geom_size[geom]
    centre = data.geom_xpos[geom][:2]
    rot = data.geom_xmat[geom].reshape(3, 3)[:2, :2]
    angles = np.linspace(0, 2 * np.pi, CIRCLE_SEGMENTS, endpoint=False)
    circle = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        local = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * size[:2]
    elif kind in (mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_CYLINDER):
        local = circle * size[0]
    elif kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        local = circle * size[:2]
    elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        # A vertical capsule is a circle from above; a horizontal one (axis along local z) a stadium.
        axis = data.geom_xmat[geom].reshape(3, 3)[:2, 2] * size[1]
        if np.hypot(*axis) < 1e-9:
            return centre + circle * size[0]
        half = circle[: CIRCLE_SEGMENTS // 2 + 1]
        direction = axis / np.hypot(*axis)
        normal = np.array([-direction[1], direction[0]])
        basis = np.stack([normal, -direction])  # half circle around the +axis end, then the -axis end
        end = half @ basis * size[0]
        return np.concatenate([centre + axis - end, centre - axis + end])
    elif kind == mujoco.mjtGeom.mjGEOM_MESH:
        # MuJoCo collides a mesh by its convex hull: the footprint is the hull of its vertices seen from above
        # (a concave `polygon` of `auv-mj arena` is several such meshes, one per triangle).
        import shapely

        mesh = int(model.geom_dataid[geom])
        start = int(model.mesh_vertadr[mesh])
        vertices = model.mesh_vert[start:start + int(model.mesh_vertnum[mesh])].astype(float)
        world = data.geom_xpos[geom][:2] + vertices @ data.geom_xmat[geom].reshape(3, 3)[:2, :].T
        hull = shapely.convex_hull(shapely.multipoints(world))
        if hull.geom_type != "Polygon":
            return None
        return np.asarray(hull.exterior.coords)[:-1]
    else:
        return None
    return centre + local @ rot.T


@dataclass(frozen=True)
class ArenaGeometry:
    """What the trajectory figure draws of an arena (world frame, metres)."""

    bounds: np.ndarray
    """(xmin, ymin, xmax, ymax) of the map, NaN when the arena has none."""
    start: np.ndarray
    goal: np.ndarray
    """Start and goal sites (NaN when absent)."""
    path: np.ndarray
    """(P, 2) global path, possibly empty."""
    polygons: tuple[np.ndarray, ...]
    """Footprints of walls and obstacles at t = 0."""
    kinds: np.ndarray
    """Per polygon: "wall" or "obstacle"."""
    owners: np.ndarray
    """Per polygon: index into `mover_names` of the moving obstacle it belongs to, -1 when static."""
    mover_names: tuple[str, ...]
    mover_paths: np.ndarray
    """(M, 2, 2): from and to of each mover's ping-pong path."""
    goals: np.ndarray
    """(K, 2) the task's goal sequence (sub-goals, then the goal); empty when the task does not say."""
    goal_radius: float


def arena_geometry(physics: VehiclePhysics, task=None) -> ArenaGeometry:
    """The arena of `physics` (composed per `auv_mj.arenas.arena`) with the task's goals, path and movers if any.

    Call it after the environment's reset: tasks draw their route (goals, path, movers) there.
    """
    info = arena_lib.arena_info(physics)
    # Planning tasks export the episode's layout (`episode.route`, an auv_mj.tasks.routes.Route); the arena's own
    # convention (path_* sites, mover_* numerics) is the fallback.
    route = getattr(getattr(task, "episode", None), "route", None)
    movers = tuple(getattr(route, "movers", ()) or ()) or info.movers
    model, data = physics.model.ptr, physics.data.ptr
    vehicle = model.body(VEHICLE_BODY).id if VEHICLE_BODY in _body_names(model) else -1
    mover_bodies = {model.body(m.body).id: i for i, m in enumerate(movers)}
    polygons, kinds, owners = [], [], []
    for g in range(model.ngeom):
        body = model.geom_bodyid[g]
        if vehicle >= 0 and _descends_from(model, body, vehicle):
            continue
        if abs(data.geom_xpos[g][2]) > model.geom_rbound[g] > 0:
            continue  # parked out of the vehicle's plane (unused obstacles of a random arena)
        outline = geom_footprint(model, data, g)
        if outline is None:
            continue
        polygons.append(outline)
        kinds.append("wall" if model.geom(g).name.startswith("wall") else "obstacle")
        owners.append(mover_bodies.get(_root_body(model, body), -1))
    nan2 = np.full(2, np.nan)
    path = info.path
    task_path = getattr(route, "path", None)
    if len(path) == 0 and task_path is not None and np.ndim(task_path) == 2:
        path = np.asarray(task_path, dtype=float)[:, :2]
    goals = getattr(task, "goals", None)
    goals = np.asarray(goals, dtype=float).reshape(-1, 2) if goals is not None else np.zeros((0, 2))
    return ArenaGeometry(
        bounds=np.asarray(info.bounds, dtype=float) if info.bounds is not None else np.full(4, np.nan),
        start=info.start if info.start is not None else nan2,
        goal=info.goal if info.goal is not None else nan2,
        path=np.asarray(path, dtype=float).reshape(-1, 2),
        polygons=tuple(polygons), kinds=np.array(kinds, dtype=str), owners=np.array(owners, dtype=int),
        mover_names=tuple(m.body for m in movers),
        mover_paths=np.array([[m.start, m.end] for m in movers], dtype=float).reshape(-1, 2, 2),
        goals=goals, goal_radius=float(getattr(task, "goal_radius", np.nan)))


def _body_names(model) -> set[str]:
    return {model.body(i).name for i in range(model.nbody)}


def _descends_from(model, body: int, ancestor: int) -> bool:
    while body > 0:
        if body == ancestor:
            return True
        body = model.body_parentid[body]
    return body == ancestor


def _root_body(model, body: int) -> int:
    while model.body_parentid[body] > 0:
        body = model.body_parentid[body]
    return body


def mover_positions(physics: VehiclePhysics, names: tuple[str, ...]) -> np.ndarray:
    """(M, 2) current positions of the named mocap bodies."""
    model, data = physics.model.ptr, physics.data.ptr
    out = np.empty((len(names), 2))
    for i, name in enumerate(names):
        out[i] = data.mocap_pos[model.body_mocapid[model.body(name).id]][:2]
    return out


# --- the record -------------------------------------------------------------------------------------


@dataclass
class EpisodeRecord:
    """One episode as arrays: N steps, N + 1 recorded instants (index 0 is the reset)."""

    task: str
    policy: str
    seed: int | None
    control_dt: float
    time: np.ndarray
    """(N+1,) simulation time [s]."""
    pose: np.ndarray
    """(N+1, 3) x [m], y [m], psi [rad]."""
    velocity: np.ndarray
    """(N+1, 3) u [m/s], v [m/s], r [rad/s] in the body frame."""
    sonar: np.ndarray
    """(N+1, 9) ranges S1..S9 [m]."""
    control: np.ndarray
    """(N+1, nu) actuator forces (tau_u [N], tau_r [N m]) in force after each step."""
    desired_goal: np.ndarray
    """(N+1, 2) the task's desired goal, NaN when the task has none."""
    movers: np.ndarray
    """(N+1, M, 2) positions of the moving obstacles."""
    action: np.ndarray
    """(N, A) the policy's actions."""
    command: np.ndarray
    """(N, 2) V_cmd [m/s], psi_cmd [rad] the executor was given during each step (NaN if unknown)."""
    reward: np.ndarray
    """(N,) rewards."""
    event: np.ndarray
    """(N,) the task's event of each step ("" for none): goal, subgoal, collision, ..."""
    success: np.ndarray
    """(N,) the task's success flag after each step."""
    info: dict[str, np.ndarray]
    """(N,) per-step numeric and string entries of the task's last_info (speed_error, phase, ...)."""
    arena: ArenaGeometry
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    """Whatever else a caller wants saved with the record."""
    cut: bool = False
    """Whether the caller stopped the episode (`max_steps`, `--max-steps`) before the task ended it: its outcome
    reads "timeout", as at the time limit, and the commands label it as cut (`outcome_label`)."""

    @property
    def steps(self) -> int:
        """Number of control steps."""
        return len(self.reward)

    @property
    def episode_return(self) -> float:
        """Sum of rewards."""
        return float(np.sum(self.reward))

    @property
    def succeeded(self) -> bool:
        """Whether the task reported success at any step."""
        return bool(np.any(self.success))

    @property
    def speed(self) -> np.ndarray:
        """(N+1,) speed over ground [m/s]."""
        return np.hypot(self.velocity[:, 0], self.velocity[:, 1])

    def subgoals(self) -> np.ndarray:
        """(K, 2) the distinct desired goals in the order the task gave them."""
        goals = self.desired_goal[np.all(np.isfinite(self.desired_goal), axis=1)]
        if len(goals) == 0:
            return goals.reshape(0, 2)
        keep = np.concatenate([[True], np.any(np.abs(np.diff(goals, axis=0)) > 1e-9, axis=1)])
        return goals[keep]

    def save(self, path: str | Path) -> Path:
        """Writes the record to one .npz file (loadable without the task) and returns its path."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays: dict[str, np.ndarray] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in ("info", "extras"):
                arrays.update({f"{f.name}/{k}": np.asarray(v) for k, v in value.items()})
            elif f.name == "arena":
                for g in fields(ArenaGeometry):
                    item = getattr(value, g.name)
                    if g.name == "polygons":
                        arrays["arena/polygon_sizes"] = np.array([len(p) for p in item], dtype=int)
                        arrays["arena/polygon_points"] = (np.concatenate(item) if item else np.zeros((0, 2)))
                    else:
                        arrays[f"arena/{g.name}"] = np.asarray(item)
            else:
                arrays[f.name] = np.asarray("" if value is None else value)
        with open(path, "wb") as f:
            np.savez_compressed(f, **arrays)
        return path

    @classmethod
    def load(cls, path: str | Path) -> EpisodeRecord:
        """Reads a record written by `save`; ValueError naming the file if it is not one."""
        try:
            return cls._read(path)
        except (OSError, ValueError, KeyError, TypeError, IndexError, AttributeError, EOFError,
                zipfile.BadZipFile) as e:
            reason = " ".join(f"{type(e).__name__}: {e}".split())[:200]
            raise ValueError(f"{inputs.source_name(path)}: not an episode record of `auv-mj render "
                             f"--save-episode` ({reason})") from None

    @classmethod
    def _read(cls, path: str | Path) -> EpisodeRecord:
        with np.load(path, allow_pickle=False) as npz:
            data = {k: npz[k] for k in npz.files}
        sizes = data.pop("arena/polygon_sizes")
        points = data.pop("arena/polygon_points")
        polygons = tuple(np.split(points, np.cumsum(sizes)[:-1])) if len(sizes) else ()
        arena = {g.name: data.pop(f"arena/{g.name}") for g in fields(ArenaGeometry) if g.name != "polygons"}
        arena["mover_names"] = tuple(str(n) for n in arena["mover_names"])
        arena["goal_radius"] = float(arena["goal_radius"])
        groups: dict[str, dict[str, np.ndarray]] = {"info": {}, "extras": {}}
        for key in [k for k in data if "/" in k]:
            group, name = key.split("/", 1)
            groups[group][name] = data.pop(key)
        seed = str(data.pop("seed"))
        cut = bool(data.pop("cut", False))  # records saved before it had the flag: not cut
        return cls(task=str(data.pop("task")), policy=str(data.pop("policy")),
                   seed=int(seed) if seed not in ("", "None") else None,
                   control_dt=float(data.pop("control_dt")), cut=cut, **data, **groups,
                   arena=ArenaGeometry(polygons=polygons, **arena))


# --- recording ----------------------------------------------------------------------------------------


@dataclass
class Snapshot:
    """The recorded state at one instant, and the step that led to it (None for the reset)."""

    time: float
    pose: np.ndarray
    velocity: np.ndarray
    sonar: np.ndarray
    control: np.ndarray
    desired_goal: np.ndarray
    movers: np.ndarray
    step: int = 0
    action: np.ndarray | None = None
    command: np.ndarray | None = None
    reward: float = 0.0
    episode_return: float = 0.0
    event: str = ""
    success: bool = False
    info: dict = field(default_factory=dict)


class EpisodeRecorder:
    """Runs `policy(time_step) -> action` on a dm_control environment and keeps a `Snapshot` per instant."""

    def __init__(self, env, task: str = "", policy: str = "", seed: int | None = None):
        self.env = env
        self.names = (task, policy, seed)
        self.arena: ArenaGeometry | None = None
        """The arena of the current episode (set by `run` after the reset)."""
        self.snapshots: list[Snapshot] = []
        self.cut = False
        """Whether `run` stopped at `max_steps` before the episode's last step."""

    def _snapshot(self, time_step, action=None, previous: Snapshot | None = None) -> Snapshot:
        physics = self.env.physics
        goal = time_step.observation.get("desired_goal") if hasattr(time_step.observation, "get") else None
        goal = np.asarray(goal, dtype=float)[:2] if goal is not None else np.full(2, np.nan)
        snap = Snapshot(time=float(physics.time()), pose=physics.pose(), velocity=physics.body_velocity(),
                        sonar=physics.sonar(), control=physics.data.ctrl.copy(), desired_goal=goal,
                        movers=mover_positions(physics, self.arena.mover_names))
        if previous is None:
            return snap
        info = dict(getattr(self.env.task, "last_info", {}) or {})
        snap.step = previous.step + 1
        snap.action = np.asarray(action, dtype=float).copy()
        snap.reward = float(time_step.reward or 0.0)
        snap.episode_return = previous.episode_return + snap.reward
        snap.event = str(info.get("event") or "")
        snap.success = bool(info.get("success", False))
        snap.command = self._command(info)
        snap.info = info
        return snap

    @staticmethod
    def _command(info: dict) -> np.ndarray:
        """The (V_cmd, psi_cmd) the task reports it gave the executor, NaN when it reports none."""
        if "command" in info and np.size(info["command"]) == 2:
            return np.asarray(info["command"], dtype=float).ravel()
        return np.full(2, np.nan)

    def start(self, time_step) -> Snapshot:
        """Starts a new record at `time_step`, the environment's reset (its arena read again). `run` calls it; so
        does whoever steps the environment outside `run` (the Gymnasium face's `render()`), then `add` per step."""
        self.arena = arena_geometry(self.env.physics, self.env.task)
        self.snapshots = [self._snapshot(time_step)]
        self.cut = False
        return self.snapshots[-1]

    def add(self, time_step, action) -> Snapshot:
        """Records `time_step`, the step that `action` led to."""
        self.snapshots.append(self._snapshot(time_step, action, self.snapshots[-1]))
        return self.snapshots[-1]

    def run(self, policy: Policy, max_steps: int | None = None) -> Iterator[Snapshot]:
        """Resets, then steps until the episode ends or `max_steps`; yields each new Snapshot."""
        time_step = self.env.reset()
        planner = as_planner(policy)
        planner.reset()
        yield self.start(time_step)
        while not time_step.last() and (max_steps is None or len(self.snapshots) <= max_steps):
            action = planner.act(time_step)
            time_step = self.env.step(action)
            yield self.add(time_step, action)
        self.cut = not time_step.last()

    def record(self) -> EpisodeRecord:
        """The snapshots so far as an EpisodeRecord."""
        snaps, steps = self.snapshots, self.snapshots[1:]
        action_dim = int(np.prod(self.env.action_spec().shape))
        info_keys = sorted({k for s in steps for k, v in s.info.items() if _recordable(v)})
        info = {key: _info_array([s.info.get(key) for s in steps]) for key in info_keys}
        task, policy, seed = self.names
        return EpisodeRecord(
            task=task, policy=policy, seed=seed, control_dt=float(self.env.control_timestep()),
            time=np.array([s.time for s in snaps]), pose=np.array([s.pose for s in snaps]),
            velocity=np.array([s.velocity for s in snaps]), sonar=np.array([s.sonar for s in snaps]),
            control=np.array([s.control for s in snaps]),
            desired_goal=np.array([s.desired_goal for s in snaps]),
            movers=np.array([s.movers for s in snaps]).reshape(len(snaps), len(self.arena.mover_names), 2),
            action=np.array([s.action for s in steps]).reshape(len(steps), action_dim),
            command=np.array([s.command for s in steps]).reshape(len(steps), 2),
            reward=np.array([s.reward for s in steps]), event=np.array([s.event for s in steps], dtype=str),
            success=np.array([s.success for s in steps], dtype=bool), info=info, arena=self.arena, cut=self.cut)


def _recordable(value) -> bool:
    return isinstance(value, str | bool | int | float | np.bool_ | np.integer | np.floating) or (
        isinstance(value, np.ndarray) and value.shape == ())


def _info_array(values: list) -> np.ndarray:
    """Per-step values of one last_info key: strings (None -> "") or floats (None -> NaN)."""
    if any(isinstance(v, str) for v in values):
        return np.array(["" if v is None else str(v) for v in values], dtype=str)
    return np.array([np.nan if v is None or not _recordable(v) else float(v) for v in values])


def record_episode(env, policy: Policy, max_steps: int | None = None, task: str = "", policy_name: str = "",
                   seed: int | None = None) -> EpisodeRecord:
    """Runs one episode of `policy(time_step) -> action` on `env` and returns its record."""
    recorder = EpisodeRecorder(env, task, policy_name, seed)
    for _ in recorder.run(policy, max_steps):
        pass
    return recorder.record()



class StepObserver(Protocol):
    """What a video's frames call beside the episode loop (their `track`): `add(env)` after the reset and after each
    control step, to gather what the frames do not keep (`Track3D`)."""

    def add(self, env) -> None: ...


@dataclass
class Track3D:
    """The 3-D track of a 6-DOF episode, gathered beside its EpisodeRecord (whose pose is the planar read-out):
    world positions and attitudes. `add(env)` after the reset and each control step; a video's frames call it
    (`auv_mj.render.episode_video3d.iter_frames_3d`'s `track`), the depth and track figures draw it
    (`auv_mj.figures.trajectory3d`)."""

    time: list = field(default_factory=list)
    position: list = field(default_factory=list)
    """[m], world, z up."""
    attitude: list = field(default_factory=list)
    """(roll, pitch, yaw) [rad]."""
    depth_command: list = field(default_factory=list)
    """The task's depth command [m] where it has one (depth_heading), else NaN."""

    def add(self, env) -> None:
        """The environment's state now."""
        physics = env.physics
        self.time.append(physics.time())
        self.position.append(physics.position())
        self.attitude.append(physics.attitude())
        self.depth_command.append(float((getattr(env.task, "last_info", {}) or {}).get("depth_command", np.nan)))

    def arrays(self) -> dict[str, np.ndarray]:
        """Each field as one float array (time (T,), position (T, 3), ...)."""
        return {k: np.asarray(v, dtype=float) for k, v in vars(self).items()}

# --- metrics: the one definition of each --------------------------------------------------------------

OUTCOMES = ("goal", "collision", "left_map", "timeout")
"""How an episode ends, exactly one of these: the task's terminal event, or the time (step) limit."""
TIME_DECIMALS = 6
"""Decimals [s] of the times the metrics report (duration, time to goal): the simulation clock sums physics steps,
whose rounding leaves 100.50000000001451 for 100.5; a microsecond is far below any step."""
TRACKING_KEYS = ("speed_error", "heading_error", "cross_track_error", "depth_error")
"""Per-step tracking errors a task may report in last_info: e_V [m/s], e_psi [rad], cross-track [m], depth [m]
(the 6-DOF depth_heading: mae_depth)."""


def outcome(events: np.ndarray | list[str]) -> str:
    """The episode's outcome from its per-step events: the last terminal event, else "timeout".

    A planner that stalls until the time limit (or a run cut by max_steps) is a "timeout"; `outcome_label` tells
    the two apart for the reader.
    """
    for event in reversed([str(e) for e in events]):
        if event in OUTCOMES:
            return event
    return "timeout"


CUT = "cut"
"""How the commands print the outcome of an episode stopped by max_steps (`--max-steps`) before the task ended it:
its recorded outcome stays "timeout" (what the benchmark and the recorded outcomes count), but the reader is told
that the time limit was not reached."""


def outcome_label(outcome_name: str, cut: bool, steps: int | None = None) -> str:
    """The outcome as the commands print it: "cut (--max-steps 50)" for an episode the caller stopped, else the
    outcome itself."""
    if not cut:
        return outcome_name
    return f"{CUT} (--max-steps {steps})" if steps is not None else CUT


def phase_mae(speed_error: np.ndarray, heading_error: np.ndarray, phases: np.ndarray,
              tracked: np.ndarray | None = None) -> dict[str, tuple[float, float]]:
    """Table 9's MAE per disturbance phase: {phase: (MAE speed [m/s], MAE heading [rad])}.

    Only steps with `tracked` true count (the task's settling time is left out); phases in order of
    first appearance.
    """
    phases = np.asarray(phases).astype(str)
    keep = np.ones(len(phases), bool) if tracked is None else np.asarray(tracked, bool)
    result = {}
    for phase in dict.fromkeys(phases[keep].tolist()):
        mask = keep & (phases == phase)
        result[phase] = (float(np.mean(np.abs(np.asarray(speed_error)[mask]))),
                         float(np.mean(np.abs(np.asarray(heading_error)[mask]))))
    return result


def _tracked(record: EpisodeRecord) -> np.ndarray:
    """Steps whose tracking errors count: those the task marks `tracked` (all steps when it does not)."""
    if "tracked" in record.info:
        return np.asarray(record.info["tracked"], dtype=float) > 0.5
    return np.ones(record.steps, bool)


def episode_metrics(record: EpisodeRecord) -> dict:
    """The metrics of one episode, as `auv-mj eval` reports them (units in docs/evaluation.md).

    None stands for a figure that is undefined for this episode: time to goal without success, a
    clearance on a task that measures none, a tracking error where the task reports none or before
    the vehicle reached its path, and success and time to goal on a task that reports no success (a tracking
    task, speed_heading or depth_heading, whose episode ends by its schedule, not at a goal).
    """
    info = record.info
    steps = record.steps
    clearance = np.asarray(info.get("min_clearance", []), dtype=float)
    clearance = clearance[np.isfinite(clearance)]
    success_steps = np.flatnonzero(record.success)
    has_goal = "success" in info
    result = {
        "return": record.episode_return, "steps": steps, "success": record.succeeded if has_goal else None,
        "outcome": outcome(record.event),
        "collision": bool(np.any(np.asarray(info.get("collision", np.zeros(steps)), dtype=float) > 0.5)),
        "safety_violation": bool(np.any(np.asarray(info.get("safety_violation", np.zeros(steps)),
                                                   dtype=float) > 0.5)),
        "min_clearance": float(clearance.min()) if clearance.size else None,
        "path_length": float(np.sum(np.hypot(*np.diff(record.pose[:, :2], axis=0).T))),
        "time_to_goal": (round(float(record.time[success_steps[0] + 1]), TIME_DECIMALS)
                         if has_goal and success_steps.size else None),
        "duration": round(float(record.time[-1] - record.time[0]), TIME_DECIMALS),
        "cut": record.cut,
    }
    tracked = _tracked(record)
    for key in TRACKING_KEYS:
        if key not in info:
            continue
        name = key.replace("_error", "")
        values = np.abs(np.asarray(info[key], dtype=float))[tracked]
        result[f"mae_{name}"] = float(values.mean()) if values.size else None
        result[f"max_{name}"] = float(values.max()) if values.size else None
    if "phase" in info and "speed_error" in info and "heading_error" in info:
        for phase, (speed, heading) in phase_mae(info["speed_error"], info["heading_error"], info["phase"],
                                                 tracked).items():
            result[f"mae_speed_{phase}"] = speed
            result[f"mae_heading_{phase}"] = heading
    return result
