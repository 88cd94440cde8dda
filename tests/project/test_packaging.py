"""The built wheel is one package, `auv_mj`, with its models, checkpoints and leaderboard; the run script."""

import os
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_an_installed_wheel_is_one_package_with_its_data(tmp_path):
    """The wheel installs everything under `auv_mj` (nothing under a generic top-level name) with the MJCF models,
    the shipped checkpoints and the published leaderboard; run from a folder holding a user's own `tasks` and
    `agents` packages, `import auv_mj` registers the Gymnasium ids, and the benchmark gives time efficiency against
    the published oracle."""
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "--no-build-isolation",
                            "-q", "-w", str(tmp_path / "dist")], capture_output=True, text=True, timeout=300,
                           cwd=tmp_path)
    assert build.returncode == 0, build.stderr
    wheel = next((tmp_path / "dist").glob("auv_mj-*.whl"))
    site = tmp_path / "site"
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        archive.extractall(site)
    tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"auv_mj"}, tops
    for name in ("auv_mj/models/auv.xml", "auv_mj/models/arenas/tunnel_inspection.xml",
                 "auv_mj/models/arenas/validation/l_bend.xml", "auv_mj/agents/checkpoints/planner_general.pt",
                 "auv_mj/tasks/suite.py", "auv_mj/planners/map_planner.py", "auv_mj/zoo/registry.py",
                 "auv_mj/benchmark/data/leaderboard.json", "auv_mj/cli/evaluate.py",
                 "auv_mj/sim/hydro_kernel.c"):
        assert name in names, name
    user = tmp_path / "user_project"  # a user's own packages named like ours were before
    for package in ("tasks", "agents"):
        (user / package).mkdir(parents=True)
        (user / package / "__init__.py").write_text("raise ImportError('a user package was imported')\n")
    probe = ("import auv_mj, gymnasium; from auv_mj import AUVPhysics, model_path; "
             "p = AUVPhysics.from_xml_path(model_path('auv.xml')); "
             "print(auv_mj.__file__); print(model_path('arenas/tunnel_inspection.xml')); print(p.sonar()[4]); "
             "p.step(10); print(auv_mj.sim.native.kernel() is not None); "
             "env = gymnasium.make('auv_mj/Goal-v0'); env.reset(seed=0); print(env.unwrapped.task_name); "
             "from auv_mj.benchmark import SUITE_V1, run_cell; "
             "r = run_cell('los-fast', SUITE_V1[0], 1, max_steps=4, progress=False); "
             "print(r['summary']['time_efficiency'], r['summary']['time_efficiency_episodes'])")
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=300, cwd=user,
                         env={"PYTHONPATH": f"{user}:{site}", "PATH": "/usr/bin:/bin", "MUJOCO_GL": "egl",
                              "AUV_MJ_CACHE": str(tmp_path / "cache")})
    assert run.returncode == 0, run.stderr
    module, arena, echo, compiled, task, efficiency, scored = run.stdout.split()
    assert Path(module).is_relative_to(site) and Path(arena).is_relative_to(site)
    assert float(echo) == 120.0
    assert compiled == "True" and list((tmp_path / "cache").glob("hydro_kernel-*.so"))
    assert task == "goal"
    assert efficiency == "0.0" and scored == "1"  # cut at 4 steps: no success, but scored against the oracle
    # the reproduction's sections and data are a checkout's (experiments/, docs/runs): from the wheel it says so
    env = {"PYTHONPATH": f"{user}:{site}", "PATH": "/usr/bin:/bin", "MUJOCO_GL": "egl"}
    refused = subprocess.run([sys.executable, "-m", "auv_mj.cli", "reproduce", "-o", "report.md"], capture_output=True,
                             text=True, timeout=120, cwd=user, env=env)
    assert refused.returncode == 2 and "AUV_MJ_EXPERIMENTS" in refused.stderr and "clone" in refused.stderr
    assert not (user / "report.md").exists()


def test_run_script_changes_nothing_outside_its_checkout(tmp_path):
    """`scripts/run.sh` links nothing into HOME or a PATH folder unless asked (`link`), and says how to activate.
    Run on a copy of the script in a checkout whose (stand-in) venv is set up, so nothing is installed."""
    checkout, home, bin_dir = tmp_path / "checkout", tmp_path / "home", tmp_path / "bin"
    for folder in (checkout / "scripts", checkout / ".venv" / "bin", home, bin_dir):
        folder.mkdir(parents=True)
    (checkout / "pyproject.toml").write_text((ROOT / "pyproject.toml").read_text())
    script = checkout / "scripts" / "run.sh"
    script.write_text((ROOT / "scripts" / "run.sh").read_text())
    command = checkout / ".venv" / "bin" / "auv-mj"
    command.write_text("#!/bin/sh\necho ran auv-mj \"$@\"\n")
    command.chmod(0o755)
    (checkout / ".venv" / ".auv-mj-installed").touch()  # after pyproject.toml: set up, nothing to install
    env = {"HOME": str(home), "PATH": f"{home}/.local/bin:{bin_dir}:/usr/bin:/bin"}
    done = subprocess.run(["bash", str(script), "nothing"], capture_output=True, text=True, env=env, timeout=60)
    assert done.returncode == 2 and "usage" in done.stderr and "setting up" not in done.stderr
    demo = subprocess.run(["bash", str(script), "demo", "--x"], capture_output=True, text=True, env=env, timeout=60)
    assert demo.returncode == 0 and demo.stdout.strip() == "ran auv-mj demo --x"
    assert "setting up" not in demo.stderr and "activate" in demo.stderr
    assert not (home / ".local").exists() and not list(bin_dir.iterdir())
    linked = subprocess.run(["bash", str(script), "link"], capture_output=True, text=True, env=env, timeout=60)
    assert linked.returncode == 0, linked.stderr
    assert (home / ".local" / "bin" / "auv-mj").resolve() == command.resolve()


def test_the_demo_installs_auv_mj_alone_and_the_first_test_run_adds_the_test_extra(tmp_path):
    """`run.sh demo` installs auv-mj without its test extra (Ray, pyarrow, pandas, SB3: 0.6 GB it does not use);
    `run.sh test` installs the extra, in a fresh venv or on top of the demo's, once; a venv set up for the tests
    (or by an older run.sh, whose stamp is empty) serves the demo as it is; a newer pyproject.toml installs again
    what the venv holds. A stand-in `python3` (and the venv's python, auv-mj, ruff, lint-imports) logs each call."""
    checkout, stubs, venv = tmp_path / "checkout", tmp_path / "stubs", tmp_path / "checkout" / ".venv"
    for folder in (checkout / "scripts", stubs, venv / "bin"):
        folder.mkdir(parents=True)
    (checkout / "pyproject.toml").write_text((ROOT / "pyproject.toml").read_text())
    (checkout / "scripts" / "run.sh").write_text((ROOT / "scripts" / "run.sh").read_text())
    log = tmp_path / "calls.log"
    for stub in (stubs / "python3", *(venv / "bin" / name for name in ("python", "auv-mj", "ruff", "lint-imports"))):
        stub.write_text(f'#!/bin/bash\necho "$(basename "$0") $*" >> {log}\nexit 0\n')
        stub.chmod(0o755)
    env = {"HOME": str(tmp_path), "PATH": f"{stubs}:/usr/bin:/bin"}
    stamp = venv / ".auv-mj-installed"

    def run(job: str) -> tuple[list[str], str]:
        log.write_text("")
        done = subprocess.run(["bash", str(checkout / "scripts" / "run.sh"), job], capture_output=True, text=True,
                              env=env, timeout=60)
        assert done.returncode == 0, done.stderr
        return [line for line in log.read_text().splitlines() if " -e " in line], done.stderr

    installs, _ = run("demo")
    assert installs == ["python -m pip install --progress-bar on -e ."] and stamp.read_text().strip() == "run"
    assert run("demo")[0] == []
    installs, said = run("test")
    assert installs == ["python -m pip install --progress-bar on -e .[test]"] and "adding the test extra" in said
    assert stamp.read_text().strip() == "test" and run("test")[0] == [] and run("demo")[0] == []
    future = stamp.stat().st_mtime + 10
    os.utime(checkout / "pyproject.toml", (future, future))
    assert run("demo")[0] == ["python -m pip install --progress-bar on -e .[test]"]  # the extra stays
    stamp.write_text("")  # set up by an older run.sh, which always installed the test extra
    os.utime(stamp, (future + 10, future + 10))
    assert run("demo")[0] == [] and run("test")[0] == []
