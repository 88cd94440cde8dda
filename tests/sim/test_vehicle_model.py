"""The vehicle model as a component: bad input, disturbances g_0 (Eq. 3), step semantics, shipped files."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from dm_control.rl.control import PhysicsError
from vehicle_reference import ReferenceAUV, read_numerics

from auv_mj import AUVPhysics, Disturbance, model_path, models_dir

X_UU = read_numerics()["X_uu"]


def new_physics() -> AUVPhysics:
    return AUVPhysics.from_xml_path(model_path("auv.xml"))


def vehicle_tree() -> ET.Element:
    return ET.parse(model_path("auv.xml")).getroot()


def write(tmp_path, root_or_text, name="vehicle.xml"):
    path = tmp_path / name
    path.write_text(root_or_text if isinstance(root_or_text, str) else ET.tostring(root_or_text, "unicode"))
    return path


def rotation(psi: float) -> np.ndarray:
    """R(psi) of Eq. (2)."""
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def state(physics: AUVPhysics) -> tuple:
    return physics.data.qpos.copy(), physics.data.qvel.copy(), physics.time()


# --- bad input ------------------------------------------------------------------------------------------

def test_missing_coefficient_names_field_and_file(tmp_path):
    root = vehicle_tree()
    custom = root.find("custom")
    custom.remove(custom.find("numeric[@name='hydro_Y_vv']"))
    path = write(tmp_path, root)
    with pytest.raises(ValueError, match="hydro_Y_vv") as error:
        AUVPhysics.from_xml_path(path)
    assert str(path) in str(error.value)


@pytest.mark.parametrize("data", ["abc", "nan", "1 2", ""])
def test_bad_coefficient_value_names_field_and_file(tmp_path, data):
    root = vehicle_tree()
    root.find("custom/numeric[@name='hydro_N_rr']").set("data", data)
    path = write(tmp_path, root)
    with pytest.raises(ValueError, match="hydro_N_rr") as error:
        AUVPhysics.from_xml_path(path)
    assert str(path) in str(error.value)


def test_unknown_coefficient_and_string_source_are_named():
    root = vehicle_tree()
    ET.SubElement(root.find("custom"), "numeric", name="hydro_X_vv", data="1")
    with pytest.raises(ValueError, match=r"my-vehicle.*hydro_X_vv"):
        AUVPhysics.from_xml_string(ET.tostring(root, "unicode"), source="my-vehicle")


def test_non_positive_mass_matrix_is_rejected(tmp_path):
    root = vehicle_tree()
    root.find("custom/numeric[@name='hydro_Y_rdot']").set("data", "100")  # coupling beyond sqrt(m_22 m_33)
    with pytest.raises(ValueError, match="positive definite"):
        AUVPhysics.from_xml_path(write(tmp_path, root))


@pytest.mark.parametrize("text", ["<mujoco><worldbody>", "not xml at all", ""])
def test_broken_xml_file_names_the_file(tmp_path, text):
    path = write(tmp_path, text, "broken.xml")
    with pytest.raises(ValueError, match="broken.xml"):
        AUVPhysics.from_xml_path(path)


def test_missing_file_names_the_file(tmp_path):
    with pytest.raises(ValueError, match="nowhere.xml"):
        AUVPhysics.from_xml_path(tmp_path / "nowhere.xml")


def test_model_mujoco_rejects_names_the_file(tmp_path):
    root = vehicle_tree()
    ET.SubElement(root.find("worldbody"), "geom", type="nonsense")
    path = write(tmp_path, root, "uncompilable.xml")
    with pytest.raises(ValueError, match="uncompilable.xml"):
        AUVPhysics.from_xml_path(path)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_control_is_rejected_and_changes_nothing(bad):
    physics = new_physics()
    physics.set_control([10.0, 2.0])
    physics.step(50)
    before = state(physics)
    ctrl_before = physics.data.ctrl.copy()
    with pytest.raises(ValueError, match="tau_r"):
        physics.set_control([5.0, bad])
    np.testing.assert_array_equal(physics.data.ctrl, ctrl_before)
    physics.data.ctrl[0] = bad  # written behind set_control's back
    with pytest.raises(ValueError, match="tau_u"):
        physics.step(10)
    after = state(physics)
    np.testing.assert_array_equal(after[0], before[0])
    np.testing.assert_array_equal(after[1], before[1])
    assert after[2] == before[2]


def test_diverging_state_raises_physics_error():
    """A state MuJoCo rejects (|qvel| > 1e10) raises dm_control's PhysicsError, as dm_control's step does."""
    physics = new_physics()
    physics.data.qvel[0] = 1e11
    with pytest.raises(PhysicsError, match="BADQVEL"):
        physics.step(5)


# --- disturbances ---------------------------------------------------------------------------------------

def one_step_velocity(psi: float, world_force: np.ndarray, timestep: float) -> np.ndarray:
    """qvel after one Euler step from rest at heading psi: dt (R M R^T)^-1 F (joint-space Eq. 3)."""
    mass = ReferenceAUV.from_xml().mass_matrix()
    return timestep * rotation(psi) @ np.linalg.solve(mass, rotation(psi).T @ world_force)


@pytest.mark.parametrize("frame", ["world", "body"])
def test_force_from_rest_accelerates_through_the_full_mass_matrix(frame):
    """At psi = 90 deg a 30 N force along world x pushes the vehicle sideways (sway + yaw via Y_rdot); the
    same force in the body frame pushes it ahead, along world y."""
    psi, wrench = math.pi / 2, np.array([30.0, 0.0, 4.0])
    physics = new_physics()
    with physics.reset_context():
        physics.data.qpos[2] = psi
    physics.add_disturbance(wrench, frame=frame)
    physics.step()
    world = wrench if frame == "world" else rotation(psi) @ wrench
    np.testing.assert_allclose(physics.data.qvel, one_step_velocity(psi, world, 0.01), atol=1e-12)


def test_constant_world_force_gives_the_closed_form_terminal_drift():
    """30 N along the heading: the surge balance 30 + X_uu |u| u = 0 gives u = sqrt(30 / -X_uu)."""
    psi = 0.6
    direction = np.array([math.cos(psi), math.sin(psi)])
    runs = {}
    for frame, force in (("world", 30.0 * direction), ("body", (30.0, 0.0))):
        physics = new_physics()
        with physics.reset_context():
            physics.data.qpos[2] = psi
        physics.add_disturbance(force, frame=frame)
        physics.step(4000)
        runs[frame] = physics
        velocity = physics.data.qvel[:2]
        assert velocity @ direction == pytest.approx(math.sqrt(30.0 / -X_UU), rel=1e-3)
        assert abs(direction[0] * velocity[1] - direction[1] * velocity[0]) < 1e-9
        assert abs(physics.data.qvel[2]) < 1e-9
    np.testing.assert_allclose(runs["world"].data.qpos, runs["body"].data.qpos, atol=1e-9)


def test_body_frame_force_turns_with_the_vehicle():
    """Spun to a new heading, the vehicle feels a body-frame force rotated with it, a world one not."""
    for frame in ("world", "body"):
        physics = new_physics()
        physics.set_control([0.0, 8.0])
        physics.step(300)
        physics.set_control([0.0, 0.0])
        disturbance = physics.add_disturbance((0.0, 25.0, 0.0), start=physics.time(), frame=frame)
        physics.forward()
        with_force = physics.data.qacc.copy()
        physics.remove_disturbance(disturbance)
        physics.forward()
        psi, push = physics.pose()[2], with_force - physics.data.qacc
        world = np.array([0.0, 25.0, 0.0]) if frame == "world" else rotation(psi) @ [0.0, 25.0, 0.0]
        mass = rotation(psi) @ ReferenceAUV.from_xml().mass_matrix() @ rotation(psi).T
        assert psi > 0.5
        np.testing.assert_allclose(push, np.linalg.solve(mass, world), atol=1e-10)


def test_windowed_force_acts_only_inside_its_window():
    physics = new_physics()
    physics.add_disturbance((30.0, 0.0), start=1.0, duration=2.0)
    surge = []
    while physics.time() < 5.0 - 1e-9:
        physics.step()
        surge.append((physics.time(), physics.data.qvel[0]))
    times, u = np.array(surge).T
    assert np.all(u[times <= 1.0 + 1e-9] == 0.0)
    inside = (times > 1.0 + 1e-9) & (times <= 3.0 + 1e-9)
    assert np.all(np.diff(u[inside]) > 0)
    assert np.all(np.diff(u[times > 3.0 + 1e-9]) < 0)
    assert u[inside][0] == pytest.approx(one_step_velocity(0.0, np.array([30.0, 0, 0]), 0.01)[0], rel=1e-12)


def test_periodic_force_and_removal():
    """The periodic disturbance of Sec. 4.2, (0, 25 sin(0.01 pi t)), and taking disturbances back."""
    disturbance = Disturbance(lambda t: (0.0, 25.0 * math.sin(0.01 * math.pi * t)))
    np.testing.assert_allclose(disturbance.world_wrench(50.0, 1.0), [0.0, 25.0, 0.0])
    physics, alone = new_physics(), new_physics()
    for p in (physics, alone):
        p.add_disturbance(disturbance)
    later = physics.add_disturbance((5.0, 0.0), start=100.0)
    physics.step(1000)
    alone.step(1000)
    assert physics.data.qvel[1] > 0.01
    np.testing.assert_array_equal(physics.data.qpos, alone.data.qpos)  # `later` not yet active
    physics.remove_disturbance(later)
    physics.clear_disturbances()
    speed = physics.speed()
    physics.step(100)
    assert physics.speed() < speed  # only drag left
    with pytest.raises(ValueError, match="frame"):
        physics.add_disturbance((1.0, 0.0), frame="ned")
    with pytest.raises(ValueError, match="finite"):
        physics.add_disturbance((math.nan, 0.0))


def test_disturbance_added_after_forward_is_applied_once():
    """forward() already applied the forces of the step to come; a change of disturbance must replace
    them, not add to them."""
    physics = new_physics()
    physics.forward()
    physics.add_disturbance((30.0, 0.0))
    physics.step()
    np.testing.assert_allclose(physics.data.qvel, one_step_velocity(0.0, np.array([30.0, 0, 0]), 0.01),
                               atol=1e-12)
    physics.forward()
    physics.clear_disturbances()
    u = physics.data.qvel[0]
    physics.step()
    assert physics.data.qvel[0] < u  # drag only, no leftover push


# --- step semantics and copies --------------------------------------------------------------------------

def test_split_and_single_steps_agree_and_copies_continue_identically():
    whole, split = new_physics(), new_physics()
    for physics in (whole, split):
        physics.set_control([12.0, -4.0])
    whole.step(300)
    for _ in range(300):
        split.step()
    np.testing.assert_array_equal(whole.data.qpos, split.data.qpos)
    copy = whole.copy()
    assert copy.hydrodynamics is whole.hydrodynamics
    whole.step(200)
    copy.step(200)
    np.testing.assert_array_equal(whole.data.qpos, copy.data.qpos)
    np.testing.assert_array_equal(whole.data.qvel, copy.data.qvel)


def test_forward_acceleration_is_eq_3():
    """After forward(), qacc = d/dt (R(psi) nu) with nu_dot from Eq. (3) for a moving, thrusting vehicle."""
    physics = new_physics()
    psi, nu = 0.4, np.array([1.5, 0.2, -0.1])
    with physics.reset_context():
        physics.data.qpos[2] = psi
        physics.data.qvel[:] = rotation(psi) @ nu
    physics.set_control([8.0, 2.0])
    physics.forward()
    reference = ReferenceAUV.from_xml()
    force = (np.array([8.0, 0.0, 2.0]) + reference.lift(*nu)
             - (reference.coriolis(*nu) + reference.damping(*nu)) @ nu)
    nu_dot = np.linalg.solve(reference.mass_matrix(), force)
    r = nu[2]  # d/dt R(psi) = r R(psi) S with S nu = (-v, u, 0)
    expected = rotation(psi) @ (nu_dot + r * np.array([-nu[1], nu[0], 0.0]))
    np.testing.assert_allclose(physics.data.qacc, expected, atol=1e-12)


# --- shipped models -------------------------------------------------------------------------------------

def test_model_path_finds_the_vehicle():
    path = model_path("auv.xml")
    assert path.is_file() and path.parent == models_dir()
    assert AUVPhysics.from_xml_path(path).model.nu == 2
    with pytest.raises(FileNotFoundError, match="no_such.xml"):
        model_path("no_such.xml")


@pytest.mark.parametrize("model", ["auv.xml", "auv6.xml"])
def test_both_vehicles_satisfy_the_vehicle_physics_protocol_with_its_signatures(model):
    """`VehiclePhysics` is what code may ask of any vehicle: the planar and the 6-DOF physics both have every method
    under the Protocol's parameter names, and their read-outs have the documented sizes."""
    import inspect

    from auv_mj.sim.physics3d import AUV3DPhysics
    from auv_mj.sim.vehicle_physics import VehiclePhysics

    cls = AUVPhysics if model == "auv.xml" else AUV3DPhysics
    physics = cls.from_xml_path(model_path(model))
    assert isinstance(physics, VehiclePhysics)
    members = [n for n, v in vars(VehiclePhysics).items()
               if not n.startswith("_") and (callable(v) or isinstance(v, classmethod | property))]
    assert len(members) == 13
    for name in members:
        if isinstance(vars(VehiclePhysics)[name], property):
            assert isinstance(getattr(cls, name), property), (cls.__name__, name)
            continue
        wanted = list(inspect.signature(getattr(VehiclePhysics, name)).parameters)
        got = list(inspect.signature(getattr(cls, name)).parameters)
        assert got[:len(wanted)] == wanted, (cls.__name__, name, got, wanted)
    physics.forward()
    assert physics.pose().shape == (3,)
    assert physics.body_velocity().shape == ((3,) if model == "auv.xml" else (6,))
    assert physics.sonar().shape == ((9,) if model == "auv.xml" else (27,))
    assert physics.speed() == pytest.approx(0.0)
