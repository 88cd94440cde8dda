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
