#!/usr/bin/env bash
# One entry point that sets up a fresh machine and runs a job:
#   bash scripts/run.sh demo    the main job: the end-to-end tunnel demo (video + table)
#   bash scripts/run.sh test    the test suite (ruff, import-linter, pytest)
#   bash scripts/run.sh link    (optional) link this checkout's auv-mj into ~/.local/bin
# The first run creates .venv (override with AUV_MJ_VENV) and installs the CPU build of PyTorch and auv-mj.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${AUV_MJ_VENV:-.venv}"
stamp="$venv/.auv-mj-installed"
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  echo "setting up $venv (first run only)..." >&2
  python3 -m venv "$venv"
  "$venv/bin/python" -m pip install --quiet --upgrade pip
  # The CPU build of PyTorch first, or pip pulls a multi-GB CUDA build.
  "$venv/bin/python" -m pip install --quiet torch==2.13.0
  "$venv/bin/python" -m pip install --quiet -e ".[test]"
  touch "$stamp"
fi
# Nothing outside this checkout changes: `auv-mj` lives in $venv/bin. `bash scripts/run.sh link` puts a link to it
# in ~/.local/bin (opt-in, for one checkout you use every day).
if [ "${1:-}" = "link" ]; then
  mkdir -p "$HOME/.local/bin"
  ln -sf "$(cd "$venv/bin" && pwd)/auv-mj" "$HOME/.local/bin/auv-mj"
  echo "auv-mj: linked $HOME/.local/bin/auv-mj -> $(cd "$venv/bin" && pwd)/auv-mj" >&2
  case ":$PATH:" in *":$HOME/.local/bin:"*) ;; *) echo "auv-mj: add $HOME/.local/bin to your PATH" >&2 ;; esac
  exit 0
fi
if [ "$(command -v auv-mj || true)" != "$(cd "$venv/bin" && pwd)/auv-mj" ]; then
  echo "auv-mj: run '. $venv/bin/activate' to put this checkout's auv-mj on your PATH" >&2
fi
export MUJOCO_GL="${MUJOCO_GL:-egl}" PYTHONUNBUFFERED=1
job="${1:-}"
shift || true
case "$job" in
  demo) exec "$venv/bin/auv-mj" demo "$@" ;;
  test)
    "$venv/bin/ruff" check .
    "$venv/bin/lint-imports" --no-cache
    exec "$venv/bin/python" -m pytest -q -n 2 "$@" ;;
  *) echo "usage: bash scripts/run.sh demo|test|link [args...]" >&2; exit 2 ;;
esac
