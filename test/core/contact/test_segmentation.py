"""State segmentation (Fig. 4, eq. 15-17) and boundary mapping (eq. 21, 24, 25) on the model."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fbcc_ros.core.contact.mapping_study import classify_study, sample_features
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import (
    OFFSET_BAND,
    OFFSET_TOL,
    STATE_INDEX,
    STATES,
    TILT_TOL,
    direction_matrix,
    feature_state,
    normalised_coordinates,
    plane_state_index,
    response_state,
)
from fbcc_ros.core.contact.spread_states import spread_states
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.paper import paper_pair

DEG = math.pi / 180
HAT_FLIP = {"D": "D^", "D^": "D", "P": "P"}


def _flip_hat(state: str) -> str:
    letter = "D^" if state.startswith("D^") else state[0]
    return HAT_FLIP[letter] + state[len(letter) :]


@pytest.mark.parametrize(
    ("features", "clearance_state", "interference_state"),
    [
        ((0.0, 0.0, 5e-3, 0.0, 0.0), "P0", "P0"),
        ((5e-6, 0.0, 5e-3, 0.0, 0.05 * DEG), "P0", "D1"),  # inside the rhombus of eq. 15
        ((-5e-6, 0.0, 5e-3, 0.0, -0.05 * DEG), "P0", "D^-1"),
        ((5e-5, 0.0, 5e-3, 0.0, 0.0), "P1", "P1"),
        ((-5e-5, 0.0, 5e-3, 0.0, 0.0), "P-1", "P-1"),
        ((0.0, 0.0, 5e-3, 0.0, 1 * DEG), "D0", "D0"),
        ((0.0, 0.0, 5e-3, 0.0, -1 * DEG), "D^0", "D^0"),
        ((5e-5, 0.0, 5e-3, 0.0, 1 * DEG), "D1", "D1"),
        ((-5e-5, 0.0, 5e-3, 0.0, 1 * DEG), "D-1", "D-1"),
        ((5e-5, 0.0, 5e-3, 0.0, -1 * DEG), "D^1", "D^1"),
        ((-5e-5, 0.0, 5e-3, 0.0, -1 * DEG), "D^-1", "D^-1"),
    ],
)
def test_feature_state_xoz(
    clearance, interference, features, clearance_state, interference_state
) -> None:
    assert feature_state(features, clearance)[0] == clearance_state
    assert feature_state(features, interference)[0] == interference_state


def test_feature_state_yoz_uses_dy_and_theta_x(clearance) -> None:
    assert feature_state((0, 5e-5, 5e-3, 1 * DEG, 0), clearance) == ("P0", "D1")
    assert feature_state((0, -5e-5, 5e-3, -1 * DEG, 0), clearance) == ("P0", "D^-1")
    xoz, yoz = feature_state(np.array([(0, 5e-5, 5e-3, 0, 0), (5e-5, 0, 5e-3, 0, 0)]), clearance)
    assert list(xoz) == ["P0", "P1"] and list(yoz) == ["P1", "P0"]


def test_clearance_p0_shrinks_with_depth(clearance) -> None:
    """Fig. 5: the rhombus of P0 loses tilt room as l grows (half-width 2 (R - r) / l)."""
    tilt = 0.15 * DEG
    assert feature_state((0, 0, 2e-3, 0, tilt), clearance)[0] == "P0"
    assert feature_state((0, 0, 10e-3, 0, tilt), clearance)[0] == "D0"


@pytest.mark.parametrize("depth", [2e-3, 5e-3, 10e-3])
def test_model_responses_identify_off_boundary_states(pair: PegHole, depth: float) -> None:
    """Nominal parts, XOZ only, away from the boundaries: no sign is ever wrong; at shallow depth
    a small tilt signature can fall inside the tilt band and read as P (docs/boundary-mapping.md),
    from l = 5 mm on every state is identified."""
    rng = np.random.default_rng(1)
    f = sample_features(rng, 400, 1e-4, 2 * DEG, (depth, depth))
    f[:, [1, 3]] = 0.0
    f = f[(np.abs(f[:, 0]) > 10e-6) & (np.abs(f[:, 4]) > 0.2 * DEG)]
    truth, _ = feature_state(f, pair)
    guess, guess_yoz = response_state(pair.response(f), f[:, 2], pair)
    assert set(guess_yoz) == {"P0"}
    missed = truth != guess
    # a miss only ever drops the tilt into the band: D1 / D^1 -> P1, D-1 / D^-1 -> P-1
    pairs = zip(truth[missed], guess[missed], strict=True)
    assert all(g == "P" + t.lstrip("D^") for t, g in pairs)
    if depth >= 5e-3:
        assert not missed.any()
    else:
        assert missed.mean() < 0.2


def test_theta_zero_maps_onto_the_tilted_line(pair: PegHole) -> None:
    """eq. 24: theta_y = 0 puts the response on the line, sigma = 0 (to round-off)."""
    f = np.array([[d, 0, l, 0, 0] for d in (-8e-5, -3e-5, 3e-5, 8e-5) for l in (2e-3, 9e-3)])
    u, sigma, _, _ = normalised_coordinates(pair.response(f), f[:, 2], pair)
    assert np.all(np.abs(u) > 0.1)
    np.testing.assert_allclose(sigma, 0.0, atol=1e-9)
    xoz, _ = response_state(pair.response(f), f[:, 2], pair)
    assert all(s in ("P1", "P-1") for s in xoz)


def test_normalised_coordinates_are_the_direction_matrix_over_fz(pair: PegHole) -> None:
    """(u_x, sigma_x, u_y, sigma_y) = rows (dx, theta_y, dy, theta_x) of A(l) F / Fz, computed
    without A, to the last bit; a row with Fz <= 0 gives NaN."""
    rng = np.random.default_rng(3)
    w = rng.normal(5.0, 20.0, (300, 5))
    w[::10, 2] = 0.0
    depth = rng.uniform(0.0, 12e-3, 300)
    a_w = np.einsum("nij,nj->ni", direction_matrix(depth, pair), w)
    with np.errstate(divide="ignore"):
        inv = np.where(w[:, 2] > 0, 1.0 / w[:, 2], np.nan)  # times 1/Fz, as computed
    expected = (a_w[:, [0, 4, 1, 3]] * inv[:, None]).T
    assert np.array_equal(np.array(normalised_coordinates(w, depth, pair)), expected,
                          equal_nan=True)  # fmt: skip


def test_dx_zero_boundary_moves_with_tilt(pair: PegHole) -> None:
    """eq. 20 holds to first order only: the image of dx = 0 leaves Fx = 0 as the tilt grows.

    Figures recorded in docs/boundary-mapping.md: |Fx/Fz| at dx = 0, l = 10 mm is ~0.03-0.07
    at 0.5°, ~0.07-0.11 at 1° and ~0.16-0.20 at 2° (interference-clearance).
    """
    shifts = []
    for tilt in (0.5, 1.0, 2.0):
        u, _, _, _ = normalised_coordinates(
            pair.response([0, 0, 10e-3, 0, tilt * DEG]), 10e-3, pair
        )
        shifts.append(abs(float(u)))
    assert shifts[0] < shifts[1] < shifts[2]
    assert shifts[0] < OFFSET_BAND < shifts[2]  # D0 is recognised at small tilt only
    assert 0.1 < shifts[2] < 0.3


def test_rotation_maps_xoz_responses_onto_yoz(pair: PegHole) -> None:
    """A pure-XOZ configuration rotated 90° about z is a pure-YOZ one: Fy' = Fx, Mx' = -My, and
    with right-hand tilts theta_x' = -theta_y, so D <-> D^ (module docstring)."""
    rng = np.random.default_rng(7)
    f = sample_features(rng, 300, 1e-4, 2 * DEG, (1e-3, 10e-3))
    f[:, [1, 3]] = 0.0
    f = f[(np.abs(f[:, 0]) > 10e-6) & (np.abs(f[:, 4]) > 0.2 * DEG)]
    rot = np.column_stack([np.zeros(len(f)), f[:, 0], f[:, 2], -f[:, 4], np.zeros(len(f))])
    w, wr = pair.response(f), pair.response(rot)
    np.testing.assert_allclose(wr[:, 1], w[:, 0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(wr[:, 3], -w[:, 4], rtol=1e-9, atol=1e-9)
    xoz, _ = response_state(w, f[:, 2], pair)
    rx, ry = response_state(wr, rot[:, 2], pair)
    assert set(rx) == {"P0"}
    assert list(ry) == [_flip_hat(s) for s in xoz]
    assert list(feature_state(rot, pair)[1]) == [_flip_hat(s) for s in feature_state(f, pair)[0]]


def test_robustness_figures_hold(pair: PegHole) -> None:
    """Guards the figures of docs/boundary-mapping.md (4000 samples there, 2000 here)."""
    exact = classify_study(pair, 2000, friction_spread=0.0)
    known = classify_study(pair, 2000, friction_spread=0.1)
    loose = classify_study(pair, 2000, friction_spread=0.5)
    assert exact.overall() >= 0.92
    assert known.overall() >= 0.89
    assert loose.overall() >= 0.78
    # the finding: friction enters the tilted boundary (mu R in eq. 24), so a wrong mu costs
    assert loose.overall() < known.overall() < exact.overall()
    both = classify_study(pair, 500, on_boundary="both")
    assert both.accuracy("P0") == 1.0


def test_no_contact_is_p0(clearance) -> None:
    assert response_state(np.zeros(5), 5e-3, clearance) == ("P0", "P0")
    assert response_state([0.01, 0, 0.01, 0, 0], 5e-3, clearance) == ("P0", "P0")


@pytest.mark.parametrize(
    ("response", "depth", "field"),
    [
        ([1, 0, 1, 0], 5e-3, "response"),
        ([1, 0, float("nan"), 0, 0], 5e-3, "response"),
        ([1, 0, 1, 0, 0], -1e-3, "depth"),
        ([1, 0, 1, 0, 0], float("inf"), "depth"),
    ],
)
def test_bad_response_input(clearance, response, depth, field: str) -> None:
    with pytest.raises(InputError) as err:
        response_state(response, depth, clearance)
    assert str(err.value).startswith(f"{field}=")


def test_depths_must_match_the_responses(clearance) -> None:
    with pytest.raises(InputError, match=r"depth=.*shape \(3,\).*shape \(5,\)"):
        response_state(np.ones((5, 5)), [1e-3, 2e-3, 3e-3], clearance)
    assert len(response_state(np.ones((5, 5)), [4e-3], clearance)[0]) == 5


def test_frictionless_geometry_cannot_normalise(clearance) -> None:
    with pytest.raises(ConfigError, match="friction"):
        response_state([1, 0, 1, 0, 0], 5e-3, clearance.replace(friction=0.0))


finite = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(resp=st.tuples(finite, finite, finite, finite, finite), depth=st.floats(0, 0.05))
def test_classifier_answers_for_every_finite_input(resp, depth) -> None:
    xoz, yoz = response_state(np.array(resp), depth, paper_pair("clearance"))
    assert xoz in STATES and yoz in STATES


@settings(max_examples=300, deadline=None)
@given(f=st.tuples(finite, finite, st.floats(0, 1), finite, finite))
def test_feature_classifier_answers_for_every_finite_input(f) -> None:
    xoz, yoz = feature_state(np.array(f), paper_pair("clearance"))
    assert xoz in STATES and yoz in STATES


@pytest.mark.parametrize(("hole", "peg"), [(5.01e-3, 5e-3), (5e-3, 5.005e-3)],
                         ids=["clearance", "interference"])  # fmt: skip
def test_state_probabilities_are_the_states_of_spread_features(hole: float, peg: float) -> None:
    """P(state) of features known to within a spread equals the share of the states of draws
    around them (4000 each; the no-contact region at the tilt given), its weighted vote the
    weighted sum, and a vanishing spread names plane_state_index's state."""
    rng = np.random.default_rng(0)
    n, draws, spread = 300, 4000, (3e-7, 3e-5)
    d, t = rng.uniform(-12e-6, 12e-6, n), rng.uniform(-5e-4, 5e-4, n)
    depth = rng.uniform(0.0, 1e-2, n)
    states = spread_states(d, t, depth, hole, peg, *spread)
    p = states.probabilities()
    weights = rng.uniform(0.0, 1.0, n)
    np.testing.assert_allclose(states.vote(weights), weights @ p, atol=1e-12)
    reach = depth * np.abs(np.sin(t)) / 2 + peg * np.cos(t)  # eq. (15) at the tilt given
    shares = np.zeros((n, len(STATES)))
    for _ in range(draws):
        dd, tt = d + rng.normal(0.0, spread[0], n), t + rng.normal(0.0, spread[1], n)
        index = STATE_INDEX[_sign(tt, TILT_TOL) + 1, _sign(dd, OFFSET_TOL) + 1]
        free = (peg < hole) & (np.abs(dd) + reach <= hole)
        shares[np.arange(n), np.where(free, STATES.index("P0"), index)] += 1.0 / draws
    np.testing.assert_allclose(p.sum(axis=1), 1.0, atol=1e-12)
    assert np.abs(p - shares).max() < 0.035  # 4 standard errors of a share of 4000 draws
    sharp = spread_states(d, t, depth, hole, peg, 1e-15, 1e-15).probabilities()
    np.testing.assert_array_equal(sharp.argmax(axis=1), plane_state_index(d, t, depth, hole, peg))
    assert sharp.max(axis=1).min() == 1.0


@pytest.mark.parametrize("spread", [(0.0, 3e-5), (3e-7, -1.0), (float("nan"), 3e-5)])
def test_state_probabilities_need_a_spread(spread: tuple) -> None:
    with pytest.raises(ConfigError, match="spread"):
        spread_states(np.zeros(3), np.zeros(3), np.zeros(3), 5.01e-3, 5e-3, *spread)


def _sign(x: np.ndarray, band: float) -> np.ndarray:
    return np.where(x > band, 1, np.where(x < -band, -1, 0))
