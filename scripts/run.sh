#!/usr/bin/env bash
# One entry point that sets up a fresh machine and runs a job:
#   bash scripts/run.sh demo    the main job: the end-to-end tunnel demo (video + table)
#   bash scripts/run.sh test    the test suite (ruff, import-linter, pytest)
#   bash scripts/run.sh link    (optional) link this checkout's auv-mj into ~/.local/bin
# The first run creates .venv (override with AUV_MJ_VENV) and installs PyTorch (its CPU build without an NVIDIA GPU)
# and auv-mj: `demo` and `link` what auv-mj needs to run, `test` also the test extra (pytest, ruff, Ray, SB3). The
# C kernels are compiled on first use into ~/.cache/auv-mj (AUV_MJ_CACHE moves it).
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${AUV_MJ_VENV:-.venv}"
TORCH_CPU_INDEX="https://download.pytorch.org/whl/cpu"
job="${1:-}"
case "$job" in
  demo|link) want="run" ;;
  test) want="test" ;;
  *) echo "usage: bash scripts/run.sh demo|test|link [args...]" >&2; exit 2 ;;
esac
# The stamp names what the venv holds: "run" (auv-mj) or "test" (auv-mj and its test extra). A stamp of an older
# run.sh is empty: that one always installed the test extra. A venv set up for the tests serves the demo as it is;
# one set up for the demo gets the test extra on the first `test`.
stamp="$venv/.auv-mj-installed"
have=""
if [ -f "$stamp" ]; then have="$(cat "$stamp")"; have="${have:-test}"; fi
if [ "$have" = "test" ]; then want="test"; fi
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || [ "$have" != "$want" ]; then
  if [ "$have" = "run" ]; then
    echo "adding the test extra to $venv (first test run only)..." >&2
  else
    echo "setting up $venv (first run only)..." >&2
  fi
  python3 -m venv "$venv"
  "$venv/bin/python" -m pip install --quiet --upgrade pip
  # PyTorch first, or pip pulls a multi-GB CUDA build. Without an NVIDIA GPU, the CPU build from PyTorch's own CPU
  # wheel index, falling back to the package index; pip shows its progress on these long downloads.
  if ! "$venv/bin/python" -c "import torch" 2>/dev/null; then
    if command -v nvidia-smi >/dev/null 2>&1 && nvidia-smi -L >/dev/null 2>&1; then
      "$venv/bin/python" -m pip install --progress-bar on torch==2.13.0
    else
      echo "installing PyTorch's CPU build (no NVIDIA GPU found)..." >&2
      if "$venv/bin/python" -c "import urllib.request as u; u.urlopen('$TORCH_CPU_INDEX/torch/', timeout=10)" \
          2>/dev/null; then
        "$venv/bin/python" -m pip install --progress-bar on --index-url "$TORCH_CPU_INDEX" torch==2.13.0 \
          || "$venv/bin/python" -m pip install --progress-bar on torch==2.13.0
      else  # PyTorch's index out of reach: the package index's torch (a CPU build where it has one)
        "$venv/bin/python" -m pip install --progress-bar on torch==2.13.0
      fi
    fi
  fi
  extra=""
  if [ "$want" = "test" ]; then extra="[test]"; fi
  echo "installing auv-mj${extra:+ with its test extra} and its dependencies..." >&2
  "$venv/bin/python" -m pip install --progress-bar on -e ".$extra" 2>&1 \
    | { grep -v "^Requirement already satisfied" || true; } >&2
  echo "$want" > "$stamp"
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
shift || true
case "$job" in
  demo) exec "$venv/bin/auv-mj" demo "$@" ;;
  test)
    "$venv/bin/ruff" check .
    "$venv/bin/python" scripts/lint_imports.py --no-logo
    exec "$venv/bin/python" -m pytest -q -n 2 "$@" ;;
esac
