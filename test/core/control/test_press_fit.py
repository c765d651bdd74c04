"""Telling a press fit from a jam under the push bound: the bound's rule on synthetic loads,
and in closed loop the out-of-tolerance parts that a bound alone stops."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fbcc_ros.core.control import press_fit
from fbcc_ros.core.sim.scenario import validate
from fbcc_ros.core.sim.simulation import Outcome, simulate

PUSH = 20.0
DT = 1e-3


def _bounds(depths: np.ndarray, forces: np.ndarray) -> np.ndarray:
    """The bound at each sample of a load (the arm's depth, F_z)."""
    state = np.zeros(press_fit.N_STATE)
    return np.array([press_fit.bound(state, d, f, PUSH, DT)
                     for d, f in zip(depths, forces, strict=True)])  # fmt: skip


def _press(slope: float, slide: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A load that climbs at ``slope`` [N/m] from 1 mm in, at 5 mm/s, to the bound; there the
    peg stops for 0.3 s (or slides on at ``slide`` [m/s]); then advances 1 mm at 1 mm/s with
    F_z on its line. Returns (depths, forces, bounds)."""
    climb = np.arange(1e-3, 1e-3 + PUSH / slope, 5e-3 * DT)
    held = climb[-1] + slide * DT * np.arange(300)
    on = held[-1] + 1e-3 * DT * np.arange(1000)
    depths = np.concatenate([climb, held, on])
    forces = np.minimum(slope * (depths - 1e-3), PUSH)
    forces[len(climb) + len(held) :] = slope * (on - 1e-3)
    return depths, forces, _bounds(depths, forces)


def test_a_press_fit_stopped_at_the_bound_is_pushed_along_its_line() -> None:
    """F_z climbing 1e4 N/m (20 N over 2 mm): once the peg has stopped at the bound for
    press_fit.PRESS_WAIT the bound becomes PRESS_MARGIN times the line through the climb, and
    rises with the depth as the press's friction does."""
    depths, forces, bounds = _press(1e4)
    n_climb = round(PUSH / 1e4 / (5e-3 * DT))
    assert np.all(bounds[: n_climb + 90] == PUSH)
    line = 1e4 * (depths - 1e-3)
    late = slice(n_climb + 300, None)  # pressed on
    np.testing.assert_allclose(bounds[late], press_fit.PRESS_MARGIN * np.maximum(line[late], PUSH),
                               rtol=0.02)  # fmt: skip
    assert bounds[-1] > 1.4 * press_fit.PRESS_MARGIN * PUSH
    assert np.all(forces[late] < bounds[late])  # the press goes on


@pytest.mark.parametrize(("case", "kwargs"), [
    ("a jam: 20 N within 40 µm", {"slope": 5e5}),
    ("sliding in at the bound at 1 mm/s", {"slope": 1e4, "slide": 1e-3}),
])  # fmt: skip
def test_a_jam_and_a_peg_sliding_in_at_the_bound_keep_push_limit(
    case: str, kwargs: dict[str, float]
) -> None:
    """Steeper than PRESS_SLOPE, or still going in at the bound: the bound stays push_limit
    throughout, and the load on past it (the next millimetre) does not raise it."""
    _, _, bounds = _press(**kwargs)
    assert np.all(bounds == PUSH), case


def test_a_load_that_falls_under_half_the_bound_forgets_its_line() -> None:
    depths, forces, bounds = _press(1e4)
    assert bounds[-1] > PUSH
    state = np.zeros(press_fit.N_STATE)
    for d, f in zip(depths, forces, strict=True):
        press_fit.bound(state, d, f, PUSH, DT)
    assert press_fit.bound(state, depths[-1], 0.4 * PUSH, PUSH, DT) == PUSH
    assert press_fit.bound(state, depths[-1] + 1e-4, 1.0 * PUSH, PUSH, DT) == PUSH


def _robust_clearance_parts(draws: list[dict[str, float]]) -> Outcome:
    """The robust_clearance study's parts (its law believes the 10 µm pair; Table II's radii
    drawn), each from its offset and tilts, held rigidly."""
    sc = validate({"geometry": {"hole_radius": 5.05e-3, "peg_radius": 5.04e-3,
                                "hole_depth": 0.01, "base_thickness": 0.005, "friction": 0.3,
                                "stiffness": 1.84e8},
                   "initial": {"dx": 0.0, "dy": 0.0, "theta_x": 0.0, "theta_y": 0.0},
                   "controller": {"type": "fbcc"}})  # fmt: skip
    parts = [dataclasses.replace(sc.geometry, hole_radius=d["hole"], peg_radius=d["peg"],
                                 stiffness=d["k"], friction=d["mu"]) for d in draws]  # fmt: skip
    initial = np.array([[d["dx"], d["dy"], 0.0, d["tx"], d["ty"]] for d in draws])
    outcome, _ = simulate(sc, "fbcc", initial=initial, geometries=parts, record=False)
    return outcome


#: Parts of the no-rim study (seed 0: trials 89, 253, 871) that its tolerances make 5-9 µm
#: interference fits: pushed by at most push_limit alone, each stopped 1.2-3.6 mm in at 20 N.
_PRESS_FITS = [
    {"hole": 5.046839e-3, "peg": 5.052033e-3, "k": 3.661e8, "mu": 0.4742,
     "dx": 5.40252e-5, "dy": -1.59828e-5, "tx": 0.0269568, "ty": 0.0223476},
    {"hole": 5.045851e-3, "peg": 5.055131e-3, "k": 5.811e8, "mu": 0.1837,
     "dx": 8.29315e-5, "dy": 4.73301e-5, "tx": -0.00559089, "ty": -0.0238775},
    {"hole": 5.049498e-3, "peg": 5.054733e-3, "k": 1.339e9, "mu": 0.389,
     "dx": -1.81313e-5, "dy": 5.23755e-6, "tx": -0.00835978, "ty": 0.0158271},
]  # fmt: skip


def test_parts_that_tolerances_make_press_fits_are_pressed_home() -> None:
    """The law believes them clearance fits; their friction grows with the engaged length and
    the bound follows it: each assembles, none near the back-off (250 N)."""
    outcome = _robust_clearance_parts(_PRESS_FITS)
    assert outcome.success.all(), (outcome.final_features[:, 2], outcome.peak_fz)
    assert not outcome.wrench_guard_tripped.any()
    assert np.all(outcome.peak_fz < 200.0), outcome.peak_fz
