"""Environments stepped, and the actor learnt, in collector processes while the learner learns the critic.

`agents.train.train(..., collectors=N)` uses the second core (and more) in lock-step rounds. In a round
every collector process steps its own environment `train_every` times with the actor and normaliser of
the round's start (exploring as `DDPG.act`); collector 0 then does the round's actor steps (Eq. 16)
against the critic of the round's start, while the learner does the round's critic steps (Eq. 17-18) on
the same batch, with the actor target of the round's start. Then the learner stores the round's
transitions, collector by collector and step by step, logs the episodes that ended, samples the next
round's batch and starts the next round. Nothing depends on timing, so a run is deterministic given its
seed and N (the same seed and N give the same run).

It is not the run of the serial loop (N = 0), where every gradient step sees the critic and actor of the
step before: here the actor climbs a critic up to one round (train_every gradient steps) old, the critic's
TD targets use an actor target up to one round old, the actor collects with weights one round behind, and
exploration draws come from a stream per (seed, collector, round). The update-to-data ratio is the serial
one: round(train_every * updates_per_step) gradient steps per `train_every` env steps.

This module sees environments only through the factory it is given (`env_fn`, picklable: it is sent to the
collector processes), never a task.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from agents.ddpg import DDPG, DDPGConfig, epsilon_at
from agents.her import policy_input
from auv_mj.seeds import train_seed

ROUND_STREAM = 2
"""Tag of the per-round exploration streams in SeedSequence([seed, ROUND_STREAM, collector, env steps])."""


def episode_seed(seed: int, episode: int) -> int:
    """The env reset seed of episode `episode` of a run seeded with `seed`: in the TRAIN range of
    `auv_mj.seeds`, never a validation or test seed."""
    return train_seed(seed, episode)


def flat_observation(spec: dict[str, Any], obs: Any) -> np.ndarray:
    """The actor's input: [observation, desired_goal] on goal tasks (the observation alone where it holds
    the goal, `agents.her.policy_input`), the flat observation otherwise."""
    if spec["kind"] == "goal":
        return policy_input(obs["observation"], obs["desired_goal"], spec.get("goal_input", True))
    return np.asarray(obs, np.float32).ravel()


def env_action(spec: dict[str, Any], action: np.ndarray, dtype: Any) -> np.ndarray:
    """The actor's [-1, 1] action scaled to the env's action bounds."""
    low = np.asarray(spec["action_low"], np.float32)
    high = np.asarray(spec["action_high"], np.float32)
    return (low + (action + 1.0) * 0.5 * (high - low)).astype(dtype)


def _numpy(module_or_optimizer: Any) -> dict[str, Any]:
    """A state dict with its tensors as numpy arrays (they pickle lighter through a pipe)."""
    import torch

    def convert(value: Any) -> Any:
        if isinstance(value, torch.Tensor):
            return value.detach().cpu().numpy()
        if isinstance(value, dict):
            return {k: convert(v) for k, v in value.items()}
        if isinstance(value, list):
            return [convert(v) for v in value]
        return value

    return convert(module_or_optimizer.state_dict())


def _torch(state: Any) -> Any:
    """The inverse of `_numpy`."""
    import torch

    if isinstance(state, np.ndarray):
        return torch.from_numpy(state)
    if isinstance(state, dict):
        return {k: _torch(v) for k, v in state.items()}
    if isinstance(state, list):
        return [_torch(v) for v in state]
    return state


def actor_state(agent: DDPG) -> dict[str, Any]:
    """What the actor learner owns: actor, its target and its optimiser, as numpy state dicts."""
    return {"actor": _numpy(agent.actor), "actor_target": _numpy(agent.actor_target),
            "actor_opt": _numpy(agent.actor_opt)}


def load_actor_state(agent: DDPG, state: dict[str, Any]) -> None:
    """Loads what `actor_state` returned into `agent`."""
    agent.actor.load_state_dict(_torch(state["actor"]))
    agent.actor_target.load_state_dict(_torch(state["actor_target"]))
    agent.actor_opt.load_state_dict(_torch(state["actor_opt"]))


def _collect(conn, env_fn: Callable[[], gym.Env], spec: dict[str, Any], config: DDPGConfig, index: int,
             count: int, first_episode: int, owned: dict[str, Any] | None) -> None:
    """A collector process: steps its env for each round the learner asks for, until told to stop (None).

    Collector 0 also learns the actor (`owned`: its starting actor, target and optimiser state): after its
    steps of a round it does the round's actor steps against the critic the learner sent, and sends back
    the actor, its target and optimiser state with its transitions.
    """
    import torch

    torch.set_num_threads(1)
    try:
        env = env_fn()
        agent = DDPG(spec["obs_dim"], spec["act_dim"], config)
        if owned is not None:
            load_actor_state(agent, owned)
        episode, obs = first_episode + index, None
        while (order := conn.recv()) is not None:
            actor, normaliser, critic, obs_batches, steps, env_steps, episodes = order
            if owned is None:
                agent.actor.load_state_dict(_torch(actor))
            agent.obs_norm.load_state_dict(_torch(normaliser))
            agent.rng = np.random.default_rng([config.seed, ROUND_STREAM, index, env_steps])
            transitions = []
            for step in range(steps):
                if obs is None:
                    obs, _ = env.reset(seed=episode_seed(config.seed, episode))
                    episode += count
                x = flat_observation(spec, obs)
                agent.epsilon = epsilon_at(config, env_steps + step * count + index, episodes)
                action = agent.act(x, explore=True)
                next_obs, reward, terminated, truncated, info = env.step(
                    env_action(spec, action, env.action_space.dtype))
                transitions.append((obs, x, action, float(reward), next_obs, bool(terminated), bool(truncated),
                                    info))
                obs = None if terminated or truncated else next_obs
            learned = None
            if owned is not None:
                losses = []
                if obs_batches is not None:
                    agent.critic.load_state_dict(_torch(critic))
                    losses = [agent.actor_step(torch.from_numpy(part)).item() for part in obs_batches]
                learned = {**actor_state(agent), "actor_loss": float(np.mean(losses)) if losses else None}
            conn.send((transitions, learned))
        env.close()
    except KeyboardInterrupt:
        pass
    except BaseException as exc:  # noqa: BLE001  (handed to the learner, which raises it)
        conn.send(exc)


class Collectors:
    """N collector processes, each with its own environment from `env_fn`; collector 0 also learns the actor.

    `start_round(agent, steps, env_steps, episodes, obs_batches)` hands the collectors the normaliser and the
    actor, and collector 0 the critic and the normalised observations of its actor steps (None before
    learning starts); `finish_round()` returns each collector's transitions (obs, flat obs, action, reward,
    next obs, terminated, truncated, info), in collector order, and loads the actor that collector 0 learnt
    into `agent`, returning its mean actor loss (None if it took no step).
    """

    def __init__(self, env_fn: Callable[[], gym.Env], spec: dict[str, Any], agent: DDPG, count: int,
                 first_episode: int = 0):
        if count < 1:
            raise ValueError(f"collectors must be >= 1, got {count}")
        context = multiprocessing.get_context("spawn")  # no forked copy of torch or MuJoCo state
        self.count, self.agent, self.conns, self.processes = count, agent, [], []
        for index in range(count):
            here, there = context.Pipe()
            owned = actor_state(agent) if index == 0 else None
            process = context.Process(target=_collect, name=f"collector-{index}", daemon=True,
                                      args=(there, env_fn, spec, agent.config, index, count, first_episode, owned))
            process.start()
            there.close()
            self.conns.append(here)
            self.processes.append(process)
        self._open = False

    def start_round(self, steps: int, env_steps: int, episodes: int,
                    obs_batches: list[np.ndarray] | None = None) -> None:
        """Starts a round of `steps` env steps in all (split as evenly as possible, the first ones more)."""
        actor = _numpy(self.agent.actor) if self.count > 1 else None
        normaliser = _numpy(self.agent.obs_norm)
        critic = _numpy(self.agent.critic) if obs_batches is not None else None
        base, extra = divmod(steps, self.count)
        for index, conn in enumerate(self.conns):
            conn.send((actor, normaliser, critic if index == 0 else None, obs_batches if index == 0 else None,
                       base + (index < extra), env_steps, episodes))
        self._open = True

    def finish_round(self) -> tuple[list[list[tuple]], float | None]:
        """Each collector's transitions of the round and collector 0's mean actor loss; raises what a
        collector raised, or if one died."""
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
        learned = results[0][1]
        load_actor_state(self.agent, learned)
        return [transitions for transitions, _ in results], learned["actor_loss"]

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
