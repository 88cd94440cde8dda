#!/usr/bin/env bash
# One entry point that sets up a fresh machine and runs a job:
#   bash scripts/run.sh demo    the main job: the end-to-end tunnel demo (video + table)
#   bash scripts/run.sh test    the test suite (ruff + pytest)
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
# Put `auv-mj` on PATH: a link in the first writable folder of ~/.local/bin, /usr/local/bin that PATH lists,
# unless PATH already finds this checkout's command or another auv-mj that is not a link of ours.
target="$(cd "$venv/bin" && pwd)/auv-mj"
found="$(command -v auv-mj || true)"
if [ -z "$found" ] || { [ -L "$found" ] && [ "$(readlink -f "$found")" != "$(readlink -f "$target")" ]; }; then
  linked=""
  for dir in "$HOME/.local/bin" /usr/local/bin; do
    case ":$PATH:" in *":$dir:"*) ;; *) continue ;; esac
    if [ -d "$dir" ] && [ -w "$dir" ]; then
      ln -sf "$target" "$dir/auv-mj" && linked="$dir" && echo "auv-mj: linked into $dir (on your PATH)" >&2
      break
    fi
  done
  [ -n "$linked" ] || echo "auv-mj: run '. $venv/bin/activate' to put auv-mj on your PATH" >&2
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
  *) echo "usage: bash scripts/run.sh demo|test [args...]" >&2; exit 2 ;;
esac
