"""The wrench guard: below the compensation's filters, it trips on an implausible reading or a
contact wrench over its limits, whatever the dead band and the low-pass are set to."""

from __future__ import annotations

import numpy as np
import pytest

from fbcc_ros.core.compensation.compensator import Compensator, SensorSetup
from fbcc_ros.core.compensation.wrench_guard import GuardLimits, WrenchGuard
from fbcc_ros.core.errors import ConfigError

DT = 1e-3


def _feed(comp: Compensator, readings: list[np.ndarray]) -> list[object]:
    return [comp.reading(DT * (k + 1), "ft_sensor", r) for k, r in enumerate(readings)]


def test_a_single_corrupt_moment_sample_trips_it_and_nothing_passes_after() -> None:
    """My = 1e6 N·m in one raw sample: beyond any sensor's range. The sample and every one
    after it are withheld (counted), the reason names the axis and the value."""
    comp = Compensator(SensorSetup())
    quiet = [np.zeros(6)] * 5
    spike = np.array([0.0, 0.0, 0.0, 0.0, 1e6, 0.0])
    out = _feed(comp, [*quiet, spike, *quiet])
    assert all(o is not None for o in out[:5]) and all(o is None for o in out[5:])
    assert "ty 1e+06 beyond the sensor's range" in str(comp.guard.reason)
    assert comp.counts["guard"] == 6


@pytest.mark.parametrize(("deadband", "lowpass_hz"), [((1000.0, 100.0), 0.0), ((0.0, 0.0), 1.0)])
def test_the_force_limit_holds_whatever_the_filters(deadband, lowpass_hz) -> None:
    """A contact force ramping to 400 N over 0.4 s against a 300 N limit. Behind a 1000 N dead
    band the output stays 0; behind a 1 Hz low-pass it lags far below: the controller's own
    limit on its input would never see 300 N. The guard trips at the first sample over its trip
    point, the limit less its 10 % stop margin."""
    comp = Compensator(SensorSetup(deadband=deadband, lowpass_hz=lowpass_hz))
    ramp = [np.array([0.0, 0.0, -f, 0.0, 0.0, 0.0]) for f in np.linspace(0.0, 400.0, 401)]
    out = _feed(comp, ramp)
    first = next(k for k, o in enumerate(out) if o is None)
    assert 270.0 < float(np.linalg.norm(ramp[first][:3])) <= 271.0
    passed = [o.wrench for o in out[:first]]  # type: ignore[attr-defined]
    assert max(abs(w[2]) for w in passed) < 270.0  # what the controller got stayed under it
    assert "over 270 N, the limit 300 N less its stop margin" in str(comp.guard.reason)


def test_a_moment_over_its_limit_trips_it() -> None:
    comp = Compensator(SensorSetup(guard=GuardLimits(moment_limit=2.0, stop_margin=0.0)))
    out = _feed(comp, [np.array([0, 0, 0, 1.5, 1.5, 0.0]), np.array([0, 0, 0, 0.5, 0.5, 0.0])])
    assert out == [None, None] and "|m| 2.121 N·m over 2 N·m" in str(comp.guard.reason)
    margin = Compensator(SensorSetup(guard=GuardLimits(moment_limit=2.0, stop_margin=0.5)))
    assert _feed(margin, [np.array([0, 0, 0, 0.8, 0.8, 0.0])]) == [None]  # 1.13 > 1 N·m


def test_a_reading_that_changes_faster_than_any_contact_trips_it() -> None:
    guard = WrenchGuard(GuardLimits(max_rate=(1e5, 1e4)))
    assert guard.raw(0.000, np.zeros(6))
    assert guard.raw(0.001, np.array([50.0, 0, 0, 0, 0, 0]))  # 5e4 N/s: a contact can
    assert not guard.raw(0.002, np.array([250.0, 0, 0, 0, 0, 0]))  # 2e5 N/s: no contact does
    assert "fx changed at 2e+05/s, faster than 1e+05/s" in str(guard.reason)


@pytest.mark.parametrize(("field", "value"), [("force_limit", 0.0), ("moment_limit", float("nan")),
                                               ("sensor_range", (100.0, -1.0)),
                                               ("max_rate", (1.0,)),
                                               ("stop_margin", 0.95)])  # fmt: skip
def test_limits_are_checked(field, value) -> None:
    with pytest.raises(ConfigError, match=f"guard.{field}"):
        GuardLimits(**{field: value})


def test_a_tare_under_load_is_refused_and_trips_the_guard() -> None:
    """A compensation restarted with the peg pressed in the hole (46, -28, -38 N on the
    sensor): the tare would take the contact for a bias. It is refused with what it measured;
    the configured bias stays and nothing passes. Without the load the same tare is taken."""
    load = np.array([46.0, -28.0, -38.0, 0.5, -0.2, 0.0])
    noise = np.random.default_rng(3).normal(0.0, 0.02, (25, 6))
    for pressed in (True, False):
        comp = Compensator(SensorSetup(tare_samples=20, bias=(1.0, 0, 0, 0, 0, 0)))
        out = _feed(comp, list(noise + (load if pressed else 0.0) + [1.0, 0, 0, 0, 0, 0]))
        assert all(o is None for o in out[:20])  # taring
        if pressed:
            assert all(o is None for o in out[20:]) and comp.guard.tripped
            assert "tare refused: it measured 65.9" in str(comp.guard.reason), comp.guard.reason
            np.testing.assert_array_equal(comp.bias, [1.0, 0, 0, 0, 0, 0])
        else:
            assert all(o is not None for o in out[20:]) and not comp.guard.tripped
            np.testing.assert_allclose(comp.bias, [1.0, 0, 0, 0, 0, 0], atol=0.02)


def test_a_gentle_load_under_max_tare_is_refused_where_the_peg_is_heard_in_the_hole() -> None:
    """A part pushed in gently loads the sensor by less than ``max_tare`` (16 N here): the
    bias check alone takes it. Heard 4 mm in the hole, the tare is refused; heard at the top
    face (where an insertion starts) or up to TARE_DEPTH in, or not heard, it is taken."""
    from fbcc_ros.core.compensation.wrench_guard import TARE_DEPTH

    load = np.array([-1.8, 0.0, -16.0, 0.0, 0.0, 0.0])
    readings = list(np.random.default_rng(4).normal(0.0, 0.02, (25, 6)) + load)
    for depth, refused in ((4e-3, True), (0.0, False), (TARE_DEPTH, False), (None, False)):
        comp = Compensator(SensorSetup(tare_samples=20))
        comp.peg_depth = depth
        out = _feed(comp, readings)
        assert comp.guard.tripped == refused == comp.tare_refused, depth
        if refused:
            assert "tare refused: the peg's tip is 4 mm in the hole" in str(comp.guard.reason)
            assert all(o is None for o in out[20:])
            np.testing.assert_array_equal(comp.bias, np.zeros(6))
        else:
            np.testing.assert_allclose(comp.bias, load, atol=0.02)


def test_a_second_source_interleaved_trips_it_and_its_zeros_are_not_the_wrench() -> None:
    """A stray publisher of zeros stamped 30 ms ahead between the sensor's readings of a 50 N
    contact: the real readings are refused as out of order, and within the window the share of
    rejections trips the guard; before it, what passed is never a real reading counted as
    zero, and after it nothing passes."""
    comp = Compensator(SensorSetup())
    real = np.array([0.0, 0.0, -50.0, 0.0, 0.0, 0.0])
    outs = []
    for k in range(1, 300):
        t = k * DT
        outs.append(comp.reading(t, "ft_sensor", real))
        if k >= 100 and k % 10 == 0:  # the stray at 100 Hz, stamped ahead
            outs.append(comp.reading(t + 0.03, "ft_sensor", np.zeros(6)))
    assert comp.guard.tripped and "of the last 100 samples rejected" in str(comp.guard.reason)
    assert "out_of_order" in str(comp.guard.reason)
    tripped_at = next(i for i, o in enumerate(outs) if i > 100 and o is None
                      and comp.counts["guard"] and all(x is None for x in outs[i:]))
    assert tripped_at < 100 + 40  # within a fraction of a second of the stray's start
    assert all(o is None for o in outs[tripped_at:])


def test_rare_rejections_do_not_trip_it() -> None:
    """One reading in ten out of order (a best-effort network reordering a lot): not a fault."""
    comp = Compensator(SensorSetup())
    for k in range(1, 1000):
        stamp = (k - 1.5) * DT if k % 10 == 0 else k * DT  # older than the one before
        comp.reading(stamp, "ft_sensor", np.zeros(6))
    assert comp.counts["out_of_order"] == 99 and not comp.guard.tripped
