"""The mock's wrist F/T sensor (fbcc_ros.core.sim.wrist_sensor, MockStage.wrist_reading): at rest
it reads its payload's weight and its bias; in contact, the compensation of a wrist sensor with
that payload and bias recovers the mock's true response (an independent path: the contact
wrench moved from the true hole to the flange, then by the compensation back to the hole)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from fbcc_ros.core.compensation.compensator import Compensator, SensorSetup
from fbcc_ros.core.compensation.payload import Motion, payload_wrench
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.kinematics.ik import solve_ik
from fbcc_ros.core.sim.wrist_sensor import WRIST_FRAME
from fbcc_ros.pipeline import mock_cell
from fbcc_ros.pipeline.parameters import resolve


def _stage(**given: Any) -> mock_cell.MockStage:
    given = {"wrist_sensor": True, "wrist_noise": [0.0] * 6, **given}
    values = resolve("mock_cell", mock_cell.TABLE, given)
    return mock_cell.MockStage(values)


def _settle_at(stage: mock_cell.MockStage, features: list[float]) -> Any:
    """The arm commanded to put the peg at the true ``features`` and left to settle."""
    cell = stage.cell
    cell.command(solve_ik(cell.robot, cell.truth.peg_target(features, 0.0), cell.q).q)
    for _ in range(400):
        sample = cell.step(stage.dt)
        stage.wrist_reading(sample)
    return sample


def test_at_rest_it_reads_the_weight_of_what_it_carries_and_its_bias() -> None:
    stage = _stage()
    sample = stage.cell.step(stage.dt)
    reading = stage.wrist_reading(sample)
    rotation = stage.cell.robot.flange_in_base(sample.q).rotation
    expected = payload_wrench(stage.wrist.payload, Motion.at_rest(rotation)) + stage.wrist.bias
    assert np.allclose(reading, expected, atol=1e-12)
    assert reading[2] == pytest.approx(0.8 * 9.81 + 3.0, abs=0.01)  # the tool points down


def test_in_contact_the_wrist_compensation_recovers_the_true_response() -> None:
    stage = _stage()
    sample = _settle_at(stage, [30e-6, -20e-6, 3e-3, 2e-3, -1e-3])
    assert np.abs(sample.response[[0, 2]]).min() > 1.0, sample.response  # in contact
    cell = stage.cell
    setup = SensorSetup(placement="wrist", frame=WRIST_FRAME, pose=pin.SE3.Identity(),
                        hole_in_base=cell.truth.hole_in_base,
                        acting_point=tuple(cell.geometry.acting_point_in_hole()),
                        payload=stage.wrist.payload, bias=tuple(stage.wrist.bias))  # fmt: skip
    comp = Compensator(setup, cell.robot)
    sample = cell.step(stage.dt)
    comp.joints(1.0, sample.q, sample.dq)
    out = comp.reading(1.0, WRIST_FRAME, stage.wrist_reading(sample))
    assert out is not None
    assert np.allclose(out.response, sample.response, rtol=1e-9, atol=1e-9)


def test_without_it_the_mock_reads_no_wrist_and_bad_settings_are_refused() -> None:
    values = resolve("mock_cell", mock_cell.TABLE, {})
    stage = mock_cell.MockStage(values)
    assert stage.wrist_reading(stage.cell.step(stage.dt)) is None
    with pytest.raises(ConfigError, match="wrist_noise"):
        _stage(wrist_noise=[0.1, 0.1, 0.1, 0.0, 0.0, -0.01])
    with pytest.raises(ConfigError, match="wrist_bias"):
        _stage(wrist_bias=[0.0] * 5)
    with pytest.raises(ConfigError, match=r"wrist_payload\.inertia"):
        _stage(**{"wrist_payload.inertia": [1.0, 0, 0, 0, -1.0, 0, 0, 0, 1.0]})
