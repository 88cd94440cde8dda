"""Suite-style evaluation, the policy names, the demo and the report helpers."""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from auv_mj.agents.offpolicy.policy import Policy
from auv_mj.benchmark import runner
from auv_mj.zoo import registry as policies
from experiments.report.fig8 import episodes_to
from experiments.report.training_speed import training_speed

AUV_MJ = [sys.executable, "-m", "auv_mj.cli"]


def test_evaluation_is_deterministic_for_a_seed():
    first = runner.evaluate("splane", ["path_line"], episodes=2, seed=3, max_steps=40, progress=False)
    again = runner.evaluate("splane", ["path_line"], episodes=2, seed=3, max_steps=40, progress=False)
    assert first == again
    other = runner.evaluate("random", ["goal"], episodes=2, seed=3, max_steps=40, progress=False)
    again = runner.evaluate("random", ["goal"], episodes=2, seed=3, max_steps=40, progress=False)
    assert other == again


def test_metrics_of_a_collision_and_of_a_success():
    collided = runner.evaluate("random", ["obstacles"], episodes=1, seed=0, progress=False)
    summary = runner.evaluate("splane", ["goal"], episodes=2, seed=0, progress=False)["tasks"]["goal"]
    assert summary["success_rate"] == 1.0 and summary["collision_rate"] == 0.0
    assert 0 < summary["time_to_goal"] < 600 and summary["path_length"] > 50
    assert math.isinf(summary["min_clearance"]) or summary["min_clearance"] > 5
    assert set(collided["tasks"]) == {"obstacles"}


def test_tracking_metrics_per_disturbance_phase():
    summary = runner.evaluate("splane", ["speed_heading"], 1, 0, progress=False)["tasks"]["speed_heading"]
    for phase in ("instantaneous", "constant", "periodic"):
        assert 0 <= summary[f"mae_speed_{phase}"] < 0.1
        assert 0 <= summary[f"mae_heading_{phase}"] < 0.1
    assert summary["max_speed"] >= summary["mae_speed"]


def test_task_resolution_and_bad_names():
    assert policies.resolve_tasks("goal") == ["goal"]
    assert "speed_heading" not in policies.resolve_tasks("all", "planner")
    assert policies.resolve_tasks("all", "executor") == ["speed_heading"]
    assert set(policies.resolve_tasks("benchmarking")) <= set(policies.resolve_tasks("all"))
    with pytest.raises(ValueError, match="unknown task, tag or domain 'nope'"):
        policies.resolve_tasks("nope")
    env = policies.make_env("splane", "goal", 0)
    with pytest.raises(ValueError, match="unknown policy 'no-such-policy'"):
        policies.make_policy("no-such-policy", env)


def test_eval_cli_writes_json_and_csv(tmp_path):
    out = tmp_path / "out.json"
    done = subprocess.run([*AUV_MJ, "eval", "--policy", "splane", "--task", "path_curve", "--episodes", "1",
                           "--max-steps", "30", "--json", str(out), "--csv", str(tmp_path / "out.csv")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "path_curve" in done.stdout and "success_rate" in done.stdout
    results = json.loads(out.read_text())
    assert set(results["tasks"]["path_curve"]) >= {"success_rate", "collision_rate", "min_clearance",
                                                   "path_length", "time_to_goal", "return", "mae_speed"}
    assert (tmp_path / "out.csv").read_text().startswith("task,")


def test_demo_runs_end_to_end_with_the_baseline(tmp_path):
    env = dict(os.environ)
    env.pop("DISPLAY", None)
    done = subprocess.run([*AUV_MJ, "demo", "--policy", "splane", "--out", str(tmp_path), "--width", "160",
                           "--height", "96", "--fps", "10"], capture_output=True, text=True, timeout=600, env=env)
    assert done.returncode == 0, done.stderr
    assert "Tunnel inspection" in done.stdout and "min_clear_m" in done.stdout
    for name in ("tunnel.mp4", "tunnel_trajectory.png", "tunnel_episode.npz"):
        assert (Path(tmp_path) / name).stat().st_size > 1000


def test_episodes_to_target_success():
    success = np.r_[np.zeros(30), np.ones(30)]
    assert episodes_to(success, 0.9, window=20) == 30 + 18
    assert math.isnan(episodes_to(np.zeros(50), 0.9, window=20))


def _write_log(path: Path, success: np.ndarray, seconds_per_episode: float) -> None:
    rows = ["episode,steps,length,return,success,wall_time"]
    for i, s in enumerate(success, start=1):
        rows.append(f"{i},{100 * i},100,0.0,{s},{seconds_per_episode * i}")
    path.write_text("\n".join(rows) + "\n")


def test_training_speed_ratio_from_peer_logs(tmp_path):
    _write_log(tmp_path / "auv-mj-her-ddpg-seed0.csv", np.r_[np.zeros(10), np.ones(30)], 2.0)
    _write_log(tmp_path / "sb3-ddpg-her-seed0.csv", np.r_[np.zeros(10), np.ones(30)], 6.0)
    lines: list[str] = []
    training_speed(lines, tmp_path)
    report = "\n".join(lines)
    # both reach 90 % over 20 episodes at episode 10 + 18 = 28: 56 s vs 168 s
    assert "| auv-mj HER-DDPG | auv-mj-her-ddpg-seed0 | 56 | 2800 |" in report
    assert "= **3.00**" in report

    _write_log(tmp_path / "auv-mj-collectors1-seed0.csv", np.r_[np.zeros(10), np.ones(30)], 1.0)
    _write_log(tmp_path / "sb3-ddpg-her-seed0.csv", np.zeros(40), 6.0)
    lines = []
    training_speed(lines, tmp_path)
    report = "\n".join(lines)
    # A peer that never reaches the target gets no time ratio: that would be a learning figure read as speed.
    assert "SB3 DDPG+HER in 0 of 1 runs" in report and "no time ratio is drawn" in report
    assert "wall-clock to the target =" not in report
    # 100 steps per episode: 50, 100 and 16.7 env steps/s
    assert "auv-mj / SB3 = **3.00** in one process each, and **6.00** with a collector" in report
    assert "**2.00** over our serial loop" in report


def test_eval_gives_an_executor_checkpoint_the_observation_it_was_trained_on(tmp_path):
    from auv_mj.agents.offpolicy import Policy
    from auv_mj.agents.offpolicy.ddpg import DDPGConfig
    from auv_mj.agents.offpolicy.train import train
    from auv_mj.cli.train import make_env_fn, task_env_id
    from auv_mj.tasks.speed_heading import run_executor

    kwargs = {"command": "random", "disturbances": "random", "observation": "integral"}
    env_fn = make_env_fn(task_env_id("speed_heading"), task_kwargs=kwargs, max_episode_steps=50)
    config = DDPGConfig(learning_starts=20, train_every=10, batch_size=16, hidden_sizes=(16, 16))
    ckpt = train(env_fn, "executor", config, total_steps=100, run_dir=tmp_path / "run", progress=False,
                 tensorboard=False).checkpoint
    assert Policy.load(ckpt).obs_dim == 9
    summary = runner.evaluate(str(ckpt), ["speed_heading"], 1, 0, max_steps=150,
                                progress=False)["tasks"]["speed_heading"]
    executor_mae = run_executor(policies.learned_executor(ckpt), time_limit=15.0)["none"]
    assert summary["mae_speed_none"] == pytest.approx(executor_mae[0])  # same episode through either path
    assert summary["mae_heading_none"] == pytest.approx(executor_mae[1])


def test_eval_task_kwargs_reach_every_episode_and_bad_ones_are_named():
    from auv_mj.control.splane import SPlaneController
    from auv_mj.tasks.speed_heading import rollout

    kwargs = {"command": "random", "disturbances": "random", "reward": "paper"}
    results = runner.evaluate("splane", ["speed_heading"], 2, seed=5, max_steps=40, progress=False,
                                task_kwargs=kwargs)
    assert results["task_kwargs"] == kwargs
    returns = []
    for seed in (5, 6):  # Eq. 30 from the same seeded episodes, run outside evaluate
        trace = rollout(SPlaneController(), random=seed, time_limit=4.0, **kwargs)
        returns.append(-np.sum(np.abs(trace["speed_error"]) + np.abs(trace["heading_error"])))
    assert results["tasks"]["speed_heading"]["return"] == pytest.approx(np.mean(returns))
    default = runner.evaluate("splane", ["speed_heading"], 2, seed=5, max_steps=40, progress=False)
    assert default["tasks"]["speed_heading"]["return"] > 0  # the suite reward is in [0, 1]
    with pytest.raises(ValueError, match="task 'speed_heading' has no option 'bogus'"):
        runner.evaluate("splane", ["speed_heading"], 1, max_steps=5, progress=False, task_kwargs={"bogus": 1})
    with pytest.raises(ValueError, match="'random' is set by --seed"):
        runner.evaluate("splane", ["speed_heading"], 1, progress=False, task_kwargs={"random": 1})
    done = subprocess.run([*AUV_MJ, "eval", "--policy", "splane", "--task", "speed_heading", "--episodes", "1",
                           "--task-kwargs", '{"bogus": 1}'], capture_output=True, text=True, timeout=300)
    assert done.returncode != 0 and "Traceback" not in done.stderr
    assert "auv-mj eval: error: task 'speed_heading' has no option 'bogus'" in done.stderr


def test_demo_table_prints_a_contact_clearance_as_zero():
    from auv_mj.cli.demo import format_rows

    table = format_rows({"splane": {"min_clear_m": -0.001, "track_mae_m": 1.234, "time_s": math.nan}})
    row = table.splitlines()[-1].split()
    assert row == ["splane", "0.00", "1.23", "nan"]


def test_the_eval_table_shows_the_safety_violations_of_episodes_that_reached_the_goal():
    """An episode can reach its goal after coming within d_s of a wall: the table's safety column says so (the JSON's
    `safety_violation_rate`, by its one definition in `metrics.summarise`), beside the outcome "goal"."""
    from auv_mj.benchmark.metrics import summarise
    from auv_mj.cli.evaluate import format_table

    rows = [{"seed": s, "success": True, "outcome": "goal", "collision": False, "safety_violation": violated,
             "min_clearance": clearance, "path_length": 700.0, "time_to_goal": 350.0, "duration": 350.0,
             "return": 2500.0} for s, violated, clearance in ((0, True, 1.08), (1, False, 6.5))]
    summary = summarise(rows)
    table = format_table({"policy": "planner-general", "episodes": 2, "seed": 0, "tasks": {"tunnel": summary}})
    header, rule, row = table.splitlines()[1:4]
    assert len(header) == len(rule) == len(row) - len("goal 2") + len("outcomes")  # the columns line up
    cells = dict(zip(header.split()[1:-1], row.split()[1:], strict=False))
    assert cells["safety_violation_rate"] == "0.500" and cells["min_clearance"] == "1.080"
    assert row.split()[-2:] == ["goal", "2"]


@pytest.mark.parametrize("command", ["train", "eval"])
@pytest.mark.parametrize(("text", "message"), [("x", "not valid JSON"), ("[1]", "must be a JSON object")])
def test_task_kwargs_that_are_not_a_json_object_are_usage_errors(command, text, message):
    args = ["executor", "--task", "speed_heading"] if command == "train" else ["--policy", "splane"]
    done = subprocess.run([*AUV_MJ, command, *args, "--task-kwargs", text], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert f"argument --task-kwargs: {message}" in done.stderr and repr(text) in done.stderr


def test_progress_bars_redraw_rarely_off_a_terminal(monkeypatch):
    import io

    from auv_mj.console import progress_bar

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    for stream, interval in ((io.StringIO(), 10.0), (Terminal(), 0.1)):
        monkeypatch.setattr(sys, "stderr", stream)
        with progress_bar(total=3, desc="bar") as bar:
            assert bar.mininterval == interval
        assert "bar:   0%" in stream.getvalue()  # drawn on stderr


class ZeroResidual:
    """A residual executor's policy that never corrects: with it the executor must be the S-plane exactly."""

    obs_dim = 17
    metadata = {"run_info": {"task_kwargs": {"observation": "history", "residual": 0.5}}}

    def __init__(self):
        self.inputs = []

    def __call__(self, obs):
        self.inputs.append(np.asarray(obs))
        return np.zeros(2)


def test_a_deployed_residual_executor_with_zero_correction_drives_a_planning_task_as_the_splane():
    from auv_mj.episode import record_episode
    from auv_mj.planners.guidance import line_of_sight
    from auv_mj.tasks import suite

    low, high = np.array([-20.0, -10.0]), np.array([20.0, 10.0])
    runs = []
    for executor in (None, policies.LearnedExecutor(ZeroResidual(), low, high)):
        kwargs = {"random": 10_003, "conditions": "ocean"} | ({"executor": executor} if executor else {})
        env = suite.load("auv", "obstacles", task_kwargs=kwargs)
        runs.append(record_episode(env, line_of_sight(env), max_steps=60))
    np.testing.assert_array_equal(runs[0].control, runs[1].control)
    np.testing.assert_array_equal(runs[0].pose, runs[1].pose)
    assert len(executor.policy.inputs) > 100 and all(x.shape == (17,) for x in executor.policy.inputs)


def test_executors_by_name_on_planning_tasks():
    splane = runner.run_episode("splane", "path_line", 0, {}, max_steps=80)
    named = runner.run_episode("splane", "path_line", 0, {"executor": "splane"}, max_steps=80)
    assert named == splane  # the default executor, asked for by name
    retuned = runner.run_episode("splane", "path_line", 0, {"executor": "splane-ocean"}, max_steps=80)
    assert retuned == runner.run_episode("splane-ocean", "path_line", 0, {}, max_steps=80)
    assert retuned["return"] != splane["return"] and retuned["path_length"] != splane["path_length"]
    with pytest.raises(ValueError, match="executor 'warp': not one of"):
        runner.run_episode("splane", "path_line", 0, {"executor": "warp"}, max_steps=5)
    with pytest.raises(ValueError, match="runs the learned executor 'executor'; leave 'executor' out"):
        runner.run_episode("two-layer", "goal", 0, {"executor": "splane"}, max_steps=5)


def test_the_ocean_gains_lower_the_ocean_tuning_cost_and_not_the_ideal_one():
    from auv_mj.control.splane import OCEAN_GAINS, SPlaneGains
    from experiments.splane_tuning import tuning_cost

    assert tuning_cost(OCEAN_GAINS, conditions="ocean") < 0.8 * tuning_cost(SPlaneGains(), conditions="ocean")
    assert tuning_cost(SPlaneGains()) < tuning_cost(OCEAN_GAINS)  # each set is best in the water it was tuned in


def test_the_shipped_ocean_executor_is_rebuilt_from_its_checkpoint_on_every_task():
    from auv_mj.tasks.speed_heading import GAIN_NAMES

    meta = Policy.load(policies.shipped_checkpoint("ocean-executor")).metadata
    assert meta["agent"] == "td3" and meta["run_info"]["task_kwargs"]["conditions"] == "ocean"
    env, policy = policies.env_and_policy("ocean-executor", "speed_heading", 10_000, {"conditions": "ocean"})
    assert env.action_spec().shape == (len(GAIN_NAMES),)  # the gain-scheduling task it was trained on
    time_step = env.reset()
    assert policy(time_step).shape == (len(GAIN_NAMES),)
    executor = policies.named_executor("ocean-executor")
    assert executor.memory.gains == meta["run_info"]["task_kwargs"]["gains"]
    m = runner.run_episode("splane", "goal", 10_000, {"conditions": "ocean", "executor": "ocean-executor"},
                             max_steps=30)
    assert m["path_length"] > 10.0  # the vehicle moves under the planner's guidance on this executor


def test_the_general_two_layer_system_runs_on_the_best_learned_executor_and_the_e2e_one_on_the_papers():
    shipped = {name: Policy.load(policies.shipped_checkpoint(name)).metadata
               for name in ("ocean-executor", "executor")}
    for name, executor in (("two-layer-general", "ocean-executor"), ("two-layer-e2e", "executor")):
        env, _ = policies.env_and_policy(name, "goal", 20_000, {})
        assert isinstance(env.task.executor, policies.LearnedExecutor)
        assert env.task.executor.policy.metadata == shipped[executor]
    env, _ = policies.env_and_policy("planner-general", "goal", 20_000, {})
    assert not isinstance(env.task.executor, policies.LearnedExecutor)  # the S-plane


def test_the_general_planner_slows_to_the_reference_speed_whenever_an_echo_is_close_ahead():
    from auv_mj.episode import record_episode
    from auv_mj.planners.avoidance import PROTECTIONS, SLOW_CONE
    from auv_mj.sim.sonar import BEAM_ANGLES

    assert policies.POLICIES["planner-general"].protection == "speed-aware"
    field = PROTECTIONS["speed-aware"]
    env, policy = policies.env_and_policy("planner-general", "obstacles", 3, {})  # a random layout
    record = record_episode(env, policy)
    ahead = record.sonar[:-1][:, np.abs(BEAM_ANGLES) <= SLOW_CONE + 1e-9].min(axis=1)  # what each step saw
    close = ahead < field.slow_distance
    assert record.succeeded and close.sum() >= 5  # the scenario puts obstacles in its way
    assert np.all(record.command[close, 0] <= field.reference_speed + 1e-9)
    assert np.any(record.command[~close, 0] > field.reference_speed + 0.2)  # and it does cruise faster elsewhere


@pytest.mark.parametrize("name", ["planner-learned", "planner-learned-3d-no-memory", "planner-learned-3d-no-teacher"])
def test_the_shipped_3d_students_fly_on_the_held_fan_their_checkpoints_name(name):
    """The learned 3-D planner and its two ablations were trained on observation="fan-held" (the fan filtered over
    pings, `FanFilter`) over the 3-D benchmark's executor: each checkpoint names both, the zoo builds the task with
    them (an env on the plain fan would feed the network other inputs), and the deterministic policy acts within
    the action box from the first step of a hard ocean tube."""
    from auv_mj.agents.ppo.checkpoint import read_ppo

    checkpoint = policies.shipped_checkpoint(name, "tunnel3d")
    options = read_ppo(checkpoint)[0].metadata["spec"]["task_options"]
    assert options == {"executor": "splane-ocean", "observation": "fan-held"}
    env, policy = policies.env_and_policy(name, "tunnel3d", 14_000, {"tier": "hard", "conditions": "ocean"})
    assert env.task.observation_kind == "fan-held" and env.task.fan_filter is not None
    time_step = env.reset()
    for _ in range(5):
        action = policy(time_step)
        assert np.all(np.abs(action) <= 1.0) and action.shape == env.action_spec().shape
        time_step = env.step(action)
