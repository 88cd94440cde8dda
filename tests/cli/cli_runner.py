"""Running `auv-mj` as a user does, in a subprocess, for the CLI tests: `run(...)` and the check of a refusal."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
AUV_MJ = [sys.executable, "-m", "auv_mj.cli"]
ENV = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),  # this checkout's auv_mj, from any folder
       "PYTHONPATH": os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}


def run(*args, timeout: float = 300, cwd=None) -> subprocess.CompletedProcess:
    """`auv-mj ARGS...` in a subprocess, its output captured."""
    return subprocess.run([*AUV_MJ, *map(str, args)], capture_output=True, text=True, timeout=timeout, env=ENV,
                          cwd=cwd)


def refused(done: subprocess.CompletedProcess, *words: str) -> None:
    """A refusal as the CLI gives it: exit 2, no traceback, and each of `words` on stderr."""
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    assert "Traceback" not in done.stderr
    for word in words:
        assert word in done.stderr, done.stderr
