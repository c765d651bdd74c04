"""The contact state as a gate on the robust law's adjustments (core/control/state_gate.py)
and the study that runs it (core/sim/gate_study.py)."""

from __future__ import annotations

import numpy as np
import pytest

from fbcc_ros.core.contact.segmentation import STATES
from fbcc_ros.core.control.contact_uncertainty import Uncertainty
from fbcc_ros.core.control.robust import RobustFbcc
from fbcc_ros.core.control.state_feed import FeedSample
from fbcc_ros.core.control.state_gate import StateGatedLaw, stated_signs, vetoed
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.gate_study import ARMS, gate_study
from fbcc_ros.core.sim.simulation import simulate


def _one_hot(xoz: str, yoz: str) -> np.ndarray:
    p = np.zeros((2, len(STATES)))
    p[0, STATES.index(xoz)] = p[1, STATES.index(yoz)] = 1.0
    return p


def test_a_sign_is_stated_from_its_marginal_at_the_confidence() -> None:
    """D1 is dx > 0 and θy > 0; D^-1 dx < 0 and θ < 0; P0 zero in both. A sign is stated
    from the sum over the states that have it: D1 0.5 + P1 0.45 states the offset's + at 0.95,
    not the tilt (0.5 / 0.45 / 0.05)."""
    signs = stated_signs(_one_hot("D1", "D^-1"), 0.9)
    assert signs.tolist() == [[1, 1], [-1, -1]]
    assert stated_signs(_one_hot("P0", "D^0"), 0.9).tolist() == [[0, 0], [0, -1]]
    p = np.zeros((2, len(STATES)))
    p[:, STATES.index("D1")], p[:, STATES.index("P1")], p[:, STATES.index("D^-1")] = (
        0.5, 0.45, 0.05)  # fmt: skip
    assert stated_signs(p, 0.9).tolist() == [[1, 2], [1, 2]]
    assert stated_signs(p, 0.5).tolist() == [[1, 1], [1, 1]]


def test_only_a_move_away_from_the_stated_zero_is_held() -> None:
    """A rise of an integrator moves its feature down. Stated dx > 0: a rise (toward zero) is
    let through, a fall held; ambiguous (2) or within its band (0): nothing held."""
    signs = np.array([[[1, -1], [2, 0]]] * 2)  # XOZ: dx +, θy -; YOZ: dy ?, θx 0
    step = np.array([[1e-6, -1e-6, 0.0, 1e-4, -1e-4],
                     [-1e-6, 1e-6, 0.0, -1e-4, 1e-4]])  # fmt: skip
    held = vetoed(signs, step)
    # row 0: dx rises (toward zero: let through); θy falls, i.e. θy rises (toward zero of a
    # negative θy: let through). Row 1: both move away: held. dy, θx: never held.
    assert held.tolist() == [[False, False, False, False, False],
                             [True, False, False, False, True]]  # fmt: skip


def test_a_gated_law_never_moves_a_feature_away_from_its_stated_zero() -> None:
    """Told D1 (dx > 0, θy > 0) throughout, the law's dx and θy integrators never fall over a
    whole insertion (they would move the peg to larger dx and θy), while alone they do: the
    gate is what holds them."""
    sc = scenario_io.load(scenario_io.find("config/scenarios/robust_clearance.yaml"))
    dev = np.array([[-8e-5, 5e-5, 0.0, 0.02, -0.03]])  # the truth disagrees with the source

    def told(_trial: int, _sample: FeedSample) -> np.ndarray:
        return _one_hot("D1", "D1")

    def run(gated: bool, tilts_only: bool = False) -> tuple[np.ndarray, np.ndarray]:
        history: list[np.ndarray] = []

        class Watched(StateGatedLaw):
            def step(self, response: np.ndarray, features: np.ndarray, dt: float
                     ) -> np.ndarray:  # fmt: skip
                command = super().step(response, features, dt)
                history.append(self.law.adjustments()[0])
                return command

        def wrap(law: RobustFbcc) -> StateGatedLaw:
            return Watched(law, told if gated else (lambda *_: np.full((2, 9), 1 / 9)),
                           tilts_only=tilts_only)

        simulate(sc, "fbcc", initial=dev, record=False, wrap=wrap)
        ints = np.array(history)
        return np.diff(ints[:, 0]), np.diff(ints[:, 4])

    d_dx, d_thy = run(gated=True)
    assert d_dx.min() >= 0.0 and d_thy.min() >= 0.0
    d_dx, d_thy = run(gated=False)  # ambiguous source: the law alone
    assert d_dx.min() < 0.0 and d_thy.min() < 0.0
    d_dx, d_thy = run(gated=True, tilts_only=True)  # the offsets' signs unused
    assert d_dx.min() < 0.0 and d_thy.min() >= 0.0


def test_the_gate_refuses_a_confidence_that_is_not_a_majority() -> None:
    law = RobustFbcc(scenario_io.load(scenario_io.find(
        "config/scenarios/robust_clearance.yaml")).geometry)  # fmt: skip
    with pytest.raises(ConfigError, match="confidence"):
        StateGatedLaw(law, lambda *_: np.zeros((2, 9)), confidence=0.5)


def test_the_gate_study_runs_the_same_insertions_each_way() -> None:
    """Each arm is scored on the same insertions; the gated arms count what they gated and
    held, and the filter's signs are scored against the truth."""
    sc = scenario_io.load(scenario_io.find("config/scenarios/robust_interference.yaml"))
    r = gate_study(sc, Uncertainty(), 5e8, 2, seed=3, particles=500)
    assert list(r) == list(ARMS)
    assert r["law alone"]["trials"] == 2 and "rows_held" not in r["law alone"]
    # the tilts alone are gated at most as often as both rows
    assert r["tilts gated by the truth"]["rows_gated"] <= r["gated by the truth"]["rows_gated"]
    for arm in ARMS[1:]:
        assert 0.0 <= r[arm]["rows_held"] <= r[arm]["rows_gated"] <= 1.0
    right = r["gated by the filter"]["signs_right"]
    assert all(v is None or 0.0 <= v <= 1.0 for v in right.values())
    # until the features are within their bands (sign 0) the truth signs them
    assert r["gated by the truth"]["rows_gated"] > 0.05
