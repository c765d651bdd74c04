"""The controller stage takes its law and rate from its scenario unless told otherwise, and its
safety limits are only tightened at runtime."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from fbcc_ros.core.control.laws import AdmittanceController, FbccController
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.pipeline import controller
from fbcc_ros.pipeline.parameters import resolve

ROOT = Path(__file__).resolve().parents[2]


def test_law_and_rate_default_to_the_scenarios(tmp_path: Path) -> None:
    data = yaml.safe_load((ROOT / "config/scenarios/fig9_clearance.yaml").read_text())
    data["controller"]["type"] = ["admittance", "fbcc"]
    data["rate_hz"] = 500
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(data))

    def stage(**given: object) -> controller.ControllerStage:
        return controller.ControllerStage(
            resolve("fbcc_controller", controller.TABLE, {"scenario": str(path), **given}))

    default = stage()
    assert isinstance(default.sup.law, AdmittanceController) and default.sup.dt == 1 / 500
    chosen = stage(law="fbcc", rate_hz=1000.0)
    assert isinstance(chosen.sup.law, FbccController) and chosen.sup.dt == 1 / 1000


def test_runtime_limits_are_only_tightened() -> None:
    """A step limit or timeout loosened while the controller runs is refused with its
    start-up value; tightened, or back to it, it is applied."""
    values = resolve("fbcc_controller", controller.TABLE, {"max_step": 1e-4})
    stage = controller.ControllerStage(values)
    for name, looser in (("max_step", 2e-4), ("max_step_angle", 0.05), ("timeout", 0.5)):
        with pytest.raises(ConfigError, match=f"{name}.*at most its start-up value"):
            stage.apply({**values, name: looser})
    assert stage.sup.limits.max_step == 1e-4
    stage.apply({**values, "max_step": 1e-6, "timeout": 0.01})
    assert (stage.sup.limits.max_step, stage.sup.limits.timeout) == (1e-6, 0.01)
    stage.apply(values)
    assert stage.sup.limits == stage.configured


def test_the_robust_law_takes_a_measured_noise_only_where_the_source_is_noisier() -> None:
    """The tare's noise floor (wire wrench, {H} origin): an F/T sensor's, near what the law was
    told, changes nothing; a virtual sensor's moments, 15 times over it, replace the moment
    noise (moved to the acting point) and the law's parameters; Table I's law has none."""
    import numpy as np

    from fbcc_ros.core.control.robust import RobustFbcc

    stage = controller.ControllerStage(resolve("fbcc_controller", controller.TABLE, {
        "scenario": "config/scenarios/robust_interference.yaml"}))  # fmt: skip
    law = stage.sup.law
    assert isinstance(law, RobustFbcc)
    told = law.params.sensor_noise
    before = law._parameters(stage.sup.dt).copy()
    assert stage.noise([0.06, 0.04, 0.05, 0.0025, 0.0015, 0.001]) == ""
    assert law.params.sensor_noise == told
    said = stage.noise([0.05, 0.05, 0.05, 0.03, 0.03, 0.01])
    assert "takes the measured noise" in said
    used = np.array(law.params.sensor_noise)
    assert used[:3].tolist() == list(told[:3])  # the forces as told
    lever = abs(stage.acting_point[2])  # the acting point below the {H} origin
    np.testing.assert_allclose(used[3:], np.hypot(0.03, lever * 0.05), rtol=1e-12)
    assert not np.array_equal(law._parameters(stage.sup.dt), before)
    table1 = controller.ControllerStage(resolve("fbcc_controller", controller.TABLE, {
        "scenario": "config/scenarios/table1_clearance_label3.yaml"}))  # fmt: skip
    assert table1.noise([1.0] * 6) == ""


def test_the_state_filters_k_is_the_scenarios_or_a_given_range() -> None:
    """state_stiffness [0, 0] leaves the filter the scenario's k; a range is handed to it; a
    range that is not one is refused at start-up, naming the parameter."""
    def stage(value: list[float]) -> controller.ControllerStage:
        return controller.ControllerStage(
            resolve("fbcc_controller", controller.TABLE, {"state_stiffness": value}))

    assert stage([0.0, 0.0]).state_stiffness is None
    ranged = stage([1e8, 1e11])
    assert ranged.start_state_worker()
    try:  # the filter's process is handed the range
        assert ranged.state_worker is not None
        assert ranged.state_worker.options == {"stiffness": (1e8, 1e11)}
    finally:
        ranged.close()
    for bad in ([1e9, 1e8], [0.0, 1e9], [1e9], [1e8, float("inf")]):
        with pytest.raises(ConfigError, match=r"state_stiffness.*0 < low <= high \[Pa\]"):
            stage(bad)


@pytest.mark.parametrize("banded", [True, False])
def test_a_dead_band_that_blinds_the_law_in_contact_faults_it(banded: bool) -> None:
    """While inserting, a window of contact samples whose lateral components read exactly zero
    (a dead band over them) faults the controller and holds the arm; the same contact through
    a sensor's noise does not."""
    import numpy as np
    import pinocchio as pin

    from fbcc_ros.core.control.phase import Phase
    from fbcc_ros.pipeline.lateral_watch import WINDOW

    stage = controller.ControllerStage(resolve("fbcc_controller", controller.TABLE, {
        "state_rate_hz": 0.0}))  # fmt: skip
    rng = np.random.default_rng(3)
    peg = stage.pose(np.array([0.0, 0.0, 1e-3, 0.0, 0.0]))
    assert peg is not None
    t = 0.0
    for k in range(2 * WINDOW):
        t = k * stage.sup.dt
        stage.features(t, pin.SE3(peg), t)
        wrench = np.zeros(6)
        wrench[2] = 20.0  # pressing, in contact
        if not banded:
            wrench[[0, 1, 3, 4]] = rng.normal(0.0, 0.05, 4)
        stage.wrench(t, t, wrench)
        if k == 5:
            assert stage.sup.start(t)[0]
    if banded:
        assert stage.sup.phase == Phase.FAULT and stage.sup.reason.startswith("blind: ")
        assert "dead band" in stage.sup.reason
    else:
        assert stage.sup.active, stage.sup.reason
