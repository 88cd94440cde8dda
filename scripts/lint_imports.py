"""Runs import-linter on auv-mj laid out as its wheel lays it out: `python scripts/lint_imports.py [ARGS...]`.

The design card's top-level folders (tasks/, agents/, planners/, models/) become the sub-packages auv_mj.tasks, ...
through the build's own package mapping (`[tool.setuptools.package-dir]` in pyproject.toml), while import-linter
finds a package's modules by walking its one folder. So this lays the package out once more, as hard links (copies
where links cannot be made) in a temporary folder, and runs `lint-imports` there with the project's contracts:
every module is checked under its import name, and each file still has one path in the checkout.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "auv_mj"


def package_folders(root: Path = ROOT) -> dict[str, Path]:
    """Each mapped sub-package of `auv_mj` (its dotted name) -> its folder in the checkout; `auv_mj` itself too."""
    config = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]
    mapped = {name: root / folder for name, folder in config.get("package-dir", {}).items()}
    return {PACKAGE: root / PACKAGE, **mapped}


def lay_out(target: Path, root: Path = ROOT) -> Path:
    """The package's Python files under `target`/auv_mj, at the paths a wheel gives them; returns that folder."""
    for name, folder in package_folders(root).items():
        into = target.joinpath(*name.split("."))
        for source in folder.rglob("*.py"):
            dest = into / source.relative_to(folder)
            dest.parent.mkdir(parents=True, exist_ok=True)
            try:
                os.link(source, dest)
            except OSError:
                shutil.copy2(source, dest)
    return target / PACKAGE


def main(argv: list[str] | None = None) -> int:
    """Lays the package out and runs lint-imports over it with pyproject.toml's contracts; its exit status."""
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which("lint-imports")
    if exe is None:
        print("lint_imports: lint-imports not found; it comes with the test extra (pip install -e '.[test]')",
              file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="auv-mj-layout-") as folder:
        lay_out(Path(folder))
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [folder, os.environ.get("PYTHONPATH")]))}
        args = [exe, "--config", str(ROOT / "pyproject.toml"), "--no-cache", *(argv or [])]
        return subprocess.run(args, cwd=folder, env=env).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
