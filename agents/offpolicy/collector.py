"""Environments stepped, and the actor learnt, in collector processes while the learner learns the critic.

`auv_mj.agents.offpolicy.train.train(..., collectors=N)` uses the second core (and more) in lock-step rounds of
train_every * N env steps. In a round the collector processes step their own environments with the actor
and normaliser of the round's start (exploring as `DDPG.act`), and with one collector the learner steps a
share of the round in an environment of its own too (`LEARNER_SHARE`); collector 0 then does the round's
actor steps (Eq. 16) against the critic of the round's start, while the learner does the round's critic
steps (Eq. 17-18) on the same batch, with the actor target of the round's start. The learner samples the
next round's batch before the round's transitions arrive, starts the next round as soon as they do, then
stores them, stream by stream and step by step, and logs the episodes that ended. Nothing depends on
timing, so a run is deterministic given its seed and N (the same seed and N give the same run).

Weights, Adam moments and batches cross between the processes through one tensor in shared memory
(`SharedSlots`); the pipes carry only orders and the round's transitions.

It is not the run of the serial loop (N = 0), where every gradient step sees the critic and actor of the
step before: here the actor climbs a critic up to one round (train_every gradient steps) old, the critic's
TD targets use an actor target up to one round old, the actor collects with weights one round behind, a
round's batch comes from the transitions of the rounds before the one before it, and exploration draws
come from a stream per (seed, stream, round). The update-to-data ratio is the serial one:
round(train_every * updates_per_step) gradient steps per train_every env steps, with the steps owed before
anything could be sampled taken later, as the serial loop does (`auv_mj.agents.offpolicy.train._learn`).

This module sees environments only through the factory it is given (`env_fn`, picklable: it is sent to the
collector processes), never a task.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig, epsilon_at, updates_per_round
from auv_mj.agents.offpolicy.her import policy_input
from auv_mj.seeds import train_seed

LEARNER_SHARE: dict[int, float] = {1: 0.375}
"""Per number of collector processes, the fraction of each round's env steps the learner steps itself.

With one collector on two cores: collector 0's actor steps cost about the learner's critic steps, and the
learner also stores and samples, so without a share of its own the learner waits for the collector
about a third of each round. A fixed fraction (not one set by timing) keeps a run deterministic. With
more collectors than spare cores, the learner steps none."""
CATCH_UP = 2
"""A round takes at most this many times its own gradient steps: `auv_mj.agents.offpolicy.train` catches up on steps
owed while nothing could be sampled yet. The batch slot of `shared_layout` is sized for it."""
ROUND_STREAM = 2
"""Tag of the per-round exploration streams in SeedSequence([seed, ROUND_STREAM, collector, env steps])."""


def episode_seed(seed: int, episode: int) -> int:
    """The env reset seed of episode `episode` of a run seeded with `seed`: in the TRAIN range of
    `auv_mj.seeds`, never a validation or test seed."""
    return train_seed(seed, episode)


def flat_observation(spec: dict[str, Any], obs: Any) -> np.ndarray:
    """The actor's input: [observation, desired_goal] on goal tasks (the observation alone where it holds
    the goal, `auv_mj.agents.offpolicy.her.policy_input`), the flat observation otherwise."""
    if spec["kind"] == "goal":
        return policy_input(obs["observation"], obs["desired_goal"], spec.get("goal_input", True))
    return np.asarray(obs, np.float32).ravel()


def env_action(spec: dict[str, Any], action: np.ndarray, dtype: Any) -> np.ndarray:
    """The actor's [-1, 1] action scaled to the env's action bounds."""
    low = np.asarray(spec["action_low"], np.float32)
    high = np.asarray(spec["action_high"], np.float32)
    return (low + (action + 1.0) * 0.5 * (high - low)).astype(dtype)


class SharedSlots:
    """Named float32 slots of one tensor in shared memory, which the learner and its collectors all map.

    Weights, optimiser moments and batches cross between the processes here, as in-place copies, and only
    small orders and the round's transitions go through the pipes: pickling the actor's state through a
    pipe each round cost more than the round's actor steps. Each side writes a slot before the pipe message
    that hands it over and reads it after the message, so nothing depends on timing.
    """

    def __init__(self, sizes: dict[str, int], tensor: torch.Tensor | None = None):
        self.sizes = dict(sizes)
        total = sum(self.sizes.values())
        self.tensor = torch.zeros(total).share_memory_() if tensor is None else tensor
        self.slots: dict[str, torch.Tensor] = {}
        offset = 0
        for name, size in self.sizes.items():
            self.slots[name] = self.tensor[offset:offset + size]
            offset += size

    def __getitem__(self, name: str) -> torch.Tensor:
        return self.slots[name]

    def __reduce__(self):  # to a collector process: the sizes and the shared tensor (a handle, not a copy)
        return SharedSlots, (self.sizes, self.tensor)


def shared_layout(agent: DDPG, count: int) -> dict[str, int]:
    """The slots `Collectors` exchanges through: the normaliser's mean and std, the critic, the actor and
    its target and Adam moments, the actor's step count, the behaviour actor of collectors 1.., and the
    normalised observations of a round's actor steps."""
    actor, critic, config = agent.vectors["actor"].data.numel(), agent.vectors["critic"].data.numel(), agent.config
    rows = CATCH_UP * count * updates_per_round(config) * config.batch_size
    return {"normaliser": 2 * agent.obs_dim, "critic": critic, "actor": actor, "actor_target": actor,
            "exp_avg": actor, "exp_avg_sq": actor, "actor_steps": 1, "behaviour": actor if count > 1 else 0,
            "obs": rows * agent.obs_dim}


def write_actor(agent: DDPG, shared: SharedSlots) -> None:
    """What the actor learner owns, into `shared`: the actor, its target, Adam's moments and step count."""
    with torch.no_grad():
        shared["actor"].copy_(agent.vectors["actor"].data)
        shared["actor_target"].copy_(agent.vectors["actor_target"].data)
        moments = agent.actor_opt.moments(agent.vectors["actor"])
        for name in ("exp_avg", "exp_avg_sq"):
            shared[name].copy_(moments[name])
        shared["actor_steps"].copy_(moments["step"].reshape(1))


def read_actor(agent: DDPG, shared: SharedSlots) -> None:
    """The inverse of `write_actor`."""
    with torch.no_grad():
        agent.vectors["actor"].data.copy_(shared["actor"])
        agent.vectors["actor_target"].data.copy_(shared["actor_target"])
        moments = agent.actor_opt.moments(agent.vectors["actor"])
        for name in ("exp_avg", "exp_avg_sq"):
            moments[name].copy_(shared[name])
        moments["step"].copy_(shared["actor_steps"][0])


class Stepper:
    """One environment of a run's rounds, stepped with the behaviour actor: stream `index` of `count`.

    Stream i resets episodes first_episode + i, + i + count, ... and explores with the draws of
    SeedSequence([seed, ROUND_STREAM, i, env steps at the round's start]), so its transitions depend on
    the round's actor and normaliser and nothing else. `agent` acts (its actor and normaliser are set
    by whoever owns the stepper before each round).
    """

    def __init__(self, env: gym.Env, spec: dict[str, Any], agent: DDPG, index: int, count: int,
                 first_episode: int):
        self.env, self.spec, self.agent, self.index, self.count = env, spec, agent, index, count
        self.episode, self.obs = first_episode + index, None

    def run(self, steps: int, env_steps: int, episodes: int) -> list[tuple]:
        """`steps` transitions (obs, flat obs, action, reward, next obs, terminated, truncated, info)."""
        agent, config, env, spec = self.agent, self.agent.config, self.env, self.spec
        agent.rng = np.random.default_rng([config.seed, ROUND_STREAM, self.index, env_steps])
        transitions = []
        for step in range(steps):
            if self.obs is None:
                self.obs, _ = env.reset(seed=episode_seed(config.seed, self.episode))
                self.episode += self.count
            obs = self.obs
            x = flat_observation(spec, obs)
            agent.epsilon = epsilon_at(config, env_steps + step * self.count + self.index, episodes)
            action = agent.act(x, explore=True)
            next_obs, reward, terminated, truncated, info = env.step(env_action(spec, action, env.action_space.dtype))
            transitions.append((obs, x, action, float(reward), next_obs, bool(terminated), bool(truncated), info))
            self.obs = None if terminated or truncated else next_obs
        return transitions


def _collect(conn, env_fn: Callable[[], gym.Env], spec: dict[str, Any], config: DDPGConfig, index: int,
             count: int, first_episode: int, shared: SharedSlots) -> None:
    """A collector process: steps its env for each round the learner asks for, until told to stop (None).

    Collector 0 also learns the actor: after its steps of a round it does the round's actor steps against
    the critic the learner put in `shared`, and puts the actor, its target and Adam's state back there.
    """
    torch.set_num_threads(1)
    try:
        agent = DDPG(spec["obs_dim"], spec["act_dim"], config)
        stepper = Stepper(env_fn(), spec, agent, index, count, first_episode)
        obs_dim = agent.obs_dim
        if index == 0:
            read_actor(agent, shared)
        while (order := conn.recv()) is not None:
            steps, env_steps, episodes, actor_updates = order
            with torch.no_grad():
                if index > 0:
                    agent.vectors["actor"].data.copy_(shared["behaviour"])
                agent.obs_norm.mean.copy_(shared["normaliser"][:obs_dim])
                agent.obs_norm.std.copy_(shared["normaliser"][obs_dim:])
            transitions = stepper.run(steps, env_steps, episodes)
            actor_loss = None
            if index == 0 and actor_updates:
                with torch.no_grad():
                    agent.vectors["critic"].data.copy_(shared["critic"])
                rows = shared["obs"][:actor_updates * config.batch_size * obs_dim].view(-1, obs_dim)
                losses = torch.stack([agent.actor_step(part) for part in rows.split(config.batch_size)])
                actor_loss = float(losses.mean())
                write_actor(agent, shared)
            conn.send((transitions, actor_loss))
        stepper.env.close()
    except KeyboardInterrupt:
        pass
    except BaseException as exc:  # noqa: BLE001  (handed to the learner, which raises it)
        conn.send(exc)


class Collectors:
    """N collector processes, each with its own environment from `env_fn`, and optionally a share of the
    env steps stepped here, in the learner's process, with `local_env` (`LEARNER_SHARE`).

    `start_round(steps, env_steps, episodes, actor_obs)` hands the collectors the normaliser and the actor,
    and collector 0 the critic and the normalised observations of its actor steps (`actor_obs`, a multiple
    of batch_size rows; None before learning starts). `step_local()` steps the learner's share of the round
    (call it while the collectors work); `finish_round()` returns the round's transitions (obs, flat obs,
    action, reward, next obs, terminated, truncated, info) per stream, the collectors' in order and then
    the learner's, and loads the actor that collector 0 learnt into `agent`, returning its mean actor loss
    (None if it took no step).
    """

    def __init__(self, env_fn: Callable[[], gym.Env], spec: dict[str, Any], agent: DDPG, count: int,
                 first_episode: int = 0, local_env: gym.Env | None = None):
        if count < 1:
            raise ValueError(f"collectors must be >= 1, got {count}")
        context = multiprocessing.get_context("spawn")  # no forked copy of torch or MuJoCo state
        self.count, self.agent, self.conns, self.processes = count, agent, [], []
        self.local: Stepper | None = None
        if local_env is not None and LEARNER_SHARE.get(count, 0.0) > 0:
            acting = DDPG(spec["obs_dim"], spec["act_dim"], agent.config)  # acts with the round's actor
            self.local = Stepper(local_env, spec, acting, count, count + 1, first_episode)
        self.streams = count + (self.local is not None)
        """Environments stepped per round: the collectors' and the learner's own."""
        self.shared = SharedSlots(shared_layout(agent, count))
        write_actor(agent, self.shared)
        for index in range(count):
            here, there = context.Pipe()
            process = context.Process(target=_collect, name=f"collector-{index}", daemon=True,
                                      args=(there, env_fn, spec, agent.config, index, self.streams, first_episode,
                                            self.shared))
            process.start()
            there.close()
            self.conns.append(here)
            self.processes.append(process)
        self._open = False
        self._local_order: tuple[int, int, int] = (0, 0, 0)
        self._local_transitions: list[tuple] = []

    def start_round(self, steps: int, env_steps: int, episodes: int, actor_obs: torch.Tensor | None = None) -> None:
        """Starts a round of `steps` env steps: the learner's share (`LEARNER_SHARE`) and the rest split
        across the collectors as evenly as possible, the first ones more."""
        agent, shared = self.agent, self.shared
        actor_updates = 0
        with torch.no_grad():
            shared["normaliser"][:agent.obs_dim].copy_(agent.obs_norm.mean)
            shared["normaliser"][agent.obs_dim:].copy_(agent.obs_norm.std)
            if self.count > 1:
                shared["behaviour"].copy_(agent.vectors["actor"].data)
            if actor_obs is not None:
                shared["critic"].copy_(agent.vectors["critic"].data)
                shared["obs"][:actor_obs.numel()].copy_(actor_obs.reshape(-1))
                actor_updates = len(actor_obs) // agent.config.batch_size
            if self.local is not None:  # the round's actor and normaliser, before collector 0's actor moves it
                self.local.agent.vectors["actor"].data.copy_(agent.vectors["actor"].data)
                self.local.agent.obs_norm.mean.copy_(agent.obs_norm.mean)
                self.local.agent.obs_norm.std.copy_(agent.obs_norm.std)
        local = round(steps * LEARNER_SHARE[self.count]) if self.local is not None else 0
        base, extra = divmod(steps - local, self.count)
        for index, conn in enumerate(self.conns):
            conn.send((base + (index < extra), env_steps, episodes, actor_updates if index == 0 else 0))
        self._local_order = (local, env_steps, episodes)
        self._local_transitions = []
        self._open = True

    def step_local(self) -> None:
        """Steps the learner's own share of the round in this process (nothing if it has none)."""
        if self.local is not None and self._local_order[0]:
            self._local_transitions = self.local.run(*self._local_order)
            self._local_order = (0, *self._local_order[1:])

    def finish_round(self) -> tuple[list[list[tuple]], float | None]:
        """Each stream's transitions of the round and collector 0's mean actor loss; raises what a
        collector raised, or if one died."""
        self.step_local()
        results = []
        self._open = False
        for index, conn in enumerate(self.conns):
            try:
                result = conn.recv()
            except (EOFError, OSError):
                raise RuntimeError(f"collector process {index} died (exit code "
                                   f"{self.processes[index].exitcode})") from None
            if isinstance(result, BaseException):
                raise RuntimeError(f"collector process {index} failed: {result!r}") from result
            results.append(result)
        read_actor(self.agent, self.shared)
        rounds = [transitions for transitions, _ in results]
        if self.local is not None:
            rounds.append(self._local_transitions)
        return rounds, results[0][1]

    def close(self) -> None:
        """Stops the processes; the transitions of an unfinished round are dropped."""
        for conn in self.conns:
            if self._open and conn.poll(10):
                try:
                    conn.recv()
                except (EOFError, OSError):
                    pass
            try:
                conn.send(None)
            except (BrokenPipeError, OSError):
                pass
        for process in self.processes:
            process.join(timeout=30)
            if process.is_alive():
                process.kill()
        for conn in self.conns:
            conn.close()

    def __enter__(self) -> Collectors:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
