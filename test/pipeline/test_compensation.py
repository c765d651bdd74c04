"""The compensation stage: after a refused tare it tares again; after a trip in contact
it keeps the bias it has; a dead band that would blind the law is refused while running."""

from __future__ import annotations

import numpy as np
import pytest

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


def test_a_tare_with_the_peg_heard_in_the_hole_is_refused_until_it_is_out() -> None:
    """A gentle load (under max_tare) with the peg 4 mm in (fbcc/features' z -4 mm): refused,
    and again after a rearm while it stays in; taken once the peg is heard out."""
    gentle = np.array([0.0, 0.0, -12.0, 0.0, 0.0, 0.0])
    stage = _stage(tare_samples=20)
    stage.peg(-4e-3)
    assert all(o is None for o in _feed(stage, 0, 30, gentle))
    assert "the peg's tip is 4 mm in the hole" in str(stage.rearm())
    assert all(o is None for o in _feed(stage, 30, 30, gentle)) and stage.comp.guard.tripped
    stage.peg(2e-3)  # withdrawn, 2 mm over the top face
    stage.rearm()
    out = _feed(stage, 60, 30, gentle)
    assert all(o is not None for o in out[20:]) and not stage.comp.guard.tripped


def test_a_rearm_after_a_trip_in_contact_keeps_the_bias() -> None:
    stage = _stage(tare_samples=20)
    _feed(stage, 0, 20, np.array([2.0, 0, 0, 0, 0, 0]))
    assert _feed(stage, 20, 1, np.array([400.0, 0, 0, 0, 0, 0]))[0] is None
    assert "|f|" in str(stage.rearm())
    out = _feed(stage, 21, 5, np.array([12.0, 0, 0, 0, 0, 0]))
    assert all(o is not None for o in out)
    np.testing.assert_allclose(out[-1].wrench[:3] @ out[-1].wrench[:3], 100.0)  # 12 - 2 N


def test_a_dead_band_that_would_blind_the_law_is_refused_while_running() -> None:
    """Widening the dead band past the lateral forces an insertion ends with is refused at
    runtime (the law would push in blind); narrower, or back to its start-up width, applies."""
    from fbcc_ros.core.errors import ConfigError
    from fbcc_ros.pipeline.lateral_watch import RESOLVE_FORCE

    values = resolve("dynamic_compensation", compensation.TABLE, {"deadband": [0.2, 0.01]})
    stage = compensation.CompensationStage(values)
    with pytest.raises(ConfigError, match=r"deadband.*\[200.0, 20.0\].*at most 0.5 N"):
        stage.apply({**values, "deadband": [200.0, 20.0]})
    assert stage._filters[1] == [0.2, 0.01]
    stage.apply({**values, "deadband": [RESOLVE_FORCE, 0.01]})
    assert stage._filters[1] == [RESOLVE_FORCE, 0.01]
    # a cell started with a wide band (warned of at start-up) may go back to it
    wide = resolve("dynamic_compensation", compensation.TABLE, {"deadband": [2.0, 0.5]})
    started_wide = compensation.CompensationStage(wide)
    started_wide.apply({**wide, "deadband": [0.0, 0.0]})
    started_wide.apply(wide)
    assert started_wide._filters[1] == [2.0, 0.5]


def test_a_low_pass_that_would_lag_the_law_is_refused_while_running() -> None:
    """Lowering the low-pass cut-off while running (or turning one on) is refused: it lags the
    law's input past what its margins budget; raising it, or off, applies."""
    from fbcc_ros.core.errors import ConfigError

    values = resolve("dynamic_compensation", compensation.TABLE, {"lowpass_hz": 200.0})
    stage = compensation.CompensationStage(values)
    with pytest.raises(ConfigError, match=r"lowpass_hz.*1.0.*at least its start-up value 200"):
        stage.apply({**values, "lowpass_hz": 1.0})
    stage.apply({**values, "lowpass_hz": 400.0})
    assert stage._filters[0] == 400.0
    stage.apply({**values, "lowpass_hz": 0.0})
    assert stage._filters[0] == 0.0
    off = resolve("dynamic_compensation", compensation.TABLE, {})
    with pytest.raises(ConfigError, match="lowpass_hz"):
        compensation.CompensationStage(off).apply({**off, "lowpass_hz": 20.0})
