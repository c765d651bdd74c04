"""The mock sensor's faults (fbcc_ros.core.sim.sensor_faults): what each makes of a stream."""

from __future__ import annotations

import numpy as np
import pytest

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim import sensor_faults as sf

DT = 1e-3


def _stream(name: str, seconds: float = 0.5) -> list[tuple[float, np.ndarray]]:
    fault = sf.SensorFault(name, DT)
    out = []
    for i in range(round(seconds / DT)):
        out += fault.apply(10.0 + i * DT, np.full(6, float(i)))
    return out


@pytest.mark.parametrize(("name", "axis", "size"), [("moment-spike", 4, sf.MOMENT_SPIKE),
                                                    ("force-spike", 2, sf.FORCE_SPIKE)])
def test_a_spike_lasts_its_span_then_the_readings_are_true(name, axis, size) -> None:
    out = _stream(name)
    assert [t for t, _ in out] == pytest.approx([10.0 + i * DT for i in range(500)])
    extra = np.array([w[axis] - i for i, (_, w) in enumerate(out)])
    spiked = round(sf.SPIKE_SPAN / DT)
    np.testing.assert_array_equal(extra[:spiked], size)
    np.testing.assert_array_equal(extra[spiked:], 0.0)
    other = [k for k in range(6) if k != axis]
    assert all((w[other] == i).all() for i, (_, w) in enumerate(out))


def test_nan_readings_then_finite_ones() -> None:
    finite = [bool(np.isfinite(w).all()) for _, w in _stream("nan-wrench")]
    assert finite == [False] * round(sf.NAN_SPAN / DT) + [True] * (500 - round(sf.NAN_SPAN / DT))


def test_a_stale_sensor_is_silent_for_its_span_then_resumes_in_step() -> None:
    out = _stream("stale-wrench")
    silent = round(sf.SILENT_SPAN / DT)
    assert len(out) == 500 - silent and out[0][0] == pytest.approx(10.0 + silent * DT)


def test_future_stamps_for_a_span_then_true_ones() -> None:
    ahead = [t - (10.0 + i * DT) for i, (t, _) in enumerate(_stream("future-stamp"))]
    n = round(sf.FUTURE_SPAN / DT)
    assert ahead[:n] == pytest.approx([sf.FUTURE_BY] * n)
    assert ahead[n:] == pytest.approx([0.0] * (500 - n))


def test_a_slow_sensor_delivers_at_its_rate() -> None:
    stamps = np.array([t for t, _ in _stream("slow-sensor")])
    assert np.diff(stamps) == pytest.approx(1 / sf.SLOW_HZ)


def test_a_burst_holds_readings_back_and_delivers_them_in_order_at_once() -> None:
    fault = sf.SensorFault("sensor-burst", DT)
    sizes = [len(fault.apply(i * DT, np.zeros(6))) for i in range(100)]
    held = round(sf.BURST_SPAN / DT)
    assert sizes[:held] == [0] * held and sizes[held] == held + 1 and set(sizes[held + 1:]) == {1}


def test_an_unknown_fault_is_refused_with_the_names() -> None:
    with pytest.raises(ConfigError, match=r"one of .*moment-spike"):
        sf.SensorFault("moment_spike", DT)
