"""The four layers (core < tasks < agents < app) and no import cycle, checked on every import statement."""

import ast
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINKED = ("tasks", "agents", "planners", "models")
"""Top-level folders that are sub-packages of auv_mj (through links in auv_mj/): auv_mj.tasks, ..."""
ABOVE_CORE = ("cli", "zoo", "jobs", "benchmark", "tasks", "agents", "planners")
"""Sub-packages of auv_mj above the simulator core."""


def test_import_linter_contract_is_kept():
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which("lint-imports")
    assert exe, "import-linter is part of the test extras"
    done = subprocess.run([exe], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "3 kept, 0 broken" in done.stdout


def test_contract_names_every_core_module():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = config["contracts"][0]["layers"]
    named = {m.strip() for m in layers[-1].split(":")}
    core = {f"auv_mj.{p.stem}" for p in (ROOT / "auv_mj").glob("*.py") if p.stem != "__init__"}
    core |= {f"auv_mj.{p.name}" for p in (ROOT / "auv_mj").iterdir() if p.is_dir() and p.name not in
             (*ABOVE_CORE, "__pycache__")}
    assert named == core, f"pyproject's core layer misses {core - named} or names gone modules {named - core}"
    inner = {m.strip() for layer in config["contracts"][1]["layers"] for m in layer.split(":")}
    assert inner == core, f"the core's inner contract misses {core - inner} or names gone modules {inner - core}"


def test_core_is_grouped_into_sub_packages():
    """The core's folder shows its architecture: at most 8 modules directly in auv_mj/, the rest grouped."""
    flat = [p.name for p in (ROOT / "auv_mj").glob("*.py")]
    assert len(flat) <= 8, flat
    for group in ("sim", "arenas", "render"):
        assert (ROOT / "auv_mj" / group / "__init__.py").is_file()


def _module(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[0] in LINKED:
        parts = ["auv_mj", *parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path, module: str, known: set[str]) -> set[str]:
    """Project modules imported anywhere in `path` (inside functions too)."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            names = [base] + [f"{base}.{a.name}" for a in node.names]
        found |= {n for n in names if n in known and n != module}
    return found


def test_no_import_cycle_between_files():
    files = {_module(p): p for top in ("auv_mj", *LINKED) for p in (ROOT / top).rglob("*.py")
             if top != "auv_mj" or p.relative_to(ROOT / "auv_mj").parts[0] not in LINKED}
    graph = {m: _imports(p, m, set(files)) for m, p in files.items()}
    # Every module also imports the packages above it (Python runs their __init__ first): leave those
    # edges out, as a package's __init__ importing its own submodules is no cycle of the code.
    graph = {m: {d for d in deps if not m.startswith(d + ".")} for m, deps in graph.items()}
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> None:
        state[node] = 1
        stack.append(node)
        for dep in sorted(graph[node]):
            if state.get(dep) == 1:
                cycle = stack[stack.index(dep):] + [dep]
                raise AssertionError("import cycle: " + " -> ".join(cycle))
            if dep not in state:
                visit(dep)
        stack.pop()
        state[node] = 2

    for module in sorted(graph):
        if module not in state:
            visit(module)
