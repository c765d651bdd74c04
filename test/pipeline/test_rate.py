"""The controller stage says when its input arrives at another rate than it is configured for."""

from __future__ import annotations

import numpy as np

from fbcc_ros.pipeline import controller
from fbcc_ros.pipeline.parameters import resolve
from fbcc_ros.pipeline.rate import WINDOW, InputRate


def test_a_sensor_at_another_rate_is_reported_a_loaded_cell_is_not() -> None:
    rng = np.random.default_rng(3)
    slow, loaded, exact = (InputRate(1000.0, "the wrench") for _ in range(3))
    t = 100.0 + np.arange(3 * WINDOW) * 1e-3
    kept = t[rng.random(t.size) > 0.3]  # 30 % dropped by a busy executor
    for stamp in t[::10]:  # a 100 Hz sensor
        slow.sample(stamp)
    for stamp in kept + rng.normal(0.0, 5e-5, kept.size):
        loaded.sample(stamp)
    assert slow.measured_hz is None and not slow.mismatch()  # its window is not full yet
    for stamp in 100.6 + np.arange(WINDOW) * 1e-2:
        slow.sample(stamp)
    for stamp in t:
        exact.sample(stamp)
    assert abs(slow.measured_hz - 100.0) < 1e-6  # type: ignore[operator]
    assert "100.0 Hz, configured for 1000 Hz" in slow.mismatch()
    assert loaded.mismatch() == "" and exact.mismatch() == ""
    assert abs(exact.measured_hz - 1000.0) < 1e-6  # type: ignore[operator]


def test_the_controller_stage_measures_the_stamps_of_its_wrenches() -> None:
    stage = controller.ControllerStage(resolve("fbcc_controller", controller.TABLE, {}))
    for k in range(WINDOW + 1):  # stamps 4 ms apart: a 250 Hz source
        stage.wrench(k * 4e-3, k * 4e-3, np.zeros(6))
    assert "250.0 Hz" in stage.input_rate.mismatch()
