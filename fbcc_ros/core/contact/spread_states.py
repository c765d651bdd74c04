"""The states of one plane for features known only to within a normal spread (the deviation
filter's readout, :mod:`~fbcc_ros.core.control.deviation_filter`): P(state) per row, and the
weighted vote of many rows. The bands and eq. 15's no-contact region are
those of :func:`~fbcc_ros.core.contact.segmentation.plane_state_index`."""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.segmentation import OFFSET_TOL, STATE_INDEX, STATES, TILT_TOL
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.vector_math import normal_cdf

_P0 = STATES.index("P0")


class SpreadStates(NamedTuple):
    """The states of one plane's features known to within a normal spread
    (:func:`spread_states`), per row: P(in eq. 15's no-contact region) (N,), and P(sign -1, 0,
    +1) of the tilt and, outside the region, of the offset, both (N, 3). The two signs are
    independent."""

    inside: FloatArray
    tilt_sign: FloatArray
    offset_sign: FloatArray

    def probabilities(self) -> FloatArray:
        """P(state) per row, shape (N, 9) over :data:`STATES`."""
        out = np.zeros((len(self.inside), len(STATES)))
        out[:, _P0] = self.inside
        for i in range(3):
            for j in range(3):
                out[:, STATE_INDEX[i, j]] += self.tilt_sign[:, i] * self.offset_sign[:, j]
        return out

    def vote(self, weights: FloatArray) -> FloatArray:
        """``weights @ probabilities()``, shape (9,), without the (N, 9) table (the deviation
        filter's readout, at every update)."""
        out = np.zeros(len(STATES))
        _weighted_joint(np.ascontiguousarray(weights, dtype=float), self.inside,
                        self.tilt_sign.T, self.offset_sign.T, STATE_INDEX, out)  # fmt: skip
        return out


@numba.njit(cache=True)  # type: ignore[misc]
def _weighted_joint(weights: FloatArray, inside: FloatArray, tilt_sign: FloatArray,
                    offset_sign: FloatArray, index: NDArray[np.int64],
                    out: FloatArray) -> None:  # fmt: skip
    """out[state] = Σ weight · P(state): P0 inside eq. 15's region, else P(tilt sign i) ·
    P(offset sign j), summed per pair (i, j); the signs' probabilities in rows (3, N)."""
    joint, free = np.zeros((3, 3)), 0.0
    for p in range(weights.shape[0]):
        free += weights[p] * inside[p]
        for i in range(3):
            wt = weights[p] * tilt_sign[i, p]
            for j in range(3):
                joint[i, j] += wt * offset_sign[j, p]
    for i in range(3):
        for j in range(3):
            out[index[i, j]] = joint[i, j]
    out[_P0] += free


def spread_states(
    offset: FloatArray,
    tilt: FloatArray,
    depth: FloatArray,
    hole_radius: float | FloatArray,
    peg_radius: float,
    offset_spread: float,
    tilt_spread: float,
) -> SpreadStates:
    """The states of one plane for features known to within a normal spread: offset ~
    N(offset, offset_spread²), tilt ~ N(tilt, tilt_spread²), both > 0, independent; the bands
    as :func:`plane_state_index`'s. Eq. 15's no-contact region, |offset| <= m with
    m = R - r cos(θ) - l |sin(θ)| / 2, is taken at the tilt given (at 10 mm deep a tilt spread
    of 0.03 mrad would move m by 0.15 µm)."""
    rows = _spread_rows(offset, tilt, depth, hole_radius, offset_spread, tilt_spread)
    n = len(rows[0])
    inside, tilt_sign, offset_sign = np.empty(n), np.empty((3, n)), np.empty((3, n))
    _factor_rows(*rows, float(peg_radius), float(offset_spread), float(tilt_spread), inside,
                 tilt_sign, offset_sign)  # fmt: skip
    return SpreadStates(inside, tilt_sign.T, offset_sign.T)


def _spread_rows(offset: FloatArray, tilt: FloatArray, depth: FloatArray,
                 hole_radius: float | FloatArray, offset_spread: float,
                 tilt_spread: float,
                 ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:  # fmt: skip
    """The offset, tilt, depth and hole radius per row, contiguous, for :func:`_factor_rows`;
    the spreads checked."""
    if not (offset_spread > 0 and tilt_spread > 0):
        raise ConfigError("spread", [offset_spread, tilt_spread], "offset and tilt spreads > 0")
    d = np.ascontiguousarray(offset, dtype=float)

    def per_row(v: float | FloatArray) -> FloatArray:
        rows = v if np.shape(v) == d.shape else np.broadcast_to(v, d.shape)  # (a view: slow)
        return np.ascontiguousarray(rows, dtype=float)

    return d, per_row(tilt), per_row(depth), per_row(hole_radius)


@numba.njit(cache=True, error_model="numpy")  # type: ignore[misc]
def _factor_rows(d: FloatArray, t: FloatArray, l: FloatArray, hole: FloatArray, peg: float,
                 sd: float, st: float, inside: FloatArray, tilt_sign: FloatArray,
                 offset_sign: FloatArray) -> None:  # fmt: skip
    """:func:`spread_states` row by row, the signs' probabilities in rows (3, N). The normal
    CDFs are in a loop without a call or a branch on a row's values, which vectorises
    (:mod:`~fbcc_ros.core.vector_math`); eq. 15's margin, whose cosine and sine are calls, and
    only a clearance's, before it."""
    margin = np.empty(d.shape[0])
    for i in range(d.shape[0]):
        margin[i] = -math.inf  # |d| <= margin: no contact (eq. 15); none for an interference
        if peg < hole[i]:
            margin[i] = hole[i] - peg * math.cos(t[i]) - l[i] * abs(math.sin(t[i])) / 2.0
    for i in range(d.shape[0]):
        tilt_sign[0, i] = normal_cdf((-TILT_TOL - t[i]) / st)
        tilt_sign[2, i] = normal_cdf((t[i] - TILT_TOL) / st)
        tilt_sign[1, i] = 1.0 - tilt_sign[0, i] - tilt_sign[2, i]
        m = margin[i] if margin[i] > 0.0 else 0.0
        # outside the region the offset's sign is beyond the wider of its band and the margin
        cut = margin[i] if margin[i] > OFFSET_TOL else OFFSET_TOL
        offset_sign[0, i] = normal_cdf((-cut - d[i]) / sd)
        offset_sign[2, i] = normal_cdf((d[i] - cut) / sd)
        # P(|offset| <= m), exactly 0 without a region (m = 0: both terms alike)
        inside[i] = normal_cdf((m - d[i]) / sd) - normal_cdf((-m - d[i]) / sd)
        # OFFSET_TOL >= |offset| > margin
        rest = 1.0 - inside[i] - offset_sign[0, i] - offset_sign[2, i]
        offset_sign[1, i] = rest if rest > 0.0 else 0.0
