"""The built wheel carries the MJCF models and the shipped checkpoints, found without the source tree."""

import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_models_are_found_from_an_installed_wheel(tmp_path):
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "--no-build-isolation",
                            "-q", "-w", str(tmp_path / "dist")], capture_output=True, text=True, timeout=300,
                           cwd=tmp_path)
    assert build.returncode == 0, build.stderr
    wheel = next((tmp_path / "dist").glob("auv_mj-*.whl"))
    site = tmp_path / "site"
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        archive.extractall(site)
    assert "auv_mj_models/auv.xml" in names and "auv_mj_models/arenas/tunnel_inspection.xml" in names
    assert "auv_mj/cli/__init__.py" in names and "auv_mj/cli/evaluate.py" in names  # the app ships too
    assert "agents/checkpoints/planner_general.pt" in names
    assert "auv_mj_models/arenas/validation/l_bend.xml" in names
    assert "auv_mj/sim/hydro_kernel.c" in names  # the C step's source, built on first use
    probe = ("import auv_mj, tasks; from auv_mj import AUVPhysics, model_path; "
             "p = AUVPhysics.from_xml_path(model_path('auv.xml')); "
             "print(auv_mj.__file__); print(model_path('arenas/tunnel_inspection.xml')); print(p.sonar()[4]); "
             "p.step(10); print(auv_mj.sim.native.kernel() is not None)")
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120, cwd=tmp_path,
                         env={"PYTHONPATH": str(site), "PATH": "/usr/bin:/bin", "MUJOCO_GL": "egl",
                              "AUV_MJ_CACHE": str(tmp_path / "cache")})
    assert run.returncode == 0, run.stderr
    module, arena, echo, compiled = run.stdout.split()
    assert Path(module).is_relative_to(site) and Path(arena).is_relative_to(site)
    assert float(echo) == 120.0
    assert compiled == "True" and list((tmp_path / "cache").glob("hydro_kernel-*.so"))


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
    assert done.returncode == 2 and "usage" in done.stderr
    assert "setting up" not in done.stderr and "activate" in done.stderr
    demo = subprocess.run(["bash", str(script), "demo", "--x"], capture_output=True, text=True, env=env, timeout=60)
    assert demo.returncode == 0 and demo.stdout.strip() == "ran auv-mj demo --x"
    assert not (home / ".local").exists() and not list(bin_dir.iterdir())
    linked = subprocess.run(["bash", str(script), "link"], capture_output=True, text=True, env=env, timeout=60)
    assert linked.returncode == 0, linked.stderr
    assert (home / ".local" / "bin" / "auv-mj").resolve() == command.resolve()
