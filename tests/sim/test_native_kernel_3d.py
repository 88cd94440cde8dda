"""The C 6-DOF step (`hydro3d_kernel.c`) against its Python reference (`Hydro3D.bind`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auv_mj import model_path
from auv_mj.arenas.arena3d import compose_xml
from auv_mj.sim import native3d
from auv_mj.sim.physics3d import AUV3DPhysics, set_pose


def trajectory(native: bool, lagged: bool = False) -> np.ndarray:
    if lagged:
        xml, source = compose_xml(None, thruster_lag=True)
        physics = AUV3DPhysics.from_xml_string(xml, source=source)
    else:
        physics = AUV3DPhysics.from_xml_path(model_path("auv6.xml"))
    if not native:
        physics.hydrodynamics.bind_native = lambda *args, **kwargs: None
        physics._bound = None  # rebind: the Python loop
    physics.model.opt.wind[:] = (0.3, -0.2, 0.0)
    set_pose(physics, (0.0, 0.0, -20.0), roll=0.1, pitch=0.05, nu=(1.2, 0.1, 0.0, 0.0, 0.0, 0.05))
    physics.disturbance = lambda t: np.array([0.0, 2.0 * math.sin(t), -1.0, 0.0, 0.0, 0.5])
    rows = []
    for k in range(150):
        physics.set_control([10.0, 0.3 * math.sin(k / 15), 0.3 * math.cos(k / 10)])  # beyond the fin limits too
        physics.step(10)
        rows.append(np.concatenate([physics.position(), physics.attitude(), physics.fins, physics.body_velocity()]))
    return np.array(rows)


@pytest.mark.parametrize("lagged", [False, True])
def test_the_c_step_follows_the_python_reference(lagged):
    assert native3d.kernel() is not None  # the machine has a C compiler: the C step is the default
    fast, reference = trajectory(True, lagged), trajectory(False, lagged)
    assert np.ptp(reference[:, :3], axis=0).max() > 10.0
    np.testing.assert_allclose(fast, reference, rtol=0, atol=1e-9)
