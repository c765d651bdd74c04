"""The compensation stage's re-arm: after a refused tare it tares again; after a trip in contact
it keeps the bias it has."""

from __future__ import annotations

import numpy as np

from fbcc_ros.pipeline import compensation
from fbcc_ros.pipeline.parameters import resolve

DT = 1e-3
LOAD = np.array([46.0, -28.0, -38.0, 0.5, -0.2, 0.0])  # the peg pressed in the hole


def _stage(**given: object) -> compensation.CompensationStage:
    return compensation.CompensationStage(
        resolve("dynamic_compensation", compensation.TABLE, given))


def _feed(stage: compensation.CompensationStage, t0: int, n: int, wrench: np.ndarray) -> list:
    return [stage.reading((t0 + k) * DT, "ft_sensor", wrench) for k in range(n)]


def test_a_refused_tare_is_taken_again_after_the_rearm() -> None:
    stage = _stage(tare_samples=20)
    assert all(o is None for o in _feed(stage, 0, 30, LOAD))
    assert "tare refused" in str(stage.comp.guard.reason)
    assert "tare refused" in str(stage.rearm())
    assert all(o is None for o in _feed(stage, 30, 30, LOAD))  # still loaded: refused again
    assert stage.comp.guard.tripped
    stage.rearm()
    bias = np.array([2.0, 0, 0, 0, 0, 0])  # unloaded: the tare is taken
    out = _feed(stage, 60, 30, bias)
    assert all(o is None for o in out[:20]) and all(o is not None for o in out[20:])
    np.testing.assert_allclose(stage.comp.bias, bias)
    assert stage.just_tared is False and not stage.comp.guard.tripped


def test_a_rearm_after_a_trip_in_contact_keeps_the_bias() -> None:
    stage = _stage(tare_samples=20)
    _feed(stage, 0, 20, np.array([2.0, 0, 0, 0, 0, 0]))
    assert _feed(stage, 20, 1, np.array([400.0, 0, 0, 0, 0, 0]))[0] is None
    assert "|f|" in str(stage.rearm())
    out = _feed(stage, 21, 5, np.array([12.0, 0, 0, 0, 0, 0]))
    assert all(o is not None for o in out)
    np.testing.assert_allclose(out[-1].wrench[:3] @ out[-1].wrench[:3], 100.0)  # 12 - 2 N
