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
