"""What the commands print and draw for a newcomer (issue 53, item 10): counts in words, honest progress bars and
tables, figures whose labels and tracks can be read."""

from __future__ import annotations

from auv_mj.cli import main
from auv_mj.console import counted


def test_counts_read_as_words(tmp_path, capsys):
    assert (counted(1, "mover"), counted(2, "mover"), counted(0, "unknown obstacle")) == (
        "1 mover", "2 movers", "0 unknown obstacles")
    assert counted(1, "wall box", "wall boxes") == "1 wall box" and counted(3, "box", "boxes") == "3 boxes"
    centreline = tmp_path / "straight.csv"
    centreline.write_text("x,y\n0,0\n100,0\n200,0\n")
    arena = tmp_path / "straight.xml"
    assert main(["tunnel", str(centreline), "--width", "40", "--unknown", "100,6,6,4", "--mover",
                 "150,-10,150,10,0.1,2", "-o", str(arena)]) == 0
    written = capsys.readouterr().out
    assert "1 unknown obstacle, 1 mover, " in written and "1 movers" not in written, written
    assert main(["check-arena", str(arena)]) == 0
    checked = capsys.readouterr().out
    assert "1 unknown obstacle, 1 mover, " in checked and "1 movers" not in checked, checked


# --- the demo on an arena of one's own ------------------------------------------------------------------------------


def test_the_demo_flies_the_general_planner_on_an_arena_of_ones_own_and_says_so(tmp_path, capsys):
    from auv_mj.cli.demo import ARENA_SYSTEM, SYSTEM, demo_policy

    assert demo_policy(None, {}) == (SYSTEM, "")
    assert demo_policy("map-replan", {"arena": "mine.xml"}) == ("map-replan", "")  # asked for: flown
    assert demo_policy(None, {"arena": "mine.xml"})[0] == ARENA_SYSTEM == "planner-general"
    centreline = tmp_path / "short.csv"
    centreline.write_text("x,y\n0,0\n60,0\n")
    arena = tmp_path / "short.xml"
    assert main(["tunnel", str(centreline), "--width", "30", "-o", str(arena)]) == 0
    capsys.readouterr()
    assert main(["demo", "--no-video", "--arena", str(arena), "--out", str(tmp_path / "demo")]) == 0
    out = capsys.readouterr().out
    assert f"flying {ARENA_SYSTEM}" in out and f"--policy {SYSTEM}" in out
    rows = [line.split() for line in out.splitlines() if line.split()[:1] and line.split()[0] in (ARENA_SYSTEM, SYSTEM)]
    assert rows and rows[0][:2] == [ARENA_SYSTEM, "goal"] and all(row[0] != SYSTEM for row in rows), out
