"""The controller hears when a dead band hides the lateral forces (pipeline.lateral_watch)."""

from __future__ import annotations

import numpy as np

from fbcc_ros.core.filters import dead_band
from fbcc_ros.pipeline.lateral_watch import CONTACT_FORCE, WINDOW, LateralWatch

RNG = np.random.default_rng(5)


def _responses(lateral_n: float, n: int = 2 * WINDOW) -> np.ndarray:
    """Responses in contact (Fz 20 N) with lateral forces of about ``lateral_n`` and moments a
    tenth of that, with a sensor's noise."""
    out = RNG.normal(0.0, 0.05, size=(n, 5))
    out[:, [0, 1]] += lateral_n * RNG.uniform(-1, 1, size=(n, 2))
    out[:, [3, 4]] += 0.1 * lateral_n * RNG.uniform(-1, 1, size=(n, 2))
    out[:, 2] = 20.0
    return out


def _watched(responses: np.ndarray) -> LateralWatch:
    watch = LateralWatch()
    for r in responses:
        watch.sample(r)
    return watch


def test_a_sensor_with_noise_is_never_called_blind() -> None:
    assert _watched(_responses(0.0)).warning() == ""
    assert _watched(_responses(1.5)).warning() == ""


def test_the_lbr_stacks_dead_band_over_small_lateral_forces_is_said() -> None:
    """2 N and 0.5 N·m per component, over lateral forces under 1.5 N: all hidden."""
    banded = dead_band(_responses(1.5), [2.0, 2.0, 0.0, 0.5, 0.5])
    watch = _watched(banded)
    np.testing.assert_array_equal(watch.blind_share, 1.0)
    assert "(Fx in 100%, Fy in 100%, Mx in 100%, My in 100% of the samples)" in watch.warning()
    # moments alone under the band: said for them alone
    moments = dead_band(_responses(1.5), [0.0, 0.0, 0.0, 0.5, 0.5])
    assert "(Mx in 100%, My in 100% of the samples)" in _watched(moments).warning()
    # a wrench mostly over the band gets through (forces to 30 N, moments to 3 N·m)
    assert _watched(dead_band(_responses(30.0), [2.0, 2.0, 0.0, 0.5, 0.5])).warning() == ""


def test_only_contact_samples_count() -> None:
    """Out of contact, the lateral response is zero for every sensor: not judged."""
    free = np.zeros((3 * WINDOW, 5))
    free[:, 2] = CONTACT_FORCE / 2
    watch = _watched(free)
    assert watch.blind_share is None and watch.warning() == ""


def test_a_dead_band_over_what_an_insertion_ends_with_is_named_before_a_run() -> None:
    from fbcc_ros.pipeline.lateral_watch import RESOLVE_FORCE, deadband_warning

    radius = 0.01
    assert deadband_warning((0.0, 0.0), radius, "ours") == ""
    assert deadband_warning((RESOLVE_FORCE, RESOLVE_FORCE * radius), radius, "ours") == ""
    said = deadband_warning((2.0, 0.5), radius, "the stack's estimate")
    assert "the stack's estimate" in said and "2 N > 0.5 N" in said
    assert "0.5 N·m > 0.005 N·m (0.5 N at the peg's radius 10 mm)" in said
    only_moment = deadband_warning((0.1, 0.01), radius, "ours")
    assert "N·m" in only_moment and "0.1 N >" not in only_moment
    assert deadband_warning((0.1, 10.0), None, "ours") == ""  # no radius: the force alone
