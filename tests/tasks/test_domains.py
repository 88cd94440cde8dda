"""The domain record (`auv_mj.tasks.domains`): one per vehicle, read by the suite, the executors and the zoo."""

import pytest

from auv_mj.sim.vehicle_physics import VehiclePhysics
from auv_mj.tasks import domains, suite
from auv_mj.tasks.executors import executor_names
from auv_mj.zoo import registry
from auv_mj.zoo.spec import DOMAINS as SPEC_DOMAINS
from auv_mj.zoo.spec import Deployment, by_domain


@pytest.mark.parametrize(("domain", "task"), [("auv", "goal"), ("auv3d", "goal3d")])
def test_each_environment_knows_its_domain_and_the_domain_its_parts(domain, task):
    record = domains.DOMAINS[domain]
    env = suite.load(domain, task, task_kwargs={"random": 0})
    assert domains.of_env(env) is record
    assert isinstance(env.physics, VehiclePhysics) and isinstance(env.physics, record.physics)
    assert set(suite.TASKS_BY_DOMAIN[domain]) == set(record.registry)
    assert executor_names(domain)[:2] == ["splane", "splane-ocean"]
    assert record.frame_renderer().__module__ == record.renderer.partition(":")[0]
    assert SPEC_DOMAINS[domain] == record.title


def test_of_env_refuses_an_environment_of_no_domain():
    with pytest.raises(ValueError, match="no environment of auv-mj's domains"):
        domains.of_env(object())


def test_by_domain_builds_the_deployments_own_and_refuses_unknown_domains():
    build = by_domain(auv=lambda d: "planar", auv3d=lambda d: "6-DOF")
    made = [build(Deployment(None, None, 0, None, None, name)) for name in ("auv", "auv3d")]
    assert made == ["planar", "6-DOF"]
    with pytest.raises(ValueError, match="no domains"):
        by_domain(auv4d=lambda d: None)


def test_a_policy_of_both_domains_is_built_for_the_environments_domain(monkeypatch):
    """`map-replan` is one spec over both domains (`by_domain`): the planar grid planner on a planar environment,
    the voxel planner on a 6-DOF one, chosen by the environment's domain."""
    built = []
    monkeypatch.setattr(registry, "sonar_map_planner", lambda env: built.append("grid") or (lambda step: [0, 0]))
    monkeypatch.setattr(registry, "sonar_voxel_planner", lambda env: built.append("voxel") or (lambda step: [0, 0]))
    for domain, task in (("auv", "obstacles"), ("auv3d", "goal3d")):
        registry.make_policy("map-replan", suite.load(domain, task, task_kwargs={"random": 0}), 0, task)
    assert built == ["grid", "voxel"]
