"""The robust law's discrete filters: the second-order low-pass per channel against the
batched row step, and the dither notch's gain at, below and above its frequency."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fbcc_ros.core.filters import (
    notch_coefficients,
    notch_step,
    second_order_coefficients,
    second_order_row,
    second_order_step,
)

DT = 1e-3


def test_one_channel_steps_as_the_batched_rows_and_settles_at_unit_gain() -> None:
    c = second_order_coefficients(400.0, 0.7, DT)
    rows = np.repeat(c[:, None], 5, axis=1)
    x, v, s = np.zeros(5), np.zeros(5), np.zeros(2)
    u = np.array([1.0, -2.0, 0.5, 3.0, 0.0])
    for _ in range(200):
        second_order_row(rows, x, v, u)
        assert second_order_step(c, s, u[3]) == pytest.approx(x[3], rel=1e-12)
    assert s[0] == pytest.approx(3.0, rel=1e-6)


@pytest.mark.parametrize("quality", [1.0, 3.0])
def test_the_notch_removes_its_frequency_and_passes_the_rest(quality: float) -> None:
    """A sinusoid at the notch's frequency is gone once the transient has passed; well below
    and at DC the notch passes (what the depth loop must still see)."""
    f0 = 47.0
    b = notch_coefficients(2 * math.pi * f0, quality, DT)
    t = np.arange(4000) * DT
    for hz, low, high in ((f0, 0.0, 0.01), (4.0, 0.97, 1.03), (0.0, 0.999, 1.001)):
        s = np.zeros(2)
        signal = np.cos(2 * math.pi * hz * t)
        out = np.array([notch_step(b, s, v) for v in signal])
        assert low <= np.abs(out[3000:]).max() <= high, (hz, np.abs(out[3000:]).max())
