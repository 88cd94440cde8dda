"""Evaluation spread over local processes and over Ray: the same JSON as the serial loop, and no finished
episode lost when a worker dies. One local Ray session (2 CPUs) serves the whole module."""

from __future__ import annotations

import functools
import json
import os
import pickle
import subprocess
import sys
from pathlib import Path

import pytest

from auv_mj.benchmark import metrics, runner
from auv_mj.cli import main
from auv_mj.jobs import distributed

AUV_MJ = [sys.executable, "-m", "auv_mj.cli"]
TASK, POLICY, EPISODES, SEED, MAX_STEPS = "goal", "random", 3, 5, 12
"""Small episodes: the point is the bookkeeping, not the driving."""


@pytest.fixture(scope="module")
def ray_session():
    import ray

    # Workers import this module to unpickle `dies_on`; they see the driver's PYTHONPATH.
    path = os.pathsep.join([str(Path(__file__).parent), *sys.path])
    ray.init(num_cpus=2, include_dashboard=False, runtime_env={"env_vars": {"PYTHONPATH": path}})
    yield ray
    ray.shutdown()


@pytest.fixture(scope="module")
def serial():
    return runner.evaluate(POLICY, [TASK], EPISODES, SEED, MAX_STEPS, progress=False)


def dies_on(marker_dir: str, doomed_seed: int, deaths: int, policy_name, task_name, seed, task_kwargs, max_steps):
    """run_episode, except that the episode seeded `doomed_seed` kills its process on its first `deaths` runs
    (the runs are counted in files under `marker_dir`, since each run is a new process)."""
    if seed == doomed_seed:
        runs = len(list(Path(marker_dir).glob(f"run-{seed}-*")))
        (Path(marker_dir) / f"run-{seed}-{runs}").touch()
        if runs < deaths:
            os._exit(17)
    return runner.run_episode(policy_name, task_name, seed, task_kwargs, max_steps)


def _dump(results: dict) -> str:
    return json.dumps(results, indent=2, allow_nan=False)


def test_workers_and_ray_give_the_serial_json(tmp_path, serial, ray_session):
    out = tmp_path / "workers.json"
    done = subprocess.run([*AUV_MJ, "eval", "--policy", POLICY, "--task", TASK, "--episodes", str(EPISODES),
                           "--seed", str(SEED), "--max-steps", str(MAX_STEPS), "--workers", "2", "--json", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert out.read_text() == _dump(serial)
    bars = [line for line in done.stderr.splitlines() if "%|" in line]
    assert bars and all(line.startswith("eval 1 task(s):") for line in bars)  # one bar across the workers
    assert f"{EPISODES}/{EPISODES}" in bars[-1]
    on_ray = runner.evaluate(POLICY, [TASK], EPISODES, SEED, MAX_STEPS, progress=False, ray_address="local")
    assert _dump(on_ray) == _dump(serial)
    assert ray_session.is_initialized()  # the module's session was used, not shut down


@pytest.mark.parametrize("where", ["workers", "ray"])
def test_a_dead_worker_loses_no_finished_episode(tmp_path, serial, ray_session, where):
    options = {"workers": 2} if where == "workers" else {"ray_address": "local"}
    doomed = SEED + 1
    (tmp_path / "once").mkdir()
    retried = runner.evaluate(POLICY, [TASK], EPISODES, SEED, MAX_STEPS, progress=False, retries=1,
                                episode_fn=functools.partial(dies_on, str(tmp_path / "once"), doomed, 1),
                                **options)
    assert _dump(retried) == _dump(serial)  # died once, rerun, nothing lost or changed

    (tmp_path / "always").mkdir()
    failed = runner.evaluate(POLICY, [TASK], EPISODES, SEED, MAX_STEPS, progress=False, retries=1,
                               episode_fn=functools.partial(dies_on, str(tmp_path / "always"), doomed, 99),
                               **options)
    assert [(f["task"], f["episode"], f["seed"]) for f in failed["failed"]] == [(TASK, 1, doomed)]
    runs = len(list((tmp_path / "always").glob("run-*")))
    assert runs == (2 if where == "ray" else 3)  # Ray: 1 + 1 retry; pool: in the pool, then alone twice
    kept = [runner.run_episode(POLICY, TASK, s, {}, MAX_STEPS) for s in (SEED, SEED + 2)]
    assert failed["tasks"][TASK] == metrics.summarise(kept)


def test_cli_reports_a_failed_episode_and_still_writes_the_rest(tmp_path, monkeypatch, capsys):
    # Episodes that raise on one task: the other task's episodes are kept, the failures named, exit 1.
    monkeypatch.setattr(runner, "run_episode", functools.partial(raises_on, "speed_heading"))
    out = tmp_path / "r.json"
    status = main(["eval", "--policy", "splane", "--task", "all", "--episodes", "1", "--max-steps", "5",
                   "--workers", "2", "--no-progress", "--json", str(out)])
    results = json.loads(out.read_text())
    assert status == 1
    assert results["tasks"]["speed_heading"] == {"episodes": 0,
                                                 "outcomes": {"goal": 0, "collision": 0, "left_map": 0,
                                                              "timeout": 0}}
    others = [task for task in results["tasks"] if task != "speed_heading"]
    assert others and all(results["tasks"][task]["episodes"] == 1 for task in others)
    assert results["failed"] == [{"task": "speed_heading", "episode": 0, "seed": 0,
                                  "error": "RuntimeError: no speed_heading today"}]
    assert "episode 0 of speed_heading (seed 0) failed: RuntimeError: no speed_heading today" in \
        capsys.readouterr().err


def raises_on(bad_task, policy_name, task_name, seed, task_kwargs, max_steps):
    """run_episode, except that it raises on `bad_task`."""
    if task_name == bad_task:
        raise RuntimeError(f"no {bad_task} today")
    return runner.run_episode(policy_name, task_name, seed, task_kwargs, max_steps)


def test_bad_options_are_refused():
    with pytest.raises(ValueError, match="retries must be >= 0"):
        list(distributed.run_jobs(print, [()], retries=-1))
    done = subprocess.run([*AUV_MJ, "eval", "--policy", "splane", "--task", "goal", "--ray", "auto",
                           "--workers", "2"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "--workers sets the CPUs of --ray local only" in done.stderr


POINT_GOAL = "test_agents:auv_mj_test/PointGoal-v0"
"""The tiny goal task of tests/agents/test_agents.py, registered by importing that module (also in Ray workers)."""
TINY = {"hidden_sizes": [16, 16], "learning_starts": 64, "buffer_size": 2000, "epsilon_decay": 100,
        "batch_size": 16}


def _log(run_dir: Path) -> list[list[str]]:
    """progress.csv without the wall-time column."""
    rows = (run_dir / "progress.csv").read_text().splitlines()
    return [row.split(",")[:-1] for row in rows]


def test_a_two_trial_sweep_trains_like_train_and_resumes(tmp_path, ray_session):
    from auv_mj.agents.offpolicy.ddpg import DDPGConfig
    from auv_mj.agents.offpolicy.train import train
    from auv_mj.cli import sweep
    from auv_mj.cli.train import make_env_fn

    out = tmp_path / "sweep"
    rows = sweep.run_sweep(out, ["her-ddpg"], [0], {"noise_std": [0.1, 0.3]}, task=POINT_GOAL, base=TINY,
                           steps=200, progress=False)
    names = ["her-ddpg-noise_std=0.1-seed0", "her-ddpg-noise_std=0.3-seed0"]
    assert [row["trial"] for row in rows] == names
    assert all(row["env_steps"] == 200 and row["episodes"] == 6 for row in rows)  # 6 whole, a 7th cut
    with open(out / "results.csv") as f:
        assert [line.split(",")[0] for line in f.read().splitlines()] == ["trial", *names]
    # each trial is the run `train` makes of the same configuration, in its own directory
    config = DDPGConfig(**{**TINY, "hidden_sizes": (16, 16)}, noise_std=0.3, seed=0)
    alone = train(make_env_fn(POINT_GOAL), "her-ddpg", config, total_steps=200, run_dir=tmp_path / "alone",
                  progress=False, tensorboard=False)
    assert _log(out / names[1]) == _log(alone.run_dir)
    assert _log(out / names[0]) != _log(alone.run_dir)

    with pytest.raises(FileExistsError, match="add --resume"):
        sweep.run_sweep(out, ["her-ddpg"], [0], {"noise_std": [0.1, 0.3]}, task=POINT_GOAL, base=TINY, steps=200)
    with pytest.raises(ValueError, match="other seeds"):
        sweep.run_sweep(out, ["her-ddpg"], [1], {"noise_std": [0.1, 0.3]}, task=POINT_GOAL, base=TINY, steps=200,
                        resume=True)
    longer = sweep.run_sweep(out, ["her-ddpg"], [0], {"noise_std": [0.1, 0.3]}, task=POINT_GOAL, base=TINY,
                             steps=300, resume=True, progress=False)
    assert [row["env_steps"] for row in longer] == [300, 300]
    assert _log(out / names[1])[:7] == _log(alone.run_dir)  # the first 200 steps' episodes are kept


def test_sweep_cli_refuses_bad_grids_and_seeds(tmp_path, capsys):
    for argv, message in (
            (["--grid", '{"no_such": [1]}'], "--grid field 'no_such' is not a DDPGConfig field"),
            (["--grid", '{"seed": [1, 2]}'], "give the seeds with --seeds"),
            (["--grid", '{"batch_size": [0]}'], "--grid batch_size=0"),
            (["--seeds", "3-1"], "empty seed range"),
            (["--workers", "2", "--ray", "auto"], "--workers sets the CPUs of --ray local only")):
        with pytest.raises(SystemExit) as exit_:
            main(["sweep", "ddpg", "--task", POINT_GOAL, "--out", str(tmp_path / "s"), *argv])
        assert exit_.value.code == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "s").exists()


def test_without_ray_the_ray_jobs_name_the_extra(monkeypatch, capsys):
    """Ray is an extra: where it is missing, `--ray` and the library's Ray jobs say which extra to install."""
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` raises ImportError
    with pytest.raises(ImportError, match=r"auv-mj\[ray\]"):
        distributed.require_ray()
    with pytest.raises(ImportError, match=r"auv-mj\[ray\]"):
        list(distributed.run_jobs(abs, [(1,)], ray_address="local"))
    with pytest.raises(SystemExit) as refused:
        main(["eval", "--policy", "splane", "--task", "goal", "--episodes", "1", "--ray", "local"])
    assert refused.value.code == 2 and "auv-mj[ray]" in capsys.readouterr().err


UNGUARDED = """import sys
from auv_mj.benchmark import SUITE_V1, run_suite
from auv_mj.benchmark.runner import evaluate

results = run_suite("los-fast", [c for c in SUITE_V1 if c.water == "ideal"][:2], episodes=1, max_steps=10,
                    workers=2, progress=False)
run = evaluate("random", ["goal"], episodes=3, seed=5, max_steps=12, workers=2, progress=False)
print(len(results["cells"]), run["tasks"]["goal"]["episodes"], file=sys.stdout)
"""


@pytest.mark.parametrize("how", ["script", "module"])
def test_a_script_that_starts_workers_runs_as_written_without_a_main_guard(tmp_path, how):
    """The README's examples with `workers=2`, pasted into a script with no `if __name__ == "__main__":`: the workers
    do not run the script again (which would start the run again in each), so it prints its results and nothing
    on stderr; as `python script.py` and as `python -m script`."""
    (tmp_path / "unguarded.py").write_text(UNGUARDED)
    command = [sys.executable, "unguarded.py"] if how == "script" else [sys.executable, "-m", "unguarded"]
    root = str(Path(__file__).resolve().parents[2])
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
           "PYTHONPATH": os.pathsep.join([root, *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=tmp_path, env=env)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["2", "3"]
    assert done.stderr == "", done.stderr  # no "bootstrapping phase", no leaked semaphores


def test_workers_still_run_the_main_script_where_the_jobs_need_what_it_defines(monkeypatch):
    """Only jobs that need nothing of the main script start their workers without it; a function of `__main__` (a
    script's own episode function) keeps the usual rule, for which the script needs its `__main__` guard."""
    assert not distributed._uses_main_script(runner.run_episode, [("random", "goal", 0, {}, 5)])

    def own_episode(*job):
        return job

    own_episode.__module__, own_episode.__qualname__ = "__main__", "own_episode"
    monkeypatch.setattr(sys.modules["__main__"], "own_episode", own_episode, raising=False)
    assert b"__main__" in pickle.dumps(own_episode)  # it pickles, by its module's name
    assert distributed._uses_main_script(own_episode, [])
    assert distributed._uses_main_script(runner.run_episode, [("random", "goal", 0, {"fn": own_episode}, 5)])
