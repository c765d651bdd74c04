"""Does the contact state help the law? (``fbcc-mapping-study --gate``)

The same drawn insertions (:func:`~fbcc_ros.core.sim.state_study.drawn_insertions`: parts and
deviations under the estimator's uncertainty, at one stiffness) run three ways:

* **the law alone**: the robust law as shipped;
* **gated by the filter**: :class:`~fbcc_ros.core.control.state_gate.StateGatedLaw` with the
  deviation filter fed as the controller feeds it;
* **gated by the truth**: the same gate told the true state at those samples, the best any
  estimator could do with this gate;
* **tilts gated by the truth**: that gate on the tilt rows alone.

Each is scored by the simulator's metrics (success, time, peak Fz, tilt overshoot and
misadjustment); the gated runs also count how often the gate held a row, and the filter's run how
often the sign it stated was the true one.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.features import true_features
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import STATES, feature_state
from fbcc_ros.core.control.contact_uncertainty import Uncertainty
from fbcc_ros.core.control.robust import RobustFbcc
from fbcc_ros.core.control.state_feed import FeedSample
from fbcc_ros.core.control.state_gate import (
    StateGatedLaw,
    StateSource,
    filter_source,
    stated_signs,
)
from fbcc_ros.core.sim.scenario import Scenario
from fbcc_ros.core.sim.simulation import Outcome, simulate
from fbcc_ros.core.sim.state_study import drawn_insertions
from fbcc_ros.core.sim.study_goals import targets

#: The arms of the study, in the order they run.
ARMS = ("law alone", "gated by the filter", "gated by the truth", "tilts gated by the truth")
_INDEX = {s: i for i, s in enumerate(STATES)}


def truth_source(sc: Scenario, parts: list[PegHole], dev: FloatArray) -> StateSource:
    """The true state of each trial's pose (its part, its hole's deviation), one-hot."""

    def source(trial: int, sample: FeedSample) -> FloatArray:
        x = true_features(sample.now, dev[trial], sc.geometry.peg_radius,
                          parts[trial].peg_radius)[0]  # fmt: skip
        x[2] = max(x[2], 0.0)
        p = np.zeros((2, len(STATES)))
        for plane, state in enumerate(feature_state(x, parts[trial])):
            p[plane, _INDEX[str(state)]] = 1.0
        return p

    return source


@dataclasses.dataclass
class SignTally:
    """How often the gate's source stated a sign, and how often the true one (per row kind)."""

    stated: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(2, dtype=np.int64))
    right: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(2, dtype=np.int64))

    def checked(self, source: StateSource, truth: StateSource, confidence: float) -> StateSource:
        """``source``, counting its stated signs against ``truth``'s."""

        def counted(trial: int, sample: FeedSample) -> FloatArray:
            p = source(trial, sample)
            said = stated_signs(p, confidence)
            true = stated_signs(truth(trial, sample), 1.0)
            on = said != 2
            self.stated += on.sum(axis=0)
            self.right += (on & (said == true)).sum(axis=0)
            return p

        return counted


def summary(outcome: Outcome, deadline: float) -> dict[str, Any]:
    """An arm's figures over its trials; ``deadline`` the time goal [s] (study_goals.targets)."""
    t = outcome.insertion_time
    done = t[np.isfinite(t)]
    return {
        "trials": len(t),
        "success": float(outcome.success.mean()),
        "force_limited": int(outcome.force_limited.sum()),
        "time_median": float(np.median(done)) if len(done) else math.nan,
        "time_max": float(done.max()) if len(done) else math.nan,
        "over_time_goal": int((done > deadline).sum()),
        "peak_fz_median": float(np.median(outcome.peak_fz)),
        "tilt_overshoot_max_deg": math.degrees(float(outcome.tilt_overshoot.max())),
        "misadjustment_max_deg": math.degrees(float(outcome.tilt_misadjustment.max())),
        "residual_max": float(outcome.residual_force.max()),
    }


def _gate(source: StateSource, confidence: float, made: list[StateGatedLaw],
          tilts_only: bool = False) -> Callable[[Any], StateGatedLaw]:  # fmt: skip
    """``simulate``'s wrap: the robust law behind the gate, kept in ``made``."""

    def wrap(law: Any) -> StateGatedLaw:
        if not isinstance(law, RobustFbcc):
            raise TypeError("the gate acts on the robust law's integrators")
        made.append(StateGatedLaw(law, source, confidence, tilts_only=tilts_only))
        return made[-1]

    return wrap


def gate_study(sc: Scenario, unc: Uncertainty, stiffness: float, trials: int, seed: int,
               confidence: float = 0.9, particles: int = 4000,
               progress: Callable[[str], None] | None = None,
               ) -> dict[str, Any]:  # fmt: skip
    """The three arms (module doc) on ``trials`` insertions of parts of ``stiffness`` [Pa]."""
    parts, dev = drawn_insertions(sc, unc, stiffness, trials, seed)
    truth = truth_source(sc, parts, dev)
    tally = SignTally()
    sources = {"gated by the filter": tally.checked(
        filter_source(sc.geometry, trials, unc, seed, particles=particles), truth, confidence),
        "gated by the truth": truth, "tilts gated by the truth": truth}  # fmt: skip
    out: dict[str, Any] = {}
    for arm in ARMS:
        gates: list[StateGatedLaw] = []
        wrap = (_gate(sources[arm], confidence, gates, tilts_only=arm.startswith("tilts"))
                if arm in sources else None)  # fmt: skip
        outcome, _ = simulate(sc, "fbcc", initial=dev, geometries=parts, seed=seed,
                              record=False, wrap=wrap)  # fmt: skip
        out[arm] = summary(outcome, targets(sc).deadline)
        if gates:
            g = gates[0]
            periods = sc.steps * trials
            out[arm]["rows_gated"] = float(g.gated.sum() / (4 * periods))
            out[arm]["rows_held"] = float(g.held.sum() / (4 * periods))
        if progress is not None:
            progress(arm)
    out["gated by the filter"]["signs_right"] = {
        kind: float(tally.right[r] / tally.stated[r]) if tally.stated[r] else None
        for r, kind in enumerate(("offset", "tilt"))}  # fmt: skip
    return out
