"""Online contact identification: the local stiffness of each controlled row, and friction.

The robust FBCC law (:mod:`fbcc_ros.core.robust`) schedules its gains by the contact it meets,
so it needs, while in contact, the local slope of each direction row ``u_j = (A(l) F)_j``
(eq. 28; rows dx, dy, theta_x, theta_y) against its own feature:

.. math::
    k_j = \\frac{\\partial u_j}{\\partial x_j} \\quad [\\mathrm{N/m}\\ \\text{offsets},
    \\ \\mathrm{N/rad}\\ \\text{tilts}],

where ``x`` are the robot's measured features (with a compliant holder, the series stiffness of
holder and contact: what the command actually meets).

**Model and estimator.** Per row, a recursive least-squares fit with exponential forgetting of
the increments from one sample to the next:

.. math::
    \\Delta u_j = k_j \\Delta x_j + b_j \\Delta l + c_j,

``b_j`` the row's sensitivity to the depth (the insertion itself presses the peg harder into the
wall), ``c_j`` the slow drift. Increments remove the unknown hole deviation (the operating point)
and the sensor bias; ``b_j`` keeps the depth motion from being read as stiffness. Excitation comes
from the controller's own adjustments and a small dither at a frequency of its own per row
(:mod:`fbcc_ros.core.robust`), so ``Δx_j`` is not collinear with ``Δl``.

**Gating and bounds.** The fit is updated only in contact (Fz or a row above its noise), so the
free-space samples of a clearance fit do not pull the stiffness to zero; the covariance is
bounded (its trace), so it does not wind up while the excitation is poor. The estimate the law
uses is bounded below by a model floor for the softest material the user allows
(``stiffness_min``, eq. 8's k in Pa) at the current depth, and falls no faster than the release
time constant: an underestimate raises the loop gain, so the estimate must err stiff.

Model floor, from finite differences of the contact model (eq. 5-13) at k = 1 GPa, both fits,
depths 1-10 mm (``test/core/test_identification.py`` pins it as a lower bound):
``k_offset >= 0.3 k l`` [N/m], ``k_tilt >= 1.5 k l^3`` [N/rad] (the smallest slopes seen over
random offsets and tilts in contact were 0.38 and 2.4).

**Friction.** With Coulomb friction the axial force is ``Fz = mu * sum of normal forces``
(eq. 11) and the lateral force is at most that sum, so ``Fz / |(Fx, Fy)| >= mu``. The estimate
is the lower envelope of that ratio (with a slow upward drift so an early low value can be
corrected): an upper bound on mu. For a peg pressed on one side the pressure spreads over an arc
and the bound is ~16 % above mu (pinned by a test); in a centred interference fit the ratio
stays large and the estimate stays at its prior.

The interface the rest of the package uses is :class:`ContactEstimate`.
"""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np

from fbcc_ros.core.contact import FloatArray

#: The controlled rows of A(l) F: features dx, dy, theta_x, theta_y (indices into 5-vectors).
ROWS = (0, 1, 3, 4)
#: Scale of the regressors (typical increments), so the RLS works on numbers near 1:
#: offsets in um, tilts in 0.1 mrad, depth in um.
ROW_SCALE = np.array([1e-6, 1e-6, 1e-4, 1e-4])
DEPTH_SCALE = 1e-6
#: Initial covariance of the RLS (in scaled units) and the bound on its trace.
P0 = 1e2
P_TRACE_MAX = 1e4
#: Model-floor coefficients: k_offset >= OFFSET_FLOOR k l, k_tilt >= TILT_FLOOR k l^3.
OFFSET_FLOOR = 0.3
TILT_FLOOR = 1.5
#: Depth below which the floor uses this depth (the model's stiffness vanishes at l = 0) [m].
FLOOR_MIN_DEPTH = 1e-4
#: Relative upward drift of the friction estimate per second (lets an early low value recover).
FRICTION_DRIFT = 0.05

#: Columns of one row's identifier state: theta (3), P (3x3), then the used stiffness.
N_STATE = 3 + 9 + 1


@dataclasses.dataclass(frozen=True)
class ContactEstimate:
    """What the identification knows of the contact (one trial, one instant).

    Attributes:
        stiffness: Local stiffness of the rows (dx, dy, theta_x, theta_y) as the law uses it:
            [N/m, N/m, N/rad, N/rad] in units of ``A(l) F`` (bounded, released slowly).
        raw_stiffness: The least-squares slope before the floor and release (may be <= 0 when
            the data say nothing).
        depth_gain: d u_j / d l of each row [N/m].
        friction: Estimated friction coefficient (an upper bound; see the module doc).
        in_contact: Whether the last sample was counted as contact.
    """

    stiffness: FloatArray
    raw_stiffness: FloatArray
    depth_gain: FloatArray
    friction: float
    in_contact: bool

    def as_dict(self) -> dict[str, object]:
        """JSON-ready."""
        return {
            "stiffness": self.stiffness.tolist(),
            "raw_stiffness": self.raw_stiffness.tolist(),
            "depth_gain": self.depth_gain.tolist(),
            "friction": self.friction,
            "in_contact": self.in_contact,
        }


def reset_rows(state: FloatArray, floor: FloatArray) -> None:
    """Initial identifier state for every trial: state (N, 4, N_STATE); ``floor`` (4,) the
    stiffness the law starts from."""
    state[:] = 0.0
    for r in range(3):
        state[:, :, 3 + 4 * r] = P0  # the diagonal of P (3x3 stored row-major at 3..11)
    state[:, :, 12] = floor


@numba.njit(cache=True)  # type: ignore[misc]
def floor_row(depth: float, stiffness_min: float, out: FloatArray) -> None:
    """The model floor of the four rows at ``depth`` [m] for eq. 8's k = ``stiffness_min``."""
    l = max(depth, FLOOR_MIN_DEPTH)
    out[0] = out[1] = OFFSET_FLOOR * stiffness_min * l  # [N/m]
    out[2] = out[3] = TILT_FLOOR * stiffness_min * l * l * l  # [N/rad]


@numba.njit(cache=True)  # type: ignore[misc]
def rls_row(s: FloatArray, dx: float, dl: float, du: float, forget: float) -> None:
    """One RLS update of one row's state ``s`` (N_STATE,) with the scaled increments:
    ``du = theta . (dx, dl, 1)``; theta = s[0:3], P = s[3:12] (row-major 3x3)."""
    phi0, phi1, phi2 = dx, dl, 1.0
    # P phi
    pp0 = s[3] * phi0 + s[4] * phi1 + s[5] * phi2
    pp1 = s[6] * phi0 + s[7] * phi1 + s[8] * phi2
    pp2 = s[9] * phi0 + s[10] * phi1 + s[11] * phi2
    den = forget + phi0 * pp0 + phi1 * pp1 + phi2 * pp2
    g0, g1, g2 = pp0 / den, pp1 / den, pp2 / den
    err = du - (s[0] * phi0 + s[1] * phi1 + s[2] * phi2)
    s[0] += g0 * err
    s[1] += g1 * err
    s[2] += g2 * err
    # P = (P - g (P phi)^T) / forget, kept symmetric; its trace bounded (no wind-up)
    trace = 0.0
    gs = (g0, g1, g2)
    ps = (pp0, pp1, pp2)
    for a in range(3):
        for b in range(3):
            s[3 + 3 * a + b] = (s[3 + 3 * a + b] - gs[a] * ps[b]) / forget
        trace += s[3 + 4 * a]
    if trace > P_TRACE_MAX:
        for i in range(3, 12):
            s[i] *= P_TRACE_MAX / trace


@numba.njit(cache=True)  # type: ignore[misc]
def identify_rows(
    s: FloatArray,
    d_rows: FloatArray,
    d_depth: float,
    d_u: FloatArray,
    in_contact: bool,
    forget: float,
    floor: FloatArray,
    release: float,
    backoff: FloatArray,
) -> None:
    """Advance the four rows' identifiers of one trial (s: (4, N_STATE)) by one sample.

    d_rows: increments of the measured features dx, dy, theta_x, theta_y; d_depth of l;
    d_u: of the direction rows. ``release`` is exp(-dt / T_release); ``backoff`` (4,) >= 1
    multiplies the used stiffness (the oscillation guard's back-off). The used stiffness
    (s[:, 12]) is max(raw slope, floor, previous * release) * backoff.
    """
    for j in range(4):
        if in_contact:
            rls_row(s[j], d_rows[j] / ROW_SCALE[j], d_depth / DEPTH_SCALE, d_u[j], forget)
        raw = s[j, 0] / ROW_SCALE[j]
        held = s[j, 12] * release
        s[j, 12] = max(max(raw, floor[j]) * backoff[j], held)


def estimate_of(state: FloatArray, friction: float, in_contact: bool) -> ContactEstimate:
    """The :class:`ContactEstimate` of one trial's identifier state (4, N_STATE)."""
    return ContactEstimate(
        stiffness=state[:, 12].copy(),
        raw_stiffness=state[:, 0] / ROW_SCALE,
        depth_gain=state[:, 1] / DEPTH_SCALE,
        friction=float(friction),
        in_contact=bool(in_contact),
    )


@numba.njit(cache=True)  # type: ignore[misc]
def friction_update(mu: float, fz: float, f_lat: float, f_min: float, dt: float) -> float:
    """The friction estimate after one sample: the lower envelope of Fz/|F_lat| (see the module
    doc), drifting up by FRICTION_DRIFT per second; unchanged while |F_lat| <= f_min."""
    if f_lat <= f_min or fz <= 0.0:
        return mu
    return min(mu * (1.0 + FRICTION_DRIFT * dt), fz / f_lat)


def forgetting(window: float, dt: float) -> float:
    """The RLS forgetting factor for a memory of ``window`` seconds at period dt."""
    return math.exp(-dt / window)
