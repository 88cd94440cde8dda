"""One checkpoint format for both learning stacks (auv_mj.agents.checkpoint): every file written is tagged with its
kind, one loader says what a file is, the shipped files written before the tag load unchanged, and the zoo builds
what the kind says."""

import numpy as np
import pytest
import torch

from auv_mj.agents import ppo
from auv_mj.agents.checkpoint import KINDS, OFFPOLICY_FORMAT, PPO_FORMAT, read_checkpoint
from auv_mj.agents.offpolicy import DDPG, TD3, DDPGConfig, Policy, TD3Config, save_agent
from auv_mj.agents.ppo import PPOPolicy
from auv_mj.zoo import registry
from auv_mj.zoo.checkpoints import _checkpoint_dir

SHIPPED = {"depth_executor.pt": "td3", "executor.pt": "executor", "executor_ocean.pt": "td3",
           "planner.pt": "her-ddpg", "planner_e2e.pt": "her-ddpg", "planner_general.pt": "ddpg",
           "planner_memory.pt": "ppo", "planner_route.pt": "ddpg", "planner_tunnel.pt": "her-ddpg"}
"""Each shipped checkpoint written before the kind tag, and the kind its format marker (and agent field) gives it."""
TAGGED = {"planner_learned.pt": "ppo", "planner_learned_3d.pt": "ppo", "planner_learned_3d_no_memory.pt": "ppo",
          "planner_learned_3d_no_teacher.pt": "ppo"}
"""Each shipped checkpoint written since, and the kind its tag says."""
SPEC = {"kind": "box", "obs_dim": 4, "act_dim": 2, "obs_shape": [4], "action_low": [-1.0, -1.0],
        "action_high": [1.0, 1.0]}


def test_shipped_checkpoints_have_no_tag_and_load_by_the_kind_their_format_gives():
    assert sorted(p.name for p in _checkpoint_dir().glob("*.pt")) == sorted({**SHIPPED, **TAGGED})
    for name, kind in SHIPPED.items():
        path = _checkpoint_dir() / name
        raw = torch.load(path, weights_only=True)["metadata"]
        assert "kind" not in raw and raw["format"] == KINDS[kind]  # written before the tag, and left so
        checkpoint = read_checkpoint(path)
        assert checkpoint.kind == kind == checkpoint.metadata["kind"]
        loaded = PPOPolicy.load(path) if kind == "ppo" else Policy.load(path)
        assert isinstance(loaded, PPOPolicy if kind == "ppo" else Policy)
    for name, kind in TAGGED.items():
        raw = torch.load(_checkpoint_dir() / name, weights_only=True)["metadata"]
        assert raw["kind"] == kind and read_checkpoint(_checkpoint_dir() / name).kind == kind
        assert isinstance(PPOPolicy.load(_checkpoint_dir() / name), PPOPolicy)


@pytest.mark.parametrize(("learner", "config", "agent", "kind"), [
    (DDPG, DDPGConfig(hidden_sizes=(8,)), "her-ddpg", "her-ddpg"), (DDPG, DDPGConfig(hidden_sizes=(8,)), None, "ddpg"),
    (TD3, TD3Config(hidden_sizes=(8,)), None, "td3")])
def test_every_offpolicy_checkpoint_written_carries_its_kind(tmp_path, learner, config, agent, kind):
    path = tmp_path / "a.pt"
    save_agent(path, learner(4, 2, config), {"spec": SPEC, **({"agent": agent} if agent else {})})
    raw = torch.load(path, weights_only=True)["metadata"]
    assert (raw["kind"], raw["agent"], raw["format"]) == (kind, kind, OFFPOLICY_FORMAT)
    assert read_checkpoint(path).kind == kind
    with pytest.raises(ValueError, match=f"a.pt is a {kind} checkpoint, not ppo"):
        read_checkpoint(path, "ppo")


def test_a_ppo_checkpoint_carries_its_kind_and_the_one_loader_reads_it(tmp_path):
    config = ppo.PPOConfig(hidden_sizes=(8,))
    model = ppo.build_model(SPEC, config)
    ppo.save_ppo(tmp_path / "p.pt", model, ppo.make_optimizer(model, config), None, config, SPEC, {})
    raw = torch.load(tmp_path / "p.pt", weights_only=True)["metadata"]
    assert (raw["kind"], raw["format"]) == ("ppo", PPO_FORMAT)
    checkpoint = read_checkpoint(tmp_path / "p.pt")
    assert checkpoint.kind == "ppo" and any(k.startswith("model.") for k in checkpoint.tensors)
    assert ppo.read_ppo(tmp_path / "p.pt")[1] == config
    with pytest.raises(ValueError, match="is a ppo checkpoint, not ddpg or td3"):
        read_checkpoint(tmp_path / "p.pt", ("ddpg", "td3"))


@pytest.mark.parametrize(("change", "message"), [
    (lambda m: m.update(format="other/1"), "not an auv-mj checkpoint"),
    (lambda m: m.update(kind="ppo"), "kind 'ppo' is not one of the auv-mj-ddpg/1 kinds"),
    (lambda m: m.update(kind="td3"), "its agent 'ddpg' and its kind 'td3' differ"),
    (lambda m: m.update(kind="sac"), "kind 'sac' is not one of")])
def test_a_foreign_or_inconsistent_tag_is_refused(tmp_path, change, message):
    save_agent(tmp_path / "a.pt", DDPG(4, 2, DDPGConfig(hidden_sizes=(8,))), {"spec": SPEC})
    payload = torch.load(tmp_path / "a.pt", weights_only=True)
    change(payload["metadata"])
    torch.save(payload, tmp_path / "b.pt")
    with pytest.raises(ValueError, match=message):
        read_checkpoint(tmp_path / "b.pt")


def test_the_zoo_runs_a_ppo_checkpoint_path_with_its_memory():
    path = _checkpoint_dir() / "planner_memory.pt"
    assert registry.checkpoint_kind(path) == "ppo"
    env = registry.make_env(str(path), "obstacles", 20_000, arena="random")
    planner = registry.make_policy(str(path), env, task="obstacles")
    time_step = env.reset()
    action = planner.act(time_step)
    assert action.shape == env.action_spec().shape and np.all(np.isfinite(action))
