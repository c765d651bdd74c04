"""Both plants behind one interface: the simulator runs the same scenario on the model of eq.
5-13 and on MuJoCo (``plant: {type: ...}``); where the physics agree, so do the outcomes, and
where the model has no top face, MuJoCo shows it. The scenario's ``plant`` key is checked."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pytest

from fbcc_ros.core.control.robust_params import RobustParams
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim import scenario
from fbcc_ros.core.sim.plants.model import ModelContact
from fbcc_ros.core.sim.plants.mujoco import MujocoContact, impedance_width, scene_of
from fbcc_ros.core.sim.plants.mujoco_scene import Contact
from fbcc_ros.core.sim.plants.plant import LaggingRobot
from fbcc_ros.core.sim.simulation import scenario_plant, simulate

BASE: dict[str, Any] = {
    "geometry": {"hole_radius": 0.00505, "peg_radius": 0.00504, "hole_depth": 0.01,
                 "base_thickness": 0.005, "friction": 0.3, "stiffness": 1.84e8},
    "initial": {"dx": 0.0, "dy": 0.0, "theta_x": 0.0, "theta_y": 0.0},
    "insertion": {"depth": 0.004, "speed": 0.005},
    "holder": {"lateral": 5e4, "angular": 30.0},
    "duration": 1.5,
}  # fmt: skip


def _scenario(plant: dict[str, Any], geometry: dict[str, Any] | None = None,
              **initial: float) -> scenario.Scenario:  # fmt: skip
    return scenario.validate({**BASE, "initial": {**BASE["initial"], **initial}, "plant": plant,
                              "geometry": {**BASE["geometry"], **(geometry or {})}})  # fmt: skip


@pytest.mark.parametrize(("kind", "cls"), [("model", ModelContact), ("mujoco", MujocoContact)])
def test_the_scenario_names_its_plant(kind: str, cls: type) -> None:
    sc = _scenario({"type": kind})
    robot = LaggingRobot(2, 1.0 / sc.rate_hz, sc.lag, sc.delay)
    plant = scenario_plant(sc, robot, sc.initial[None].repeat(2, axis=0), [sc.geometry])
    assert isinstance(plant.contact, cls) and plant.robot is robot
    features, response = plant.sense()
    assert features.shape == response.shape == (2, 5)


def test_an_aligned_insertion_agrees_on_both_plants() -> None:
    """No deviation, a compliant grip: both assemble, to the same final features within 1 µm
    and 1e-4 rad; neither presses (the clearance is 10 µm)."""
    summaries = [simulate(_scenario({"type": kind}), "fbcc", record=False)[0].summary(0)
                 for kind in ("model", "mujoco")]  # fmt: skip
    model, mujoco = summaries
    assert model["success"] and mujoco["success"]
    for name in ("dx", "dy", "l"):
        assert mujoco["final_features"][name] == pytest.approx(model["final_features"][name],
                                                               abs=1e-6)  # fmt: skip
    for name in ("theta_x", "theta_y"):
        assert mujoco["final_features"][name] == pytest.approx(model["final_features"][name],
                                                               abs=1e-4)  # fmt: skip
    assert abs(mujoco["peak_fz"]) < 1.0


def test_mujoco_has_the_top_face_the_model_lacks() -> None:
    """0.1 mm off, ten times the clearance, no chamfer, the law's hole search off: the model
    without its rim (no top face) lets the peg in and the law assembles; on MuJoCo the peg lands
    on the hole's top face and stands there (test_hole_search: the search finds the hole)."""
    sc = {"type": "model"}, {"type": "mujoco"}
    model, mujoco = (simulate(dataclasses.replace(_scenario(plant, dx=1e-4),
                                                  params=RobustParams(search_range=0.0)),
                              "fbcc", record=False)[0] for plant in sc)  # fmt: skip
    assert model.summary(0)["success"]
    stood = mujoco.summary(0)
    assert not stood["success"] and stood["final_features"]["l"] < 5e-5
    assert stood["peak_fz"] > 10.0  # it pressed on the face


@pytest.mark.parametrize(("plant", "key"), [
    ({"type": "bullet"}, "plant.type"), ({"type": "mujoco", "facets": 8}, "plant.facets"),
    ({"type": "mujoco", "chamfer": 3e-4}, "plant.chamfer"),  # the part's: geometry.chamfer
    ({"type": "mujoco", "timestep": 3e-4}, "plant.timestep"),
    ({"type": "mujoco", "timestep": 3e-5}, "plant.timestep"),
    ({"type": "mujoco", "timestep": 1e-4}, "plant.timeconst"),  # 2 timesteps: unsettled
    ({"type": "mujoco", "mesh": "x.stl"}, "plant"),
])  # fmt: skip
def test_a_bad_plant_is_refused_naming_its_key(plant: dict[str, Any], key: str) -> None:
    with pytest.raises(ConfigError, match=key):
        _scenario(plant)


def test_a_chamfer_wider_than_the_top_face_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"geometry\.chamfer.*plant\.face_width"):
        _scenario({"type": "mujoco", "face_width": 0.002}, {"rim": True, "chamfer": 0.003})


def test_the_plant_keys_build_the_scene_they_name() -> None:
    """facets, the part's chamfer, face_width and timestep reach MuJoCo's model: the bore's
    boxes, their place, the timestep and the substeps of a control period."""
    keys = {"type": "mujoco", "facets": 64, "face_width": 0.004, "timestep": 1e-4,
            "timeconst": 1e-3}  # fmt: skip
    sc = _scenario(keys, {"rim": True, "chamfer": 2e-4})
    robot = LaggingRobot(1, 1.0 / sc.rate_hz, sc.lag, sc.delay)
    plant = scenario_plant(sc, robot, sc.initial[None], [sc.geometry])
    assert isinstance(plant.contact, MujocoContact)
    model = plant.contact.scenes[0].model
    assert model.opt.timestep == 1e-4 and plant.contact.substeps == 10
    assert model.geom_solref[0][0] == 1e-3
    assert model.ngeom == 2 * 64 + 1 + 1  # facets, chamfer facets, bottom, peg
    facet = model.geom_size[0]  # half the face, half a facet's width, half the bore's depth
    assert facet[0] == pytest.approx(0.002) and facet[2] == pytest.approx((0.01 - 2e-4) / 2)


def test_a_scenario_without_a_plant_runs_on_the_model() -> None:
    sc = scenario.validate({k: v for k, v in BASE.items()})
    assert sc.plant.type == "model"


def _chamfered_insertion(**plant: Any) -> dict[str, Any]:
    """The Fig. 9 pair 0.1 mm off into a 0.3 mm chamfer, 1 mm deep, no sensor noise."""
    sc = scenario.validate(
        {
            **BASE,
            "initial": {**BASE["initial"], "dx": 1e-4},
            "insertion": {"depth": 0.001, "speed": 0.005},
            "duration": 1.0,
            "sensor": {"noise": 0},
            "geometry": {**BASE["geometry"], "rim": True, "chamfer": 3e-4},
            "plant": {"type": "mujoco", **plant},
        }
    )
    return simulate(sc, "fbcc", record=False)[0].summary(0)


def test_a_chamfered_insertion_settles_in_the_timestep_and_the_facets() -> None:
    """Halving the timestep, or doubling the facets, moves the insertion's peak force by less
    than 5 % and its final features by less than 2 µm (the credibility study,
    docs/plant.md)."""
    first = _chamfered_insertion()
    for other in (_chamfered_insertion(timestep=2.5e-5), _chamfered_insertion(facets=256)):
        assert first["success"] and other["success"]
        assert other["peak_fz"] == pytest.approx(first["peak_fz"], rel=0.05)
        for name in ("dx", "dy", "l"):
            assert other["final_features"][name] == pytest.approx(
                first["final_features"][name], abs=2e-6)


@pytest.mark.parametrize(("timeconst", "width"), [(2e-4, 1e-5), (1e-3, 1e-4)])
def test_one_time_constant_names_a_contact_from_metal_like_to_plastic_like(
        timeconst: float, width: float) -> None:  # fmt: skip
    """A scenario's plant.timeconst sets the impedance's width too: the shipped metal-like
    contact at 0.2 ms (the scene's default Contact), the credibility study's plastic-like one at
    1 ms, and between them on the line through both."""
    sc = scenario.load(Path(__file__).resolve().parents[3] / "config" / "scenarios"
                       / "mujoco_clearance.yaml")
    sc = dataclasses.replace(sc, plant=dataclasses.replace(sc.plant, timeconst=timeconst))
    _, contact = scene_of(sc)
    assert contact.timeconst == timeconst
    assert contact.solimp[2] == pytest.approx(width, rel=1e-12)
    assert contact.solimp[:2] + contact.solimp[3:] == Contact.solimp[:2] + Contact.solimp[3:]
    if timeconst == 2e-4:
        assert contact.solimp == Contact().solimp
    assert 1e-5 < impedance_width(4e-4) < impedance_width(6e-4) < 1e-4
