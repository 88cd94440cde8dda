"""Loading and reloading the 6-DOF vehicle (`auv_mj.sim.physics3d`, `auv_mj.arenas.arena3d.compose_xml`): what a
reset does, and that the facts read from the compiled model are the MJCF's."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from auv_mj import model_path
from auv_mj.arenas.arena3d import arena_root, compose_xml, seabed
from auv_mj.sim.hydro3d import spec_from_model, spec_from_xml
from auv_mj.sim.physics3d import AUV3DPhysics
from auv_mj.tasks import auv3d, suite


@pytest.mark.parametrize("lag", [False, True])
def test_the_spec_read_from_the_compiled_model_is_the_one_written_in_the_mjcf(lag):
    xml, source = compose_xml(arena_root("bed", [seabed(30.0)], {"path": [0.0, 0.0, -5.0]}), thruster_lag=lag)
    physics = AUV3DPhysics.from_xml_string(xml, source=source)
    assert spec_from_model(physics.model.ptr, source) == spec_from_xml(xml, source) is not None
    assert physics.hydrodynamics.spec == spec_from_xml(model_path("auv6.xml").read_text())


def test_a_vehicle_with_an_unknown_or_no_coefficient_is_refused_by_name():
    xml, _ = compose_xml(None)
    unknown = xml.replace('name="hydro_X_uu"', 'name="hydro_X_uuu"')
    with pytest.raises(ValueError, match=r"mine\.xml: unknown 6-DOF coefficient <numeric name=\"hydro_X_uuu\">"):
        AUV3DPhysics.from_xml_string(unknown, source="mine.xml")
    bare = "".join(line for line in xml.splitlines(keepends=True) if 'name="hydro_' not in line)
    assert bare != xml
    with pytest.raises(ValueError, match="mine.xml: no 6-DOF coefficients.*not an auv-mj vehicle"):
        AUV3DPhysics.from_xml_string(bare, source="mine.xml")
    physics = AUV3DPhysics.from_xml_string(xml)
    with pytest.raises(ValueError, match="mine.xml: unknown 6-DOF coefficient"):
        physics.reload_from_xml_string(unknown, source="mine.xml")


def test_compose_writes_the_arena_into_the_vehicle_and_refuses_other_elements():
    rock = ET.Element("geom", name="rock", type="sphere", size="2", pos="10 0 -5")
    xml, source = compose_xml(arena_root("rocks", [seabed(30.0), rock], {"path": [1.0, 2.0, -3.0]}))
    assert source == "rocks" and "auv-mj arena" not in xml
    physics = AUV3DPhysics.from_xml_string(xml, source=source)
    model = physics.model.ptr
    np.testing.assert_allclose(model.geom("rock").pos, [10.0, 0.0, -5.0])
    np.testing.assert_allclose(model.numeric("path").data, [1.0, 2.0, -3.0])
    assert model.geom("rock").bodyid[0] == 0 and model.geom("hull").bodyid[0] != 0
    bad = arena_root("bad", [ET.Element("camera", name="eye")])
    with pytest.raises(ValueError, match="bad: a 3-D arena's <worldbody> may hold geoms.*got <camera>"):
        compose_xml(bad)


def test_a_reset_builds_no_named_indexers_and_named_follows_the_new_arena():
    env = suite.load(auv3d.DOMAIN, "goal3d", task_kwargs={"arena": "random", "random": 3})
    env.reset()
    physics = env.physics
    assert physics._named is None  # the reset compiled a new arena and read its sensors without them
    before = physics.named.model.geom_pos.axes.row.names
    assert physics.named.data.qpos["root"].shape == (7,)
    np.testing.assert_array_equal(physics.named.data.qpos["root"], physics.data.qpos[:7])
    env.reset()
    assert physics._named is None
    after = physics.named.model.geom_pos.axes.row.names
    assert len(after) == physics.model.ngeom and before != after
