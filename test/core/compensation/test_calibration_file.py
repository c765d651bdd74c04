"""The payload calibration's file (fbcc_ros.core.compensation.calibration_file): what
fbcc-calibrate writes is what the compensation node loads, and a file without the keys is
refused naming them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fbcc_ros.core.compensation.calibration_file import calibration_yaml, load_calibration
from fbcc_ros.core.compensation.payload import Calibration, Payload
from fbcc_ros.core.errors import ConfigError

BIAS = np.array([1.0, -2.0, 3.0, 0.01, 0.02, -0.03])


def test_calibration_file_round_trip(tmp_path: Path) -> None:
    fit = Calibration(
        Payload(0.8, (0.002, -0.001, 0.06), ((2e-3, 0, 0), (0, 2e-3, 0), (0, 0, 4e-4))),
        BIAS,
        (0.05, 0.002),
        4.2,
        24,
    )
    path = tmp_path / "payload.yaml"
    path.write_text(calibration_yaml(fit, "static fit\nresidual 0.05 N"))
    assert path.read_text().startswith("# static fit\n# residual 0.05 N\n")
    payload, bias = load_calibration(path)
    assert payload == fit.payload
    np.testing.assert_array_equal(bias, BIAS)
    path.write_text("dynamic_compensation:\n  ros__parameters:\n    bias: [1, 2]\n")
    with pytest.raises(ConfigError, match=r"calibration=.*payload\.\(mass, com, inertia\)"):
        load_calibration(path)
    with pytest.raises(ConfigError, match="calibration"):
        load_calibration(tmp_path / "missing.yaml")
