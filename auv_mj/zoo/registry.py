"""The policy registry: every name `--policy` takes, as one table of `PolicySpec`s (dm_control's `@SUITE.add`,
MuJoCo Playground's registry).

The one place where tasks and agents meet (the app layer). A spec holds what a name means: how its policy is built,
its shipped checkpoint, the executor it runs on, its protection domain (Sec. 3.2.2), the suite domains (planar,
6-DOF) and kind of task it runs on and a one-line description. Everything else derives from `POLICIES`: the names,
the `--policy` help of every command, the policy table of docs/policies.md (`auv-mj policies --markdown`),
`resolve_tasks` (which tasks of 'all', a tag or a domain a policy runs), `check_runs_on` (the one-line refusal of a
task it cannot run), `make_env` and `make_policy`.

Adding a policy is one entry: `register("my-planner", PolicySpec("what it is", build=...))`, in this file or in a
module imported by it.

Besides the names:
- a checkpoint path runs that trained policy (by its kind: `auv_mj.agents.offpolicy.Policy` with the protection domain
  it trained with, or `auv_mj.agents.ppo.PPOPolicy` with its memory);
- `NAME=PATH` runs the checkpoint PATH in place of the shipped one, for a spec with `accepts_path` (`planner`,
  `planner-raw`, `two-layer`), to compare or choose candidates on validation seeds;
- `RESOLVERS` turn other forms of name into specs (e.g. a module's factory, `MODULE:FACTORY`).

On the planning tasks the executor under any planner without an executor of its own is chosen in the task
options, `--task-kwargs '{"executor": NAME}'`, NAME one of EXECUTORS["auv"] (or a speed_heading checkpoint path), e.g.
the general planner on the learned ocean executor:
`--policy planner-general --task-kwargs '{"executor": "ocean-executor"}'`. On the 6-DOF planning tasks (goal3d,
tunnel3d) NAME is one of EXECUTORS["auv3d"] (or a depth_heading checkpoint path), e.g. `--policy los-avoid --task goal3d
--task-kwargs '{"executor": "depth-executor"}'`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import torch

from auv_mj.agents.baselines import uniform_random
from auv_mj.agents.checkpoint import read_checkpoint
from auv_mj.control.depth_heading import OCEAN_DEPTH_GAINS
from auv_mj.episode import Planner, as_planner
from auv_mj.inputs import did_you_mean, shown, unknown_name
from auv_mj.planners.avoidance import map_fence, protection_field, with_repulsion
from auv_mj.planners.bug import bug_planner
from auv_mj.planners.guidance import classical, is_goal_task, line_of_sight
from auv_mj.planners.los3d import classical_3d, los_policy
from auv_mj.planners.map_planner import fast_line_of_sight, sonar_map_planner, true_map_planner
from auv_mj.planners.map_planner3d import sonar_voxel_planner, true_voxel_planner
from auv_mj.planners.teacher import geodesic_teacher
from auv_mj.planners.teacher3d import geodesic_teacher_3d
from auv_mj.tasks import domains as suite_domains
from auv_mj.tasks import suite
from auv_mj.tasks.auv3d import DOMAIN as DOMAIN_3D
from auv_mj.tasks.auv3d import DepthHeading, splane_policy
from auv_mj.tasks.depth_executor import executor_options as depth_executor_options
from auv_mj.tasks.speed_heading import executor_options, executor_policy
from auv_mj.zoo.checkpoints import _checkpoint_dir, checkpoint_path, shipped_checkpoint  # noqa: F401  (re-exported)
from auv_mj.zoo.executors import (  # noqa: F401  (re-exported: the zoo's face, and the entry points' targets)
    EXECUTORS,
    LearnedExecutor,
    depth_executor,
    learned_depth_executor,
    learned_executor,
    named_executor,
    ocean_executor,
    paper_executor,
)
from auv_mj.zoo.learned import (  # noqa: F401  (re-exported: the zoo's face)
    checkpoint_kind,
    checkpoint_policy,
    from_checkpoint,
    loaded_policy,
    recurrent_policy,
)
from auv_mj.zoo.spec import (
    DOMAINS,
    POLICIES,
    RESOLVERS,
    ROLES,
    RUNS_ON,  # noqa: F401  (re-exported)
    Deployment,
    PolicySpec,
    by_domain,
    register,
)


def _splane_ocean(deployment: Deployment) -> Planner:
    """Line of sight on a planar planning task (its executor set by `make_env`); the re-tuned S-plane on
    speed_heading (`OCEAN_GAINS`)."""
    env = deployment.env
    return line_of_sight(env) if is_goal_task(env) else executor_policy(env, named_executor("splane-ocean"))


def _splane_ocean_3d(deployment: Deployment) -> Planner:
    """3-D line of sight on a 6-DOF planning task; the re-tuned depth-heading S-plane on depth_heading
    (`OCEAN_DEPTH_GAINS`)."""
    env = deployment.env
    return splane_policy(env, OCEAN_DEPTH_GAINS) if isinstance(env.task, DepthHeading) else los_policy(env)


def _learned(description: str, checkpoint: str, **kwargs: Any) -> PolicySpec:
    return PolicySpec(description, from_checkpoint, family="learned", checkpoint=checkpoint, **kwargs)


BOTH = tuple(DOMAINS)
"""`PolicySpec.domains` of a policy that runs on the planar and the 6-DOF vehicle's tasks."""

PAPER_PLANNER = {"checkpoint": "planner.pt", "checkpoint_on": {"tunnel": "planner_tunnel.pt"}, "tasks": "planning",
                 "accepts_path": True}
"""The paper's HER-DDPG planner: one checkpoint per environment (`planner_tunnel.pt` on the tunnel task)."""

register("planner", _learned("the paper's HER-DDPG planner with its protection domain (Sec. 3.2.2), on the task's "
                             "executor; trained on the paper's scenarios, it fails on tunnels of your own",
                             protection=True, **PAPER_PLANNER, role="paper"))
register("planner-raw", _learned("the paper's planner without the protection domain", protection=False,
                                 **PAPER_PLANNER, role="paper"))
register("two-layer", _learned("the paper's planner (protection domain) on the learned DDPG executor (Sec. 4.3); "
                               "it fails on tunnels of your own",
                               protection=True, executor="executor", **PAPER_PLANNER, role="paper"))
GENERAL_DEPLOYMENT = {"tasks": "planning", "protection": "speed-aware"}
"""How the general planners are deployed: on every planning task, inside the speed-aware domain with the geofence."""
GENERAL_SPEED = "fixed"
"""The speed `planner-general` runs at (`auv_mj.planners.guidance.SPEEDS`): the classical planners' (2 m/s, slowing
near a
small final goal), its network steering only. Chosen on validation seeds over the speed it learned ("absolute",
`planner-general-speed`): paired time efficiency +0.020 [+0.008, +0.033] over 230 validation episodes
(docs/runs/planner-top/selection.md)."""


def _general(speed: str, zeroed: bool = False) -> Callable[[Deployment], Planner]:
    """The build of planner_general.pt at `speed`, its output zeroed if `zeroed`."""
    return lambda d: checkpoint_policy(d.checkpoint, d.env, "speed-aware", zeroed=zeroed, speed=speed)


register("planner-general", PolicySpec(
    "the general planner: a residual planner steering along the sonar map's planned path (the map is its memory) at "
    "the classical planners' speed, trained on the hard tier, inside the speed-aware domain and geofence",
    _general(GENERAL_SPEED), family="learned", checkpoint="planner_general.pt", **GENERAL_DEPLOYMENT))
register("two-layer-general", PolicySpec("planner-general on the learned ocean executor", _general(GENERAL_SPEED),
                                         family="learned", checkpoint="planner_general.pt",
                                         executor="ocean-executor", **GENERAL_DEPLOYMENT))
register("planner-general-zeroed", PolicySpec(
    "planner-general with its learned output zeroed, the rest as deployed: its classical skeleton, which is "
    "map-replan exactly (the ablation)", _general(GENERAL_SPEED, zeroed=True), family="reference",
    checkpoint="planner_general.pt", **GENERAL_DEPLOYMENT, role="reference"))
register("planner-general-speed", PolicySpec(
    "planner-general at the speed it learned (its network's speed action; the deployment of the previous release)",
    _general("absolute"), family="learned", checkpoint="planner_general.pt", **GENERAL_DEPLOYMENT, role="comparison"))
register("planner-route", _learned(
    "the first general planner: a residual planner over line of sight along the route "
    "(no memory), trained on the standard arenas, speed-aware domain and geofence", "planner_route.pt",
    **GENERAL_DEPLOYMENT, role="comparison"))
register("two-layer-route", _learned("planner-route on the learned ocean executor", "planner_route.pt",
                                     executor="ocean-executor", **GENERAL_DEPLOYMENT, role="comparison"))
register("planner-e2e", _learned("the first planner trained on the distribution of arenas, end to end (kept for "
                                 "comparison)", "planner_e2e.pt", tasks="planning", protection=True, role="comparison"))
register("two-layer-e2e", _learned("planner-e2e on the paper's learned executor", "planner_e2e.pt",
                                   tasks="planning", protection=True, executor="executor", role="comparison"))
register("executor", _learned("the paper's DDPG execution layer (speed_heading)", "executor.pt", tasks="executor",
                              role="paper"))
register("ocean-executor", _learned("TD3 scheduling the S-plane's gains every step, trained in ocean water "
                                    "(speed_heading)", "executor_ocean.pt", tasks="executor"))
register("depth-executor", _learned("TD3 scheduling the depth-heading S-plane's gains every step, trained in ocean "
                                    "water (depth_heading, the 6-DOF vehicle); kept for comparison: on held-out "
                                    "schedules it tracks less closely than splane-ocean", "depth_executor.pt",
                                    tasks="executor", domains=("auv3d",), role="comparison"))
register("two-layer-3d", PolicySpec("the two-layer system in 3-D: 3-D line of sight with the protection domain on the "
                                    "3-D fan (los-avoid) on the learned depth executor (goal3d, tunnel3d)",
                                    lambda d: classical_3d(d.env, avoid=True), tasks="planning",
                                    executor="depth-executor", protection="paper", domains=("auv3d",),
                                    role="comparison"))
register("los-executor", PolicySpec("line of sight on the learned DDPG executor: the execution layer alone",
                                    lambda d: line_of_sight(d.env), tasks="planning", executor="executor",
                                    role="paper"))
register("splane", PolicySpec("the classical baseline: line of sight + the S-plane (Eq. 32), or the S-plane alone "
                              "on speed_heading (auv3d: the depth-heading S-plane, with 3-D line of sight on "
                              "goal3d/tunnel3d)",
                              by_domain(auv=lambda d: classical(d.env), auv3d=lambda d: classical_3d(d.env)),
                              domains=BOTH))
register("splane-ocean", PolicySpec("the S-plane baseline with its gains re-tuned in ocean water "
                                    "(`auv_mj.control.splane.OCEAN_GAINS`; auv3d: the depth-heading S-plane's, "
                                    "`OCEAN_DEPTH_GAINS`)", by_domain(auv=_splane_ocean, auv3d=_splane_ocean_3d),
                                    default_executor="splane-ocean", role="reference", domains=BOTH))
register("los-avoid", PolicySpec("line of sight along the route with the paper's protection domain: the classical "
                                 "local planner (auv3d: 3-D line of sight, the domain on the 3-D fan)",
                                 by_domain(auv=lambda d: line_of_sight(d.env),
                                           auv3d=lambda d: classical_3d(d.env, avoid=True)),
                                 tasks="planning", protection="paper", role="paper", domains=BOTH))
register("planner-map", PolicySpec(
    "planner-route on the sonar map's path without training on it (`guide=\"map\"`): what planner-general's "
    "training on the map adds over it", lambda d: checkpoint_policy(d.checkpoint, d.env, "speed-aware", guide="map"),
    family="learned", checkpoint="planner_route.pt", **GENERAL_DEPLOYMENT, role="reference"))
MEMORY_PLANNER = "planner_memory.pt"
"""The shipped checkpoint of `planner-memory`: PPO with a GRU on the training mixture, chosen on validation seeds
(docs/runs/planner-memory-ppo/)."""
register("planner-memory", PolicySpec(
    "a planner learned from scratch (PPO with a GRU memory) on random obstacles, moving obstacles and tunnels, both "
    "tiers and waters: the sonars, its motion and the goal in, (speed, heading) out, nothing classical under it",
    lambda d: recurrent_policy(d.checkpoint, d.env), family="learned", checkpoint=MEMORY_PLANNER, tasks="planning",
    protection=False, accepts_path=True, role="comparison"))
LEARNED_PLANNER = "planner_learned.pt"
"""The shipped checkpoint of `planner-learned`: a GRU student that reads its own sonar map (observation="planner-map"),
taught by `map-replan` flying beside it (DAgger on the training mixture, then a final fit of 128 epochs over DAgger's
data), then a PPO stage with the tunnels oversampled, held near the student by an imitation term on its own frozen
actions (`auv-mj train ppo --init --ppo-imitation-source init`), chosen on validation seeds
(docs/runs/planner-learned/)."""
LEARNED_PLANNER_3D = "planner_learned_3d.pt"
"""The shipped checkpoint of `planner-learned` on the 6-DOF tasks: an ensemble (`auv_mj.agents.ppo.model.ActorEnsemble`,
the mean of the members' actions) of three GRU students of the 3-D geodesic teacher, the recipe's training seeds 0, 1
and 2, each by DAgger on the 6-DOF mixture and a final fit of 128 epochs over DAgger's data, reading the fan held over
pings (observation="fan-held"), on the re-tuned S-plane; chosen on validation seeds over its best single seed, the
same recipe on the plain fan, on the sonar map, DAgger alone, its PPO fine-tunes and its ablations
(docs/runs/planner-learned-3d/)."""
register("planner-learned", PolicySpec(
    "the learned planner of the well-posed problem (geodesic reward, rate action, planner observation): a GRU "
    "student of map-replan (DAgger on random obstacles, moving obstacles and tunnels, both tiers and waters), "
    "fine-tuned with PPO on the geodesic reward; the sonars and its own sonar map, its pose, the route target and its "
    "last action in, (speed, heading rate) out; no search, no line of sight, no protection domain, no residual "
    "(auv3d: the ensemble of three students of the 3-D teacher on goal3d and tunnel3d, the fan held over pings, "
    "altimeter and target in, (speed, heading, depth) out, on splane-ocean)",
    lambda d: recurrent_policy(d.checkpoint, d.env), family="learned", checkpoint=LEARNED_PLANNER,
    checkpoint_on={"goal3d": LEARNED_PLANNER_3D, "tunnel3d": LEARNED_PLANNER_3D}, tasks="planning",
    protection=False, accepts_path=True, domains=BOTH))
LEARNED_PLANNER_3D_NO_MEMORY = "planner_learned_3d_no_memory.pt"
"""The learned 3-D planner's no-memory ablation: the shipped student's DAgger (teacher, batch, rounds, final fit, seed,
the held fan) with a feed-forward student (`--dagger-recurrent none`; docs/runs/planner-learned-3d/)."""
register("planner-learned-3d-no-memory", PolicySpec(
    "planner-learned on the 6-DOF tasks without its memory (the ablation): the same DAgger of the 3-D teacher, a "
    "feed-forward student", lambda d: recurrent_policy(d.checkpoint, d.env), family="learned",
    checkpoint=LEARNED_PLANNER_3D_NO_MEMORY, tasks="planning", protection=False, accepts_path=True,
    domains=(DOMAIN_3D,), role="comparison"))
LEARNED_PLANNER_3D_NO_TEACHER = "planner_learned_3d_no_teacher.pt"
"""The learned 3-D planner's no-teacher ablation: PPO from scratch on the student's batch, problem, input (the held
fan) and network, its critic reading the privileged inputs, for about the student's training wall-clock (`auv-mj train
ppo --task planning-mix-3d --task-kwargs '{"observation": "fan-held"}'`; docs/runs/planner-learned-3d/)."""
register("planner-learned-3d-no-teacher", PolicySpec(
    "planner-learned on the 6-DOF tasks without its teacher (the ablation): PPO from scratch on the same problem, "
    "batch and network", lambda d: recurrent_policy(d.checkpoint, d.env), family="learned",
    checkpoint=LEARNED_PLANNER_3D_NO_TEACHER, tasks="planning", protection=False, accepts_path=True,
    domains=(DOMAIN_3D,), role="comparison"))
register("planner-memory-safe", PolicySpec(
    "planner-memory inside the speed-aware protection domain and the geofence (the safety layer under it)",
    lambda d: recurrent_policy(d.checkpoint, d.env, "speed-aware"), family="learned", checkpoint=MEMORY_PLANNER,
    tasks="planning", protection="speed-aware", accepts_path=True, role="comparison"))
register("los-fast", PolicySpec("line of sight along the route at 2 m/s inside the speed-aware protection domain and "
                                "the geofence: planner-route's zero action at top speed",
                                lambda d: fast_line_of_sight(d.env), tasks="planning", protection="speed-aware",
                                role="reference"))
register("map-replan", PolicySpec("the mapping local planner: a sonar occupancy grid searched again as it changes, "
                                  "followed by line of sight at 2 m/s (speed-aware domain; "
                                  "`auv_mj.planners.map_planner`; auv3d: a voxel map of the 3-D fan and the "
                                  "altimeter, a pitch-limited search, 3-D line of sight, "
                                  "`auv_mj.planners.map_planner3d`)",
                                  by_domain(auv=lambda d: sonar_map_planner(d.env),
                                            auv3d=lambda d: sonar_voxel_planner(d.env)),
                                  tasks="planning", protection="speed-aware", domains=BOTH))
register("bug", PolicySpec("a complete sensor-based planner of the Bug family (DistBug's leave rule) on the "
                           "sonar's remembered echoes, at 2 m/s inside the speed-aware domain (`auv_mj.planners.bug`)",
                           lambda d: bug_planner(d.env), tasks="planning", protection="speed-aware"))
register("oracle", PolicySpec("plans on the true map (every geom, movers where they are) and follows the plan as "
                              "map-replan does: certifies arenas, the reference of time efficiency (auv3d: on the "
                              "true voxel map)",
                              by_domain(auv=lambda d: true_map_planner(d.env),
                                        auv3d=lambda d: true_voxel_planner(d.env)),
                              family="reference", tasks="planning",
                              protection="speed-aware", role="reference", domains=BOTH))
register("geodesic-teacher", PolicySpec("the privileged teacher of the learned planner: steers down the episode's "
                                        "geodesic field on the true map, round the movers where they truly are, in "
                                        "action=\"rate\" (`auv_mj.planners.teacher`; auv3d: line of sight down "
                                        "the field of the true voxel map, `auv_mj.planners.teacher3d`); it uses the "
                                        "true map",
                                        by_domain(auv=lambda d: geodesic_teacher(d.env),
                                                  auv3d=lambda d: geodesic_teacher_3d(d.env)),
                                        family="reference", tasks="planning", role="reference", domains=BOTH))
register("random", PolicySpec("uniform random actions", lambda d: uniform_random(d.env, d.seed), family="reference",
                              role="reference", domains=BOTH))

CHECKPOINT = PolicySpec("a trained checkpoint (`auv-mj train`), with the protection domain it trained with",
                        from_checkpoint, family="learned", domains=BOTH)
"""The spec of a checkpoint path given as the name."""


# --- names -> specs ---------------------------------------------------------------------------------------------


def resolve(policy_name: str) -> tuple[PolicySpec, Path | None]:
    """(spec, checkpoint) of a `--policy` value: a registered name, NAME=PATH, a checkpoint path or a RESOLVERS
    form. The checkpoint is PATH or the checkpoint file; None where the spec's own (shipped) one applies.
    ValueError naming the valid names for an unknown one; FileNotFoundError for NAME=PATH with no file."""
    if not isinstance(policy_name, str) or not policy_name:
        raise ValueError(f"policy name must be a non-empty string, got {policy_name!r}")
    if policy_name in POLICIES:
        return POLICIES[policy_name], None
    base, sep, path = policy_name.partition("=")
    if sep and base in POLICIES and POLICIES[base].accepts_path:
        if not Path(path).is_file():
            raise FileNotFoundError(f"policy {policy_name!r}: no checkpoint at {path}")
        return POLICIES[base], Path(path)
    for resolver in RESOLVERS:
        found = resolver(policy_name)
        if found is not None:
            return found
    if Path(policy_name).is_file():
        return CHECKPOINT, Path(policy_name)
    paths = ", ".join(f"{n}=PATH" for n, spec in POLICIES.items() if spec.accepts_path)
    raise ValueError(unknown_name("policy", policy_name, POLICIES, f"; or a checkpoint file, {paths}, "
                                  "MODULE:FACTORY or PATH.zip (`auv-mj policies` describes each name)", "policies"))


def split_name(policy_name: str) -> tuple[PolicySpec, Path | None]:
    """`resolve`, under its older name."""
    return resolve(policy_name)


def _checkpoint_of(spec: PolicySpec, path: Path | None, task: str | None) -> Path | None:
    """The checkpoint a resolved name runs on `task`: PATH, else the spec's shipped one, else None."""
    if path is not None:
        return path
    if spec.checkpoint is None:
        return None
    name = next(n for n, s in POLICIES.items() if s is spec)
    return shipped_checkpoint(name, task)


def executor_tasks() -> tuple[str, ...]:
    """The suite's execution-layer tasks of both domains (tagged "executor"): the tasks with no executor option."""
    return tuple(t for domain in suite_domains.DOMAINS.values() for t in domain.registry.tagged("executor"))


def domain_tasks(domain: str, runs_on: str = "any") -> list[str]:
    """The task names of suite domain `domain` tagged `runs_on` ("planning", "executor"), or all of them ("any")."""
    names = suite.TASKS_BY_DOMAIN[domain]
    if runs_on == "any":
        return list(names)
    tagged = set(suite_domains.DOMAINS[domain].registry.tagged(runs_on))
    return [t for t in names if t in tagged]


def runs_on(spec: PolicySpec, task_name: str) -> bool:
    """Whether a policy of `spec` runs on suite task `task_name` (its domains and `PolicySpec.tasks`)."""
    domain = suite.domain_of(task_name)
    return domain in spec.domains and task_name in domain_tasks(domain, spec.tasks)


def task_policies(task_name: str) -> list[str]:
    """The registered policies that run on `task_name`."""
    return [name for name, spec in POLICIES.items() if runs_on(spec, task_name)]


def _kind(runs: str) -> str:
    return {"any": "", "planning": "planning ", "executor": "tracking "}[runs]


def check_runs_on(policy_name: str, task_name: str) -> None:
    """ValueError, one line, when the policy does not run on the task: naming the policy, the task, what the policy
    runs on and which registered policies run on the task."""
    spec = resolve(policy_name)[0]
    if runs_on(spec, task_name):
        return
    domain = suite.domain_of(task_name)
    kind = next((k for k in ("planning", "executor") if task_name in domain_tasks(domain, k)), "any")
    raise ValueError(f"policy {policy_name!r} runs on {_runs_on_text(spec)}; {task_name!r} is a {DOMAINS[domain]} "
                     f"{_kind(kind)}task: its policies are {', '.join(task_policies(task_name))}")


def _runs_on_text(spec: PolicySpec) -> str:
    """What a spec runs on, in words: "the planar planning tasks (goal, ...)"."""
    where = " and ".join(DOMAINS[d] for d in spec.domains)
    tasks = [t for d in spec.domains for t in domain_tasks(d, spec.tasks)]
    return f"the {where} {_kind(spec.tasks)}tasks ({', '.join(tasks)})"


def make_env(policy_name: str, task_name: str, seed: int, **task_kwargs):
    """The suite environment for one episode; a spec with an executor plugs it in, and a checkpoint gets the
    observation it was trained on (read from its metadata). Only what the policy needs is set (an executor, a
    checkpoint's observation), never an option its task does not take. ValueError (`check_runs_on`) for a policy
    that does not run on the task."""
    check_runs_on(policy_name, task_name)
    spec, path = resolve(policy_name)
    task_kwargs["random"] = seed
    executor = task_kwargs.get("executor")
    planning = task_name not in executor_tasks()
    domain = suite.domain_of(task_name)
    three_d = domain == DOMAIN_3D
    if spec.executor is not None and planning:
        if executor is not None:
            raise ValueError(f"policy {policy_name!r} runs the learned executor {spec.executor!r}; leave 'executor' "
                             f"out of task_kwargs (or use a planner policy with it)")
        task_kwargs["executor"] = named_executor(spec.executor, domain)
    elif isinstance(executor, str):
        task_kwargs["executor"] = named_executor(executor, domain)
    elif spec.default_executor is not None and planning:
        task_kwargs["executor"] = named_executor(spec.default_executor, domain)
    checkpoint = _checkpoint_of(spec, path, task_name)
    if checkpoint is not None and checkpoint_kind(checkpoint) == "ppo":  # the options it was trained with
        trained = read_checkpoint(checkpoint).metadata["spec"].get("task_options", {})
        task_kwargs.update({k: v for k, v in trained.items() if k not in task_kwargs})
    elif checkpoint is not None and "observation" not in task_kwargs:
        # an off-policy checkpoint gets the observation it was trained on
        meta = read_checkpoint(checkpoint).metadata
        if not planning:  # the executor's observation (residual, gains, base) it was trained with
            trained = meta.get("run_info", {}).get("task_kwargs", {})
            options = depth_executor_options if three_d else executor_options
            memory = options(int(meta["obs_dim"]), trained)
            task_kwargs.update({k: v for k, v in memory.items() if k not in task_kwargs})
        elif meta["spec"].get("kind") == "goal" and not three_d:  # a planar planner reading the goal beside the
            # paper's vector
            task_kwargs["observation"] = "paper" if meta["spec"].get("goal_input", True) else "relative"
    return suite.load(suite.domain_of(task_name), task_name, task_kwargs=task_kwargs)


def make_policy(policy_name: str, env, seed: int = 0, task: str | None = None) -> Planner:
    """The named policy as a Planner (`reset()`, `act(time_step)`) for `env` (of suite task `task`, which picks the
    checkpoint). ValueError (`check_runs_on`) for a policy that does not run on `task`, or on `env`'s domain when no
    task is named."""
    spec, path = resolve(policy_name)
    domain = suite_domains.of_env(env).name
    if task is not None:
        check_runs_on(policy_name, task)
    elif domain not in spec.domains:
        raise ValueError(f"policy {policy_name!r} runs on {_runs_on_text(spec)}, not on a {DOMAINS[domain]} task")
    checkpoint = _checkpoint_of(spec, path, task)
    planner = as_planner(spec.build(Deployment(env, task, seed, checkpoint, spec, domain)))
    if checkpoint is None and spec.protection and domain == "auv":  # a classical policy inside a protection domain
        # (an auv3d policy carries its own domain on the 3-D fan)
        planner = with_repulsion(planner, protection_field(spec.protection), map_fence(env))
    return planner


def resolve_tasks(spec: str, policy_name: str = "splane") -> list[str]:
    """A task name, a tag, a domain ("auv", "auv3d") or 'all' -> the task names the policy runs on (its
    `PolicySpec.domains` and `PolicySpec.tasks`).

    'all' and the tags cover both domains, the planar tasks first; a group keeps the tasks the policy runs on, and
    a task named alone that it does not run on is refused in one line (`check_runs_on`)."""
    domains = {d: list(names) for d, names in suite.TASKS_BY_DOMAIN.items()}
    names = [t for group in domains.values() for t in group]
    tags = sorted({tag for domain in suite_domains.DOMAINS.values() for tag in domain.registry.tags()})
    if spec in names:
        check_runs_on(policy_name, spec)
        return [spec]
    if spec == "all":
        chosen = names
    elif spec in domains:
        chosen = domains[spec]
    elif spec in tags:
        chosen = [t for d in domains for t in domain_tasks(d, spec)]
    else:
        raise ValueError(f"unknown task, tag or domain {shown(spec)}{did_you_mean(spec, [*names, *tags, *domains])}; "
                         f"{tasks_text()}; tags: {', '.join(tags)}; or all")
    policy = resolve(policy_name)[0]
    kept = [t for t in chosen if runs_on(policy, t)]
    if not kept:
        raise ValueError(f"policy {policy_name!r} runs on {_runs_on_text(policy)}, none of {spec!r} "
                         f"({', '.join(chosen)})")
    return kept


def env_and_policy(policy_name: str, task_name: str, seed: int, task_kwargs: dict | None = None):
    """The environment of one episode of `task_name` (seeded `seed`) and the named policy acting in it.

    Raises ValueError naming the option when the task does not take one of `task_kwargs`. Policies infer on
    one torch thread: their small MLPs are fastest so, and parallel episodes do not oversubscribe the cores.
    """
    torch.set_num_threads(1)
    task_kwargs = dict(task_kwargs or {})
    if "random" in task_kwargs:
        raise ValueError("task_kwargs: 'random' is set by --seed (episode i gets seed + i), leave it out")
    try:
        env = make_env(policy_name, task_name, seed, **task_kwargs)
    except TypeError as e:  # an option the task does not take
        raise ValueError(f"task_kwargs {task_kwargs} do not fit task {task_name!r}: {e}") from None
    return env, make_policy(policy_name, env, seed, task_name)


# --- tables derived from the registry ---------------------------------------------------------------------------


def tasks_text() -> str:
    """The tasks of each domain, as refusals and `--task`'s help name them: "tasks of domain auv (the planar
    vehicle): goal, ...; of domain auv3d (the 6-DOF vehicle): depth_heading, ..."."""
    return "; ".join(f"{'tasks of ' if i == 0 else 'of '}domain {domain} (the {DOMAINS[domain]} vehicle): "
                     f"{', '.join(names)}" for i, (domain, names) in enumerate(suite.TASKS_BY_DOMAIN.items()))


def policy_help() -> str:
    """The `--policy` help of every command, from the registry."""
    paths = ", ".join(f"{n}=PATH" for n, s in POLICIES.items() if s.accepts_path)
    return (f"a registered policy ({', '.join(POLICIES)}; `auv-mj policies` describes each), a checkpoint path, "
            f"{paths} (a candidate checkpoint in the shipped one's place), MODULE:FACTORY (your factory(env) -> "
            f"policy(time_step) -> action) or PATH.zip (a Stable-Baselines3 model)")


def runs_on_label(spec: PolicySpec) -> str:
    """The "runs on" cell of a spec: its domains' words and its kind of task ("planar + 6-DOF planning tasks"), or
    the tracking tasks by name."""
    if spec.tasks == "executor":
        return ", ".join(t for d in spec.domains for t in domain_tasks(d, "executor"))
    return f"{' + '.join(DOMAINS[d] for d in spec.domains)} {_kind(spec.tasks)}tasks"


def markdown_table() -> str:
    """docs/policies.md's policy tables, one per role (`ROLES`): name, family, tasks, executor, protection, what."""
    lines = []
    for role, title in ROLES.items():
        lines += [f"**{title}**", "", "| policy | family | runs on | executor | protection | what it is |",
                  "| --- | --- | --- | --- | --- | --- |"]
        for name, spec in POLICIES.items():
            if spec.role != role:
                continue
            tasks = runs_on_label(spec)
            executor = spec.executor or spec.default_executor or ("task's" if spec.tasks != "executor" else "-")
            protection = {None: "as trained" if spec.checkpoint else "-", True: "paper's (or its own)",
                          False: "none"}.get(spec.protection, spec.protection)
            lines.append(f"| `{name}` | {spec.family} | {tasks} | {executor} | {protection} | {spec.description} |")
        lines.append("")
    return "\n".join(lines).rstrip()


from auv_mj.zoo import outside  # noqa: E402, F401, I001  (registers MODULE:FACTORY and PATH.zip in RESOLVERS)


def load_policy(name: str, env, task: str | None = None, seed: int = 0) -> Planner:
    """The named policy (any `--policy` form) acting in `env`, a suite environment of task `task` (which picks a
    per-task checkpoint), as a Planner: `reset()` at an episode's start, `act(time_step) -> action`. For an environment
    that the policy needs set up (its executor, the observation a checkpoint was trained on), build both with
    `env_and_policy`."""
    return make_policy(name, env, seed, task)
