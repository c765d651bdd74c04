"""How often the contact state is named right (``fbcc-mapping-study --estimator``): the
paper's sector rule, our boundary mapping and the contact-state estimator
(:mod:`fbcc_ros.core.control.contact_state`), against the state of the true features
(:func:`~fbcc_ros.core.contact.segmentation.feature_state` on the true part).

* **Drawn responses**: per state of XOZ, features drawn inside it on parts drawn from the
  estimator's :class:`~fbcc_ros.core.control.contact_uncertainty.Uncertainty` (with their own seed,
  and either way of drawing magnitudes), responses with the sensor's noise; each classified
  from that one response.
* **Along insertions**: the simulator's closed loop (the scenario's law, the robust one by
  default) on parts drawn alike at a given stiffness, deviations uniform within the ranges;
  in-hole samples of both planes, classified from that response alone, and by the deviation
  filter (:mod:`fbcc_ros.core.control.deviation_filter`) from the responses and poses so far.

The sector rule is Fig. 6 read literally: the side of the vertical axis and of the tilted
line, a boundary state only on its line (``response_state`` with zero bands, which names none
of them in practice). Boundary mapping is ``response_state`` with its bands.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import ContactBatch, PegHole
from fbcc_ros.core.contact.segmentation import STATES, feature_state, response_state
from fbcc_ros.core.control.contact_state import ContactStateEstimator, most_probable
from fbcc_ros.core.control.contact_uncertainty import Uncertainty, draw_in_state
from fbcc_ros.core.control.deviation_filter import along
from fbcc_ros.core.sim.scenario import Scenario
from fbcc_ros.core.sim.simulation import simulate

#: The bins of the stated probability in which the calibration is counted.
CALIBRATION_EDGES = (0.0, 0.3, 0.5, 0.7, 0.9, 0.99, 1.0 + 1e-9)
_INDEX = {s: i for i, s in enumerate(STATES)}
#: The level of a share's interval over insertions, and the bootstrap's draws.
INTERVAL_LEVEL = 0.95
RESAMPLES = 10_000
#: A part is drawn only if its quasi-static push-in is within this share of the force limit
#: (as ``fbcc-montecarlo`` draws them).
PUSH_IN_SHARE = 2.0 / 3.0


@dataclasses.dataclass
class Tally:
    """A confusion matrix over :data:`STATES` (``confusion[truth, named]``) and, for a method
    that states a probability, how often it was right per bin of it (CALIBRATION_EDGES)."""

    confusion: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros((len(STATES), len(STATES)), dtype=np.int64))
    stated: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(len(CALIBRATION_EDGES) - 1, dtype=np.int64))
    right: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(len(CALIBRATION_EDGES) - 1, dtype=np.int64))
    #: Σ of the stated probabilities per bin (their mean, for the calibration error)
    stated_sum: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(len(CALIBRATION_EDGES) - 1))
    #: (right, samples, stratum) of each insertion added as one (the unit :meth:`interval`
    #: resamples, within its stratum: the tally's index among those :meth:`pooled`)
    insertions: list[tuple[int, int, int]] = dataclasses.field(default_factory=list)

    def add(self, truth: np.ndarray, named: np.ndarray, probability: FloatArray | None = None,
            insertion: bool = False) -> None:  # fmt: skip
        """Count named states against the true ones; ``insertion``: these are one insertion's
        samples, kept apart for :meth:`interval`."""
        t = np.array([_INDEX[s] for s in truth.ravel()], dtype=np.int64)
        n = np.array([_INDEX[s] for s in named.ravel()], dtype=np.int64)
        np.add.at(self.confusion, (t, n), 1)
        if insertion and len(t):
            self.insertions.append((int(np.sum(t == n)), len(t), 0))
        if probability is not None:
            b = np.searchsorted(CALIBRATION_EDGES, probability.ravel(), side="right") - 1
            np.add.at(self.stated, b, 1)
            np.add.at(self.right, b, (t == n).astype(np.int64))
            np.add.at(self.stated_sum, b, probability.ravel())

    @property
    def accuracy(self) -> float:
        total = self.confusion.sum()
        return float(np.trace(self.confusion) / total) if total else math.nan

    def interval(self, level: float = INTERVAL_LEVEL) -> tuple[float, float] | None:
        """A ``level`` interval of :attr:`accuracy` over the insertions (None under two): the
        samples of one insertion are not independent, its insertions are. The percentile
        bootstrap of Σ right / Σ samples over :data:`RESAMPLES` draws of the insertions with
        replacement, each stratum's count drawn from it (a pooled study ran so many at each
        stiffness), seeded, so a study's table is reproducible. It can only resample the
        insertions it has: where lost insertions (named 0.3-0.7 right) are rare, a draw of 48
        often holds none, and the lower bound is then too high (simulated, 48 insertions of
        which 6 % or 3 % are lost: the share fell under it 10 % or 25 % of the time, not
        2.5 %). Many insertions, several seeds, are what bound a share from below."""
        if len(self.insertions) < 2:
            return None
        right, samples, stratum = np.array(self.insertions, dtype=float).T
        rng = np.random.default_rng(0)
        picked_right = np.zeros(RESAMPLES)
        picked_samples = np.zeros(RESAMPLES)
        for s in np.unique(stratum):
            members = np.flatnonzero(stratum == s)
            pick = members[rng.integers(0, len(members), (RESAMPLES, len(members)))]
            picked_right += right[pick].sum(axis=1)
            picked_samples += samples[pick].sum(axis=1)
        lo, hi = np.quantile(picked_right / picked_samples, [(1 - level) / 2, (1 + level) / 2])
        return float(lo), float(hi)

    @classmethod
    def pooled(cls, tallies: list[Tally]) -> Tally:
        """The tallies' samples and insertions as one tally, each tally's insertions a stratum
        of :meth:`interval`."""
        out = cls()
        for k, t in enumerate(tallies):
            for name in ("confusion", "stated", "right", "stated_sum"):
                getattr(out, name)[...] += getattr(t, name)
            out.insertions += [(right, n, k) for right, n, _ in t.insertions]
        return out

    def per_state(self) -> dict[str, tuple[float, int]]:
        """Per true state: the share named right and the samples."""
        rows = self.confusion.sum(axis=1)
        return {s: (float(self.confusion[i, i] / rows[i]), int(rows[i]))
                for i, s in enumerate(STATES) if rows[i]}  # fmt: skip

    def as_dict(self) -> dict[str, object]:
        interval = self.interval()
        return {"accuracy": self.accuracy, "samples": int(self.confusion.sum()),
                "insertions": len(self.insertions),
                "interval": None if interval is None else list(interval),
                "per_state": {s: {"accuracy": a, "samples": n}
                              for s, (a, n) in self.per_state().items()},
                "confusion": self.confusion.tolist(), "calibration": self.calibration()}

    def calibration_error(self) -> float:
        """The expected calibration error: Σ over the bins of their share of the stated samples
        times |share right - mean stated|."""
        n = self.stated
        has = n > 0
        return float(np.sum(np.abs(self.stated_sum[has] - self.right[has])) / n.sum())

    def calibration(self) -> list[dict[str, Any]]:
        """Per bin of the stated probability that has samples: the bin, the samples and the
        share right."""
        return [{"stated": [lo, min(hi, 1.0)], "samples": int(n), "right": float(r / n)}
                for lo, hi, n, r in zip(CALIBRATION_EDGES[:-1], CALIBRATION_EDGES[1:],
                                        self.stated, self.right, strict=True)
                if n]  # fmt: skip


def calibration_text(calibration: list[dict[str, Any]]) -> str:
    """A tally's calibration (:meth:`Tally.calibration`) in one line: each bin of the stated
    probability, the share right and the samples."""
    return "; ".join(f"{c['stated'][0]:.2f}–{c['stated'][1]:.2f}: {c['right']:.2f} "
                     f"({c['samples']})" for c in calibration)  # fmt: skip


def sector_rule(response: FloatArray, depth: FloatArray, nominal: PegHole) -> np.ndarray:
    """Fig. 6 read literally (module doc): states (N, 2)."""
    return np.column_stack(response_state(response, depth, nominal, offset_band=0.0,
                                          tilt_band=0.0))  # fmt: skip


def drawn_study(estimator: ContactStateEstimator, per_state: int, seed: int,
                magnitudes: str = "log", parts_per_state: int = 20,
                ) -> dict[str, Tally]:  # fmt: skip
    """Each method on ``per_state`` drawn responses per state of XOZ (module doc)."""
    nominal = estimator.nominal
    unc = dataclasses.replace(estimator.uncertainty, magnitudes=magnitudes)
    rng = np.random.default_rng(seed)
    feats, parts, truth = [], [], []
    for state in STATES:
        for _ in range(parts_per_state):
            part = unc.part(nominal, rng)
            f = draw_in_state(state, max(1, per_state // parts_per_state), part, unc, rng)
            feats.append(f)
            parts += [part] * len(f)
            truth += [state] * len(f)
    f = np.concatenate(feats)
    w = unc.noisy(ContactBatch.of(parts).response(f), rng)
    t = np.asarray(truth, dtype=object)
    tallies = {name: Tally() for name in ("sector rule", "boundary mapping", "estimator")}
    tallies["sector rule"].add(t, sector_rule(w, f[:, 2], nominal)[:, 0])
    tallies["boundary mapping"].add(t, np.asarray(response_state(w, f[:, 2], nominal)[0]))
    named, p = most_probable(estimator.probabilities(w, f[:, 2])[:, 0])
    tallies["estimator"].add(t, named, p)
    return tallies


def drawn_insertions(sc: Scenario, unc: Uncertainty, stiffness: float, trials: int, seed: int,
                     ) -> tuple[list[PegHole], FloatArray]:  # fmt: skip
    """``trials`` parts drawn by ``unc`` around the scenario's geometry at ``stiffness`` [Pa]
    and their holes' deviations (N, 5), uniform within the ranges (module doc)."""
    rng = np.random.default_rng(seed)
    nominal = sc.geometry.replace(stiffness=stiffness)
    parts: list[PegHole] = []
    while len(parts) < trials:  # as fbcc-montecarlo: a part no controller can push in is not
        part = unc.part(nominal, rng)  # drawn (its push-in over 2/3 of the force limit)
        if part.push_in_force() <= PUSH_IN_SHARE * sc.params.F_ext_limit:
            parts.append(part)
    lateral = rng.uniform(-1.0, 1.0, (trials, 4)) * np.array(
        [unc.max_offset, unc.max_offset, unc.max_tilt, unc.max_tilt])
    return parts, np.column_stack([lateral[:, :2], np.zeros(trials), lateral[:, 2:]])


def trajectory_study(sc: Scenario, estimator: ContactStateEstimator, stiffness: float,
                     trials: int, seed: int, law: str = "fbcc", stride: int = 5,
                     particles: int = 4000,
                     progress: Callable[[int, int], None] | None = None,
                     ) -> tuple[dict[str, Tally], float]:  # fmt: skip
    """Each method along ``trials`` simulated insertions of parts of ``stiffness`` [Pa]
    (module doc), at the samples the deviation filter updates at
    (:func:`~fbcc_ros.core.control.deviation_filter.along`: every ``stride``-th from the first
    measured contact) that are in the hole. Returns the tallies and the share of
    insertions that succeeded; ``progress(done, trials)`` after each insertion."""
    unc = estimator.uncertainty
    parts, dev = drawn_insertions(sc, unc, stiffness, trials, seed)
    outcome, traj = simulate(sc, law, initial=dev, geometries=parts, seed=seed)
    assert traj is not None  # record=True
    tallies = {name: Tally() for name in ("boundary mapping", "estimator, one response",
                                          "estimator, history")}  # fmt: skip
    for i in range(trials):
        x, w, pose = traj.features[:, i], traj.measured[:, i], traj.pose[:, i]
        # the filter as the controller and the report run it: every stride-th sample from the
        # first measured contact
        # its nominal part is the case's: the user states k, to within the uncertainty
        rows, named = along(pose, w, sc.geometry.replace(stiffness=stiffness), stride,
                            uncertainty=unc, particles=particles, seed=seed + i)  # fmt: skip
        inside = x[rows, 2] > 0  # scored in the hole, where a true state is named
        scored = rows[inside]
        truth = np.array([feature_state(x[k], parts[i]) for k in scored], dtype=object)
        depth = np.maximum(pose[scored, 2], 0.0)  # what the robot measures
        ws = w[scored]
        tallies["boundary mapping"].add(
            truth, np.column_stack(response_state(ws, depth, sc.geometry)), insertion=True)
        tallies["estimator, one response"].add(
            truth, *most_probable(estimator.probabilities(ws, depth)), insertion=True)
        tallies["estimator, history"].add(truth, *most_probable(named[inside]), insertion=True)
        if progress is not None:
            progress(i + 1, trials)
    return tallies, float(outcome.success.mean())
