"""Scenario validation (DESIGN §4): defaults, and errors that name the key, the value and what
is expected, before anything is simulated."""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fbcc_ros.core.control.robust_params import RobustParams
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.paper import paper_scenario
from fbcc_ros.core.sim.scenario import DEFAULT_NOISE, load, validate

ROOT = Path(__file__).resolve().parents[3]
SCENARIOS = sorted((ROOT / "config" / "scenarios").glob("*.yaml"))


def test_defaults_are_documented_values() -> None:
    sc = validate(paper_scenario("clearance"))
    assert sc.laws == ("fbcc",) and sc.params == RobustParams()  # the robust configuration
    assert sc.rate_hz == 1000 and sc.seed == 0 and sc.lag == 0.005
    assert sc.duration == pytest.approx(0.01 / 0.005 + 2.0)
    np.testing.assert_array_equal(sc.noise, DEFAULT_NOISE)
    np.testing.assert_array_equal(sc.bias, np.zeros(5))


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_every_shipped_scenario_validates(path: Path) -> None:
    sc = load(path)
    assert sc.geometry.stiffness == pytest.approx(1.84e8)
    # every one inserts the whole hole but the MuJoCo cases, which insert part of it (their cost)
    whole = sc.insertion.depth == pytest.approx(sc.geometry.hole_depth)
    assert whole or (sc.plant.type == "mujoco" and sc.insertion.depth < sc.geometry.hole_depth)


def _with(path: tuple[str, ...], value: Any) -> dict[str, Any]:
    s = copy.deepcopy(paper_scenario("clearance"))
    node = s
    for key in path[:-1]:
        node = node.setdefault(key, {})
    if value is _DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return s


_DELETE = object()


@pytest.mark.parametrize(
    ("path", "value", "field", "expected"),
    [
        (("geometry", "hole_radius"), 5.05, "geometry.hole_radius", "m"),  # mm given as m
        (("geometry", "hole_radius"), _DELETE, "geometry.hole_radius", "required"),
        (("geometry", "stiffness"), 2.2, "geometry.stiffness", "Pa"),  # GPa given as Pa
        (("geometry", "friction"), "0.3x", "geometry.friction", "number"),
        (("geometry", "colour"), "red", "geometry.colour", "one of"),
        (("initial", "theta_y"), 2.0, "initial.theta_y", "rad"),  # degrees given as rad
        (("initial", "dx"), 0.05, "initial.dx", "m"),  # mm given as m
        (("initial", "dy"), _DELETE, "initial.dy", "required"),
        (("insertion", "depth"), 0.02, "insertion.depth", "hole_depth"),
        (("insertion", "speed"), 5.0, "insertion.speed", "m/s"),
        (("controller", "type"), "pid", "controller.type", "fbcc"),
        (("controller", "params"), {"K_dq": 1.0}, "controller.params.K_dq", "K_dp"),
        (("controller", "params"), {"K_dp": -1.0}, "controller.params.K_dp", "> 0"),
        (("sensor", "noise"), [0.1, 0.1], "sensor.noise", "five"),
        (("rate_hz",), 1.0, "rate_hz", "Hz"),
        (("seed",), 1.5, "seed", "integer"),
        (("duration",), 0.005, "duration", "control periods"),
        (("durration",), 3.0, "scenario.durration", "did you mean 'duration'?"),
        (("robot", "model"), "kr6", "robot.model", "iiwa14"),
        (("robot", "namespace"), "lbr", "robot.namespace", "/lbr"),
        (("robot", "conventions"), "fri", "robot.conventions", "lbr"),
        (("robot", "rate_hz"), 5.0, "robot.rate_hz", "Hz"),
        (("robot", "delay"), 20.0, "robot.delay", "s"),  # ms given as s
        (("robot", "delay"), -0.01, "robot.delay", "s"),
        (("sensor", "source"), "wrist", "sensor.source", "measured_torques"),
        (("sensor", "qos"), "sensor_data", "sensor.qos", "best_effort"),
        (("sensor", "source"), "estimated", "sensor.source", "conventions lbr"),
    ],
)
def test_bad_scenarios_name_key_value_and_expectation(
    path: tuple[str, ...], value: Any, field: str, expected: str
) -> None:
    with pytest.raises(ConfigError) as err:
        validate(_with(path, value))
    assert err.value.field == field
    assert expected in str(err.value)


def test_a_peg_much_wider_than_the_hole_smells_of_mixed_units() -> None:
    with pytest.raises(ConfigError, match="differs by microns"):
        validate(_with(("geometry", "peg_radius"), 6e-3))


def test_yaml_exponents_without_a_dot_are_numbers(tmp_path: Path) -> None:
    """PyYAML (YAML 1.1) reads 5e-5 as the text '5e-05'; our loader reads it as a number."""
    text = (ROOT / "config/scenarios/fig9_clearance.yaml").read_text()
    text = text.replace("stiffness: 1.84e+8", "stiffness: 1.84e8").replace("dx: 5e-05", "dx: 5e-5")
    p = tmp_path / "s.yaml"
    p.write_text(text)
    sc = load(p)
    assert sc.geometry.stiffness == 1.84e8 and sc.initial[0] == 5e-5


def test_numbers_given_as_text_get_a_hint() -> None:
    with pytest.raises(ConfigError, match="given as text"):
        validate(_with(("initial", "dx"), "5e-5"))


def test_missing_and_malformed_files(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"a readable file \(No such file"):
        load(tmp_path / "nope.yaml")
    latin1 = tmp_path / "latin1.yaml"
    latin1.write_bytes("name: caf\xe9\n".encode("latin-1"))
    with pytest.raises(ConfigError, match="UTF-8 text"):
        load(latin1)
    bad = tmp_path / "bad.yaml"
    bad.write_text("geometry: [1, 2\n")
    with pytest.raises(ConfigError, match="valid YAML"):
        load(bad)
    notmap = tmp_path / "list.yaml"
    notmap.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="scenario"):
        load(notmap)


def test_laws_may_be_a_list_to_compare() -> None:
    sc = validate(_with(("controller", "type"), ["fbcc", "admittance"]))
    assert sc.laws == ("fbcc", "admittance")
    with pytest.raises(ConfigError, match="single law"):
        _ = sc.law
    assert sc.with_law("admittance").law == "admittance"
    assert math.isfinite(sc.duration)


def test_the_ros_cell_section_checks_its_keys_together() -> None:
    s = _with(("robot", "conventions"), "lbr")
    s["robot"]["model"] = "panda"
    with pytest.raises(ConfigError, match=r"robot.model='panda'.*an LBR"):
        validate(s)
    s["robot"].update(model="med7", rate_hz=100, namespace="/lbr")
    s["sensor"] = {"source": "estimated", "qos": "best_effort"}
    sc = validate(s)
    assert (sc.cell.model, sc.cell.namespace, sc.cell.source, sc.rate_hz) == (
        "med7", "/lbr", "estimated", 100.0)
    s["rate_hz"] = 250
    with pytest.raises(ConfigError, match=r"robot.rate_hz=100.*250 Hz"):
        validate(s)
