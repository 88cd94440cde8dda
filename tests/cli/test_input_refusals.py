"""Inputs a newcomer gets wrong are refused in one line that names the problem: a CSV separated by semicolons or
spaces, a video file that is neither .mp4 nor .gif, a vehicle whose mass or inertia no AUV has."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from auv_mj.arenas import layout, tubes, tunnels
from auv_mj.assets import model_path
from auv_mj.sim import vehicle
from auv_mj.sim.physics import AUVPhysics


def one_line(error: BaseException) -> str:
    text = str(error)
    assert "\n" not in text, text
    return text


@pytest.mark.parametrize(("text", "named"), [
    ("0;100;40\n200;100;40\n400;150;40\n", "';'"),
    ("x;y;width\n0;100;40\n200;100;40\n400;150;40\n", "';'"),
    ("0\t100\n200\t100\n400\t150\n", "tabs"),
    ("0 100\n200 100\n400 150\n", "spaces"),
])
def test_a_centreline_csv_with_another_delimiter_is_named(tmp_path, text, named):
    path = tmp_path / "centreline.csv"
    path.write_text(text)
    with pytest.raises(ValueError) as error:
        tunnels.read_centreline(path)
    message = one_line(error.value)
    assert message.startswith(f"{path}: row 1") and named in message and "commas" in message, message


def test_an_open_water_csv_with_semicolons_is_named(tmp_path):
    path = tmp_path / "harbour.csv"
    path.write_text("start;60;300\ngoal;540;300\nbox;pier;300;300;40;10\n")
    with pytest.raises(ValueError) as error:
        layout.read_layout(path)
    message = one_line(error.value)
    assert message.startswith(f"{path}: row 1") and "';'" in message and "commas" in message, message


def test_a_tube_csv_with_semicolons_is_named(tmp_path):
    path = tmp_path / "tube.csv"
    path.write_text("x;y;z\n0;0;-10\n100;0;-20\n")
    with pytest.raises(ValueError) as error:
        tubes.read_centreline(path)
    message = one_line(error.value)
    assert message.startswith(f"{path}: row 1") and "';'" in message, message


def test_comma_separated_files_still_read(tmp_path):
    path = tmp_path / "centreline.csv"
    path.write_text("# a comment; with a semicolon\nx,y,width\n0,100,40\n200,100,40\n400,150,40\n")
    assert len(tunnels.read_centreline(path).points) == 3


@pytest.mark.parametrize("name", ["x.avi", "x.MOV", "x"])
def test_render_refuses_a_video_suffix_it_cannot_write_before_work(tmp_path, name):
    out = tmp_path / name
    done = subprocess.run([sys.executable, "-m", "auv_mj.cli", "render", "--task", "goal", "--policy", "no-such-policy",
                           "-o", str(out)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and "-o " in done.stderr and ".mp4 or .gif" in done.stderr, done.stderr
    assert not out.exists()


def _vehicle_xml(**inertial: str) -> str:
    root = ET.parse(model_path("auv.xml")).getroot()
    element = root.find(".//inertial")
    for key, value in inertial.items():
        element.set(key, value)
    return ET.tostring(root, encoding="unicode")


@pytest.mark.parametrize(("inertial", "field"), [
    ({"mass": "1e-12"}, "mass"),
    ({"mass": "1e9"}, "mass"),
    ({"diaginertia": "1e-12 1e-12 1e-12"}, "inertia"),
    ({"diaginertia": "1e7 1e7 1e7"}, "inertia"),
])
def test_a_vehicle_beyond_physical_bounds_is_refused_naming_file_and_field(tmp_path, inertial, field):
    path = tmp_path / "vehicle.xml"
    path.write_text(_vehicle_xml(**inertial))
    with pytest.raises(ValueError) as error:
        AUVPhysics.from_xml_path(path)
    message = one_line(error.value)
    assert message.startswith(str(path)) and field in message, message


def test_the_bounds_hold_the_shipped_vehicle_and_are_physical():
    low, high = vehicle.MASS_RANGE
    assert 1.0 <= low < 30.48 < high <= 1e5
    low, high = vehicle.GYRATION_RANGE
    assert 0 < low < (3.45 / 30.48) ** 0.5 < high  # REMUS-100: Izz 3.45 kg m^2 on 30.48 kg
    AUVPhysics.from_xml_path(model_path("auv.xml"))


def test_the_triangle_inequality_of_the_principal_moments_is_checked():
    """MuJoCo refuses such an explicit inertia itself; the check covers one it computed or was handed."""
    import numpy as np

    with pytest.raises(ValueError, match="triangle inequality"):
        vehicle.check_inertia(30.0, np.array([0.1, 0.1, 3.0]), "v.xml", "auv")
    vehicle.check_inertia(30.48, np.array([0.177, 3.45, 3.45]), "v.xml", "auv")
