"""The deviation filter's vote calibrated (fbcc_ros.core.control.state_calibration): the named
state is kept, a clearance's vote is untouched, an interference's is sharpened by its power."""

from __future__ import annotations

import numpy as np
import pytest

from fbcc_ros.core.control.state_calibration import SHARPNESS, calibrated


def test_a_clearance_vote_is_left_as_it_is() -> None:
    votes = np.array([[0.6, 0.3, 0.1] + [0.0] * 6, [0.5, 0.5] + [0.0] * 7])
    assert calibrated(votes, "clearance") is votes


def test_an_interference_vote_is_raised_to_its_power_and_keeps_its_state() -> None:
    a = SHARPNESS["interference"]
    assert a > 1.0  # the interference stated its states too timidly
    rng = np.random.default_rng(3)
    votes = rng.dirichlet(np.ones(9), size=(50, 2))
    out = calibrated(votes, "interference")
    assert out.shape == votes.shape
    np.testing.assert_allclose(out.sum(axis=-1), 1.0, rtol=1e-12)
    np.testing.assert_array_equal(out.argmax(axis=-1), votes.argmax(axis=-1))
    assert np.all(out.max(axis=-1) >= votes.max(axis=-1))  # surer of the named state
    two = np.zeros(9)
    two[:2] = 0.75, 0.25
    assert calibrated(two, "interference")[0] == pytest.approx(0.75**a / (0.75**a + 0.25**a))
    sure = np.eye(9)[4]
    assert calibrated(sure, "interference") == pytest.approx(sure)


def test_an_unknown_fit_is_refused() -> None:
    with pytest.raises(ValueError, match="'press': expected one of clearance, interference"):
        calibrated(np.full(9, 1 / 9), "press")
