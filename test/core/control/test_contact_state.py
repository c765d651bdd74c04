"""The contact-state estimator from one response (fbcc_ros.core.control.contact_state):
states known by construction, drawn responses against the sector rule and boundary mapping,
the stated probability against the share right, and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fbcc_ros.core.contact.segmentation import STATES, feature_state
from fbcc_ros.core.control.contact_state import ContactStateEstimator, most_probable
from fbcc_ros.core.control.contact_uncertainty import Uncertainty, draw_in_state
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.paper import paper_pair
from fbcc_ros.core.sim.state_study import CALIBRATION_EDGES, drawn_study

FITS = ("clearance", "interference")


@pytest.fixture(scope="module", params=FITS)
def estimator(request: pytest.FixtureRequest) -> ContactStateEstimator:
    return ContactStateEstimator(paper_pair(request.param), seed=3)


@pytest.mark.parametrize("fit", FITS)
@pytest.mark.parametrize("magnitudes", ["log", "uniform"])
def test_features_are_drawn_inside_the_state_asked_for(fit: str, magnitudes: str) -> None:
    unc = Uncertainty(magnitudes=magnitudes)
    rng = np.random.default_rng(1)
    part = unc.part(paper_pair(fit), rng)
    for state in STATES:
        f = draw_in_state(state, 50, part, unc, rng)
        if state == "P0" and fit == "interference":
            assert len(f) > 0  # the point of eq. 17 within the bands
        assert len(f) == 50
        assert (feature_state(f, part)[0] == state).all()
        assert (np.abs(f[:, [0, 1]]) <= unc.max_offset).all()
        assert (np.abs(f[:, [3, 4]]) <= unc.max_tilt).all()


@pytest.mark.parametrize("fit", FITS)
def test_a_clear_state_is_named_with_confidence_and_mus_spread_costs_it(fit: str) -> None:
    """The nominal part's own response 50 µm off and tilted 1°, in each of the four D
    states: with μ known to ±10 % it is named with over 3/4; with μ ±50 % (the default) the
    friction arm μR moves the line of θ = 0 by about Δμ·Fx/Fz (0.4 here), so the same
    response is less certain."""
    known = ContactStateEstimator(paper_pair(fit), Uncertainty(friction=0.1), seed=3)
    unknown = ContactStateEstimator(paper_pair(fit), seed=3)
    for d, tilt, state in ((1, 1, "D1"), (-1, 1, "D-1"), (1, -1, "D^1"), (-1, -1, "D^-1")):
        f = np.array([d * 50e-6, 0.0, 5e-3, 0.0, tilt * math.radians(1.0)])
        assert feature_state(f, known.nominal)[0] == state
        w = known.nominal.response(f)
        named, p = most_probable(known.probabilities(w, f[2]))
        assert named[0, 0] == state and p[0, 0] > 0.75, p
        assert unknown.probabilities(w, f[2])[0, 0, STATES.index(state)] < p[0, 0]


def test_one_response_beats_the_sector_rule_and_boundary_mapping(
        estimator: ContactStateEstimator) -> None:
    """Drawn responses under the uncertainty, with a seed of their own (the table's is 3)."""
    for magnitudes in ("log", "uniform"):
        t = drawn_study(estimator, 200, seed=11, magnitudes=magnitudes)
        assert t["estimator"].accuracy > t["boundary mapping"].accuracy + 0.03
        assert t["estimator"].accuracy > t["sector rule"].accuracy + 0.15


def test_the_stated_probability_is_the_share_right_on_drawn_responses(
        estimator: ContactStateEstimator) -> None:
    """In each bin of the stated probability with enough samples, the share right lies within
    the bin widened by 3 binomial deviations (the responses drawn as the table's are)."""
    t = drawn_study(estimator, 300, seed=12)["estimator"]
    for lo, hi, n, right in zip(CALIBRATION_EDGES[:-1], CALIBRATION_EDGES[1:], t.stated,
                                t.right, strict=True):  # fmt: skip
        if n < 50:
            continue
        share, sd = right / n, 3 * math.sqrt(0.25 / n)
        assert lo - sd <= share <= min(hi, 1.0) + sd, (lo, hi, n, share)


def test_no_contact_is_p0_for_a_clearance_fit() -> None:
    est = ContactStateEstimator(paper_pair("clearance"), seed=3)
    named, p = most_probable(est.probabilities(np.zeros((1, 5)), 5e-3))
    assert list(named[0]) == ["P0", "P0"] and (p > 0.5).all()


@pytest.mark.parametrize(("make", "match"), [
    (lambda: Uncertainty(friction=1.2), r"uncertainty.friction=1.2.*\[0, 1\)"),
    (lambda: Uncertainty(magnitudes="cubic"), r"magnitudes='cubic'.*\['log', 'uniform'\]"),
    (lambda: Uncertainty(depth_range=(5e-3, 1e-3)), r"depth_range.*0 < low < high"),
    (lambda: Uncertainty(noise=(0.1, 0.1)), r"noise.*five finite"),
    (lambda: ContactStateEstimator(paper_pair("clearance"), samples=5), r"samples >= 20"),
    (lambda: ContactStateEstimator(paper_pair("clearance"), prior=[1.0, 2.0]),
     r"prior.*9 probabilities"),
])  # fmt: skip
def test_bad_settings_are_refused_with_what_is_allowed(make: object, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        make()  # type: ignore[operator]


def test_bad_inputs_are_refused(estimator: ContactStateEstimator) -> None:
    with pytest.raises(InputError, match="depth"):
        estimator.probabilities(np.zeros((1, 5)), math.nan)
    with pytest.raises(InputError, match="state"):
        draw_in_state("Q1", 3, estimator.nominal, estimator.uncertainty,
                      np.random.default_rng(0))  # fmt: skip
