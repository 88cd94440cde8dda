"""The five layers (core < tasks < policies < library < app) and no import cycle, checked on every import
statement; the package mapping that makes the design card's top-level folders sub-packages of auv_mj, without links."""

import ast
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
import lint_imports  # noqa: E402  (scripts/lint_imports.py, the test command's import-linter run)

MAPPED = {name.split(".", 1)[1]: folder for name, folder in
          tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"].items()}
"""Sub-packages of auv_mj kept in top-level folders (pyproject's package-dir): "tasks" -> "tasks", ..."""
ABOVE_CORE = ("cli", "zoo", "jobs", "speed", "benchmark", "tasks", "agents", "planners")
"""Sub-packages of auv_mj above the simulator core."""


def test_the_design_cards_folders_are_mapped_packages_and_the_tree_has_no_link():
    assert MAPPED == {"tasks": "tasks", "agents": "agents", "planners": "planners", "models": "models"}
    tracked = subprocess.run(["git", "ls-files", "-s"], cwd=ROOT, capture_output=True, text=True, check=True)
    links = [line.split("\t")[-1] for line in tracked.stdout.splitlines() if line.startswith("120000")]
    assert links == [], f"symbolic links in the tree: {links}"
    import auv_mj.planners.map_planner
    import auv_mj.tasks.suite
    assert Path(auv_mj.tasks.suite.__file__).resolve() == ROOT / "tasks" / "suite.py"
    assert Path(auv_mj.planners.map_planner.__file__).resolve() == ROOT / "planners" / "map_planner.py"


def test_import_linter_contracts_are_kept_on_the_wheels_layout():
    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "lint_imports.py")], cwd=ROOT,
                          capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "4 kept, 0 broken" in done.stdout


def test_import_linter_sees_a_mapped_folders_import_upward(tmp_path):
    """A task module that imports the zoo (layer 4) breaks the layers contract: the mapped folders are checked."""
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which("lint-imports")
    package = lint_imports.lay_out(tmp_path)
    goal = package / "tasks" / "goal.py"
    text = goal.read_text()
    goal.unlink()  # a hard link to the checkout's file: replace it, never write through it
    goal.write_text(text + "\nimport auv_mj.zoo.registry  # noqa\n")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    done = subprocess.run([exe, "--config", str(ROOT / "pyproject.toml"), "--no-cache"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=180)
    assert done.returncode != 0 and "auv_mj.tasks.goal -> auv_mj.zoo.registry" in done.stdout, done.stdout
    assert "import auv_mj.zoo" not in (ROOT / "tasks" / "goal.py").read_text()


def test_contract_names_every_core_module():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = config["contracts"][0]["layers"]
    named = {m.strip() for m in layers[-1].split(":")}
    core = {f"auv_mj.{p.stem}" for p in (ROOT / "auv_mj").glob("*.py") if p.stem != "__init__"}
    core |= {f"auv_mj.{p.name}" for p in (ROOT / "auv_mj").iterdir() if p.is_dir() and p.name not in
             (*ABOVE_CORE, "__pycache__")}
    core |= {f"auv_mj.{name}" for name in MAPPED if name not in ABOVE_CORE}
    assert named == core, f"pyproject's core layer misses {core - named} or names gone modules {named - core}"
    # siblings of a layer are joined by ":" or, where they must not import each other, by "|"
    inner = {m.strip() for layer in config["contracts"][1]["layers"] for m in re.split(r"[:|]", layer)}
    assert inner == core, f"the core's inner contract misses {core - inner} or names gone modules {inner - core}"


def test_core_is_grouped_into_sub_packages():
    """The core's folder shows its architecture: at most 8 modules directly in auv_mj/, the rest grouped."""
    flat = [p.name for p in (ROOT / "auv_mj").glob("*.py")]
    assert len(flat) <= 8, flat
    for group in ("sim", "arenas", "render"):
        assert (ROOT / "auv_mj" / group / "__init__.py").is_file()


def _module(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[0] in MAPPED.values():
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
    files = {_module(p): p for top in ("auv_mj", *MAPPED.values()) for p in (ROOT / top).rglob("*.py")}
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


def _layer_of(module: str, layers: list[list[str]]) -> int | None:
    """Index of `module`'s layer in the layers contract, top (the app) first; None for the root package."""
    for index, group in enumerate(layers):
        if any(module == name or module.startswith(name + ".") for name in group):
            return index
    return None


def test_no_module_names_a_layer_above_it_by_string():
    """Names resolve once, at the top: no module holds a "module" or "module:function" string of a layer above its
    own (an import by string that import-linter cannot see). Declared entry points (pyproject.toml) are how a lower
    layer finds plugins."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = [[m.strip() for m in group.split(":")] for group in config["contracts"][0]["layers"]]
    named = re.compile(r"(auv_mj(?:\.\w+)+)(?::\w+)?")
    found = []
    for top in ("auv_mj", *MAPPED.values()):
        for path in (ROOT / top).rglob("*.py"):
            module = _module(path)
            own = _layer_of(module, layers)
            if own is None:
                continue
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Constant) and isinstance(node.value, str):
                    match = named.fullmatch(node.value.strip())
                    other = _layer_of(match.group(1), layers) if match else None
                    if other is not None and other < own:
                        found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.value!r}")
    assert not found, "strings naming a layer above their module:\n" + "\n".join(found)
