"""Outside policies end to end through the CLI: a module's factory on PYTHONPATH (`--policy MODULE:FACTORY`) and a
Stable-Baselines3 model trained on our Gymnasium id (`--policy model.zip`), with their refusals."""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

AUV_MJ = [sys.executable, "-m", "auv_mj.cli"]

FACTORIES = textwrap.dedent('''
    """A user's policies, as an outside package would write them."""
    import numpy as np

    SEEN = []

    def ahead(env):
        """Full speed ahead on a constant heading command."""
        shape = env.action_spec().shape

        def policy(time_step):
            SEEN.append(np.asarray(time_step.observation["desired_goal"]).copy())
            return np.full(shape, 0.5)
        return policy

    def seeded(env, seed):
        rng = np.random.default_rng(seed)
        return lambda time_step: rng.uniform(-1, 1, env.action_spec().shape)

    def wrong_shape(env):
        return lambda time_step: np.zeros(7)

    def not_finite(env):
        return lambda time_step: np.full(env.action_spec().shape, np.nan)

    def raises(env):
        raise RuntimeError("needs a GPU")

    def not_callable(env):
        return 3

    CONSTANT = 5
''')


@pytest.fixture
def user_module(tmp_path):
    (tmp_path / "user_policies.py").write_text(FACTORIES)
    (tmp_path / "broken_module.py").write_text("import not_a_real_package_xyz\n")
    return tmp_path


def _run(tmp_path, *args, timeout=300):
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([*AUV_MJ, *map(str, args)], capture_output=True, text=True, timeout=timeout, env=env,
                          cwd=tmp_path)


def _refused(done, *words):
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    assert "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1, done.stderr
    for word in words:
        assert word in done.stderr, done.stderr


def test_a_module_factory_runs_through_eval(user_module):
    out = user_module / "r.json"
    done = _run(user_module, "eval", "--policy", "user_policies:ahead", "--task", "goal", "--episodes", "2",
                "--max-steps", "30", "--no-progress", "--json", out)
    assert done.returncode == 0, done.stderr
    result = json.loads(out.read_text())
    summary = result["tasks"]["goal"]
    assert summary["episodes"] == 2 and result["policy"] == "user_policies:ahead"
    assert summary["path_length"] > 1.0  # it moved under its own actions


def test_the_factory_sees_the_episode_the_seed_gives(user_module):
    """The first-action check resets the env once; the episode after it is the seed's own episode."""
    sys.path.insert(0, str(user_module))
    try:
        import user_policies

        from auv_mj.benchmark.runner import run_episode
        from auv_mj.tasks import suite
        from auv_mj.zoo import registry as policies

        policies.env_and_policy("user_policies:ahead", "goal", 10_000)  # the check's reset
        user_policies.SEEN.clear()
        run_episode("user_policies:ahead", "goal", 10_000, max_steps=3)
        fresh = suite.load("auv", "goal", task_kwargs={"random": 10_000}).reset()
        np.testing.assert_array_equal(user_policies.SEEN[0], fresh.observation["desired_goal"])
        other = run_episode("user_policies:seeded", "goal", 10_001, max_steps=20)
        again = run_episode("user_policies:seeded", "goal", 10_001, max_steps=20)
        assert other == again  # the factory got the episode seed
    finally:
        sys.path.remove(str(user_module))


@pytest.mark.parametrize(("name", "words"), [
    ("user_policies:wrong_shape", ["shape (7,)", "shape (2,)"]),
    ("user_policies:not_finite", ["non-finite"]),
    ("user_policies:raises", ["factory raised RuntimeError: needs a GPU"]),
    ("user_policies:not_callable", ["returned int", "not a callable"]),
    ("user_policies:missing", ["has no attribute 'missing'"]),
    ("user_policies:CONSTANT", ["not a factory"]),
    ("broken_module:make", ["does not import", "not_a_real_package_xyz"]),
    ("no_such_module:make", ["does not import", "no_such_module"]),
])
def test_bad_outside_policies_are_usage_errors(user_module, name, words):
    _refused(_run(user_module, "eval", "--policy", name, "--task", "goal", "--episodes", "1", "--no-progress",
                  timeout=120), *words)


def test_a_factory_runs_on_render_and_plot(user_module):
    done = _run(user_module, "plot", "trajectory", "--policy", "user_policies:ahead", "--task", "goal",
                "--max-steps", "20", "-o", user_module / "t.png")
    assert done.returncode == 0, done.stderr
    assert (user_module / "t.png").stat().st_size > 0
    _refused(_run(user_module, "render", "--policy", "user_policies:wrong_shape", "--task", "goal", "-o",
                  user_module / "v.mp4", timeout=120), "shape (7,)")


TRAIN_SB3 = textwrap.dedent('''
    import sys
    import gymnasium as gym
    import torch
    from stable_baselines3 import TD3
    import auv_mj.tasks  # registers the auv_mj ids
    torch.set_num_threads(1)
    model = TD3("MultiInputPolicy", gym.make("auv_mj/Goal-v0"), learning_starts=100, seed=0,
                policy_kwargs={"net_arch": [32, 32]})
    model.learn(total_timesteps=300)
    model.save(sys.argv[1])
''')


def test_a_stable_baselines3_model_runs_through_eval(tmp_path):
    model = tmp_path / "model.zip"
    (tmp_path / "train.py").write_text(TRAIN_SB3)
    trained = subprocess.run([sys.executable, tmp_path / "train.py", model], capture_output=True, text=True,
                             timeout=300, cwd=tmp_path)
    assert trained.returncode == 0, trained.stderr
    out = tmp_path / "r.json"
    done = _run(tmp_path, "eval", "--policy", model, "--task", "goal", "--episodes", "2", "--max-steps", "30",
                "--no-progress", "--json", out)
    assert done.returncode == 0, done.stderr
    summary = json.loads(out.read_text())["tasks"]["goal"]
    assert summary["episodes"] == 2 and sum(summary["outcomes"].values()) == 2

    # Its actions are the model's own on the adapter's observation.
    from auv_mj.tasks.gym_adapter import gym_spaces
    from auv_mj.zoo import outside
    from auv_mj.zoo import registry as policies

    env, act = policies.env_and_policy(str(model), "goal", 10_000)
    time_step = env.reset()
    expected, _ = outside.load_sb3(model).predict(gym_spaces(env)[2](time_step.observation), deterministic=True)
    np.testing.assert_allclose(act(time_step), expected)

    _refused(_run(tmp_path, "eval", "--policy", model, "--task", "speed_heading", "--episodes", "1",
                  "--no-progress", timeout=120), "observation space", "Dict(", "does not fit the task's Box(")
    (tmp_path / "junk.zip").write_text("not a model")
    _refused(_run(tmp_path, "eval", "--policy", tmp_path / "junk.zip", "--task", "goal", "--no-progress",
                  timeout=120), "not a zip file")
    _refused(_run(tmp_path, "eval", "--policy", tmp_path / "none.zip", "--task", "goal", "--no-progress",
                  timeout=120), "no Stable-Baselines3 model file")
