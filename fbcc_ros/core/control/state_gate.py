"""The contact state as a gate on the robust law's adjustments: does knowing the state help?

The robust law (:mod:`fbcc_ros.core.control.robust`) moves each feature by the sign of its
filtered row, whatever the state. A state names the sign of each plane's offset and tilt
(``segmentation.SIGNS``: D1 is dx > 0 and θy > 0 in XOZ). This gate, per row of a plane:

* takes the marginal of that sign, ``P(s) = Σ P(state)`` over the states with sign s;
* when a sign ±1 is stated with ``P(s) >= confidence``, lets the row move only toward that
  feature's zero;
* otherwise (ambiguous, or the feature within its band) leaves the law alone. Holding a row
  whose feature is within its band (sign 0) was tried: told the true state, it held 83 % of the
  rows' periods and left up to 2 N of lateral force at the depth, since the law settles forces,
  and a peg within its band can still press (a tilt's eq. 20 shift). With ``tilts_only`` the
  offsets' signs are not used: the tilt rows alone are gated.

A vetoed row's integrator returns to where it was before the period
(:meth:`RobustFbcc.hold_adjustments`), so the veto acts from the next command on (one period
late). The state comes from a source: the deviation filter along the insertion
(:class:`~fbcc_ros.core.control.deviation_filter.DeviationFilter`, fed as the controller feeds
it), or, in the simulator, the true state (the gate's best case). ``fbcc-mapping-study --gate``
measures both against the law alone (docs/boundary-mapping.md).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import SIGNS, STATES
from fbcc_ros.core.control.contact_uncertainty import Uncertainty
from fbcc_ros.core.control.deviation_filter import DeviationFilter
from fbcc_ros.core.control.robust import RobustFbcc
from fbcc_ros.core.control.state_feed import FeedSample, StateFeed
from fbcc_ros.core.errors import ConfigError

#: The rows of each plane in feature order (dx, dy, l, θx, θy): (offset, tilt).
PLANE_ROWS = ((0, 4), (1, 3))
#: sign_of[k, s + 1]: 1 where state k has sign s, for the offset (k, 0) and the tilt (k, 1).
_SIGN_OF = np.zeros((len(STATES), 2, 3))
for _k, (_d, _t) in enumerate(SIGNS):
    _SIGN_OF[_k, 0, _d + 1] = _SIGN_OF[_k, 1, _t + 1] = 1.0

#: Where a trial's states come from: ``source(trial, sample)`` at a sample the feed takes (what
#: it hands the filter), P(state) (2, 9) of XOZ and YOZ.
StateSource = Callable[[int, FeedSample], FloatArray]


def stated_signs(p_states: ArrayLike, confidence: float) -> np.ndarray:
    """Per plane and row (offset, tilt) the sign stated with at least ``confidence`` (-1, 0,
    1), or 2 where none is: P(state) (..., 2, 9) gives (..., 2, 2) ints."""
    marginal = np.einsum("...k,kar->...ar", np.asarray(p_states, dtype=float), _SIGN_OF)
    best = marginal.argmax(axis=-1)
    sure = np.take_along_axis(marginal, best[..., None], axis=-1)[..., 0] >= confidence
    return np.where(sure, best - 1, 2)


def vetoed(signs: np.ndarray, step: FloatArray) -> np.ndarray:
    """Which rows a period's adjustment ``step`` (N, 5; a rise moves the feature down) may not
    make under the stated ``signs`` (N, 2, 2) (module doc): (N, 5) bool."""
    held = np.zeros(step.shape, dtype=bool)
    for plane, rows in enumerate(PLANE_ROWS):
        for r, f in enumerate(rows):
            s = signs[:, plane, r]
            away = np.sign(step[:, f]) * s < 0  # the feature moves away from its zero
            held[:, f] = (np.abs(s) == 1) & away
    return held


class StateGatedLaw:
    """The robust law behind the gate (module doc): the law's interface (``reset``, ``step``,
    ``stopped``, ``trips``) for the simulator's batch, one state source per trial, updated at
    the samples a :class:`StateFeed` of ``every`` takes.

    Attributes:
        held: Row-periods vetoed, per trial and feature (N, 5).
        gated: Row-periods a sign ±1 was stated for (the gate could act), per trial and
            feature.
    """

    def __init__(self, law: RobustFbcc, source: StateSource, confidence: float = 0.9,
                 every: int = 5, tilts_only: bool = False) -> None:  # fmt: skip
        if not 0.5 < confidence <= 1.0:
            raise ConfigError("confidence", confidence, "a probability in (0.5, 1]")
        self.law, self.source, self.confidence, self.every = law, source, confidence, every
        #: gate the tilt rows alone (the offsets' signs are not used)
        self.tilts_only = tilts_only

    @property
    def stopped(self) -> np.ndarray:
        return self.law.stopped

    @property
    def trips(self) -> FloatArray:
        return self.law.trips

    @property
    def lever_frictions(self) -> FloatArray:
        return self.law.lever_frictions

    def reset(self, features: ArrayLike) -> None:
        self.law.reset(features)
        n = len(np.atleast_2d(features))
        self._feeds = [StateFeed(self.every) for _ in range(n)]
        self._signs = np.full((n, 2, 2), 2)
        self.held = np.zeros((n, 5), dtype=np.int64)
        self.gated = np.zeros((n, 5), dtype=np.int64)

    def step(self, response: FloatArray, features: FloatArray, dt: float) -> FloatArray:
        for i, feed in enumerate(self._feeds):
            if (sample := feed.take(features[i], response[i])) is not None:
                self._signs[i] = stated_signs(self.source(i, sample),
                                              self.confidence)  # fmt: skip
                if self.tilts_only:
                    self._signs[i, :, 0] = 2
        before = self.law.adjustments()
        command = self.law.step(response, features, dt)
        held = vetoed(self._signs, self.law.adjustments() - before)
        self.law.hold_adjustments(held, before)
        self.held += held
        on = np.abs(self._signs) == 1
        for plane, rows in enumerate(PLANE_ROWS):
            for r, f in enumerate(rows):
                self.gated[:, f] += on[:, plane, r]
        return command


def filter_source(nominal: PegHole, trials: int, uncertainty: Uncertainty | None = None,
                  seed: int = 0, **options: object) -> StateSource:  # fmt: skip
    """A deviation filter per trial (seeds ``seed + trial``), as the controller runs it."""
    filters = [DeviationFilter(nominal, uncertainty, seed=seed + i, **options)  # type: ignore[arg-type]
               for i in range(trials)]  # fmt: skip

    def source(trial: int, sample: FeedSample) -> FloatArray:
        return filters[trial].update(*sample)

    return source
