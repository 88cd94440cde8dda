"""`auv-mj manoeuvre` (the scripted zig-zag) and `auv-mj bench`: behaviour and CLI smoke tests."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from auv_mj import SONAR_RANGE, cli
from auv_mj.arenas.arena import load
from auv_mj.sim.manoeuvre import channel_arena, zigzag
from auv_mj.speed import sections

BOW = 0.665


def test_zigzag_switches_at_the_angle_and_sonar_sees_the_channel():
    physics = load(channel_arena(half_width=12.0))
    result = zigzag(physics, duration=40.0, angle_deg=20.0, approach=10.0)
    t, _, y, psi, u, _, r, tau_r = result.track.T
    assert result.switch_times[0] == pytest.approx(10.0)
    assert len(result.switch_times) >= 6
    for switch in result.switch_times[1:]:  # each switch happens as the heading passes +-20 deg
        k = np.searchsorted(t, switch + 0.005)  # the first step with the new yaw moment
        assert abs(math.degrees(psi[k - 1])) == pytest.approx(20.0, abs=0.5)
        assert tau_r[k] == -tau_r[k - 1] and abs(tau_r[k]) == 5.0
        assert np.sign(tau_r[k]) == -np.sign(psi[k - 1])
    assert np.all(result.overshoots > 0) and np.all(result.overshoots < 15)
    assert np.max(np.abs(np.degrees(psi))) == pytest.approx(20.0 + result.overshoots.max(), abs=0.1)
    assert 3.0 < result.period < 15.0 and np.all(np.abs(y) < 12.0) and u[-1] > 2.0
    first = result.sonar[0, 1:]
    assert first[0] == pytest.approx(12.0, abs=1e-6) and first[8] == pytest.approx(12.0, abs=1e-6)
    assert first[4] == SONAR_RANGE
    np.testing.assert_allclose(np.diff(result.sonar[:, 0]), 0.5, atol=1e-9)


def test_manoeuvre_command_prints_track_and_figures():
    out = subprocess.run([sys.executable, "-m", "auv_mj.cli", "manoeuvre", "--duration", "30"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    rows = [line for line in lines if line.strip() and line.split()[0].replace(".", "").isdigit()]
    assert len(rows) == 15 and all(len(row.split()) == 8 + 9 for row in rows)
    assert any(line.startswith("overshoot angles") for line in lines)


def test_bench_quick_writes_json(tmp_path, capsys):
    path = tmp_path / "bench.json"
    assert cli.main(["bench", "--quick", "--repeats", "1", "--json", str(path)]) == 0
    payload = json.loads(path.read_text())
    assert set(payload["sections"]) >= {"physics", "sonar"}
    for measurements in payload["sections"].values():
        assert measurements and all(m["value"] > 0 and math.isfinite(m["value"]) for m in measurements)
    names = [m["name"] for m in payload["sections"]["physics"]]
    assert "hydrodynamic step / plain mj_step" in names
    assert "hydrodynamic step / plain mj_step" in capsys.readouterr().out


def test_bench_sections_are_pluggable():
    """A section added with @section runs with the others (how a "tasks" section plugs in), from Python as from the
    command; an unknown name is refused by both."""
    calls = []

    @sections.section("dummy")
    def dummy(settings: sections.BenchSettings) -> list[sections.Measurement]:
        calls.append(settings.repeats)
        return [sections.Measurement("answer", 42.0, "x")]

    try:
        results = sections.run_bench(["dummy"], sections.BenchSettings(repeats=2))
        assert calls == [2] and results["dummy"][0].value == 42.0
    finally:
        del sections.SECTIONS["dummy"]
    import auv_mj.speed

    assert auv_mj.speed.run_bench is sections.run_bench  # the library's call, as the command makes it
    with pytest.raises(ValueError, match="unknown section"):
        sections.run_bench(["nonexistent"])
    with pytest.raises(SystemExit):
        cli.main(["bench", "--sections", "nonexistent"])
