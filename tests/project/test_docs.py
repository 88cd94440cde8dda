"""The README and docs/ stay true to the code: the policy table (docs/policies.md) is the registry's, the layout
(docs/layout.md) names every part of the core and only paths that exist, every relative link (and its #anchor)
resolves, and the README's Python examples run."""

import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
POLICIES_PAGE = ROOT / "docs" / "policies.md"
LAYOUT_PAGE = ROOT / "docs" / "layout.md"
PAGES = [README, *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
"""A Markdown link's target: `[text](target)`."""


def _block(name: str, page: Path) -> str:
    """The page's text between `<!-- name -->` and `<!-- /name -->`."""
    text = page.read_text()
    match = re.search(rf"<!-- {name} -->\n(.*?)\n<!-- /{name} -->", text, re.S)
    assert match, f"{page.relative_to(ROOT)} has no <!-- {name} --> ... <!-- /{name} --> block"
    assert len(re.findall(rf"<!-- {name} -->", "".join(p.read_text() for p in PAGES))) == 1, \
        f"the <!-- {name} --> block must be on one page only"
    return match.group(1)


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces as hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)  # a `# comment` in a code block is no heading
    return {_slug(line.lstrip("#")) for line in text.splitlines() if re.match(r"#{1,6} ", line)}


def test_the_docs_policy_table_is_the_registry_s():
    """docs/policies.md's copy is `auv-mj policies --markdown`; refresh it from there when a policy is registered."""
    from auv_mj.zoo.registry import POLICIES, markdown_table

    block = _block("policies", POLICIES_PAGE)
    assert block == markdown_table(), \
        "docs/policies.md's policy table is stale: paste `auv-mj policies --markdown` over it"
    listed = re.findall(r"^\| `([^`]+)` \|", block, re.M)
    assert sorted(listed) == sorted(POLICIES)


def test_auv_mj_policies_markdown_prints_the_table(capsys):
    from auv_mj.cli import main
    from auv_mj.zoo.registry import markdown_table

    assert main(["policies", "--markdown"]) in (0, None)
    assert capsys.readouterr().out.strip() == markdown_table()


def test_the_layout_names_every_part_of_the_core_and_every_layer():
    block = _block("layout", LAYOUT_PAGE)
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    core = {m.strip() for m in config["contracts"][0]["layers"][-1].split(":")}
    for module in sorted(core):
        name = module.split(".", 1)[1]
        assert (f"`auv_mj/{name}/`" in block or f"`auv_mj/{name}.py`" in block or f"`{name}`" in block
                or f"`{module}`" in block), \
            f"docs/layout.md's layout does not name {module}"
    for folder in ("auv_mj/cli/", "agents/", "tasks/", "planners/", "auv_mj/zoo/", "auv_mj/jobs/",
                   "auv_mj/benchmark/", "experiments/report/", "models/"):
        assert f"`{folder}`" in block, folder


def test_the_layout_names_only_paths_that_exist():
    paths = re.findall(r"`((?:auv_mj|agents|tasks|planners|models|tests|docs|experiments)/[\w/.-]*)`",
                       _block("layout", LAYOUT_PAGE))
    assert len(paths) >= 8
    missing = [p for p in paths if not (ROOT / p).exists()]
    assert not missing, f"docs/layout.md's layout names paths that do not exist: {missing}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_and_anchors_resolve(page):
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
    broken = []
    for target in LINK.findall(text):
        if re.match(r"[a-z]+:", target):
            continue  # http(s), mailto: outside the repository
        path, _, anchor = target.partition("#")
        linked = (page.parent / path).resolve() if path else page
        if not linked.exists():
            broken.append(target)
        elif anchor and linked.suffix == ".md" and anchor not in _anchors(linked):
            broken.append(target)
    assert not broken, f"{page.name}: links that do not resolve: {broken}"


def test_the_readme_python_api_examples_run(tmp_path):
    """The README's Python API section runs as written (its blocks in order, as one script), in a fresh process from
    an empty folder: named policies, a suite cell and a suite with workers, the metrics, a leaderboard of one's own."""
    import subprocess
    import sys

    text = README.read_text()
    section = text[text.index("## Python API"):]
    section = section[:section.index("\n## ", 1)]
    code = "\n".join(re.findall(r"```python\n(.*?)```", section, re.S))
    assert "run_suite" in code and "publish" in code and "load_policy" in section
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    board = tmp_path / "my_board"
    assert (board / "leaderboard.json").is_file() and (board / "leaderboard.md").is_file()
    lines = done.stdout.splitlines()
    assert lines[-1].startswith("| `los-fast` | suite v1 | 6 |")  # its own row: six cells, one episode each


def test_the_readme_gymnasium_examples_run(tmp_path):
    """The README's Gymnasium section (one env, then the batched env) runs as written, in a fresh process."""
    import subprocess
    import sys

    text = README.read_text()
    section = text[text.index("## Gymnasium"):]
    section = section[:section.index("\n## ", 1)]
    code = "\n".join(re.findall(r"```python\n(.*?)```", section, re.S))
    assert "gym.make(" in code and "gym.make_vec(" in code
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("['achieved_goal', 'desired_goal', 'observation']")
    assert lines[0].endswith("(720, 1280, 3)")
    assert lines[-1] == "AUVVectorEnv (256,) (256, 17)"
