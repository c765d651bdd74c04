"""Online contact identification: the local stiffness of each controlled row, and friction.

The robust FBCC law (:mod:`fbcc_ros.core.control.robust`) schedules its gains by the contact it
meets, so it needs, while in contact, the local slope of each direction row ``u_j = (A(l) F)_j``
(eq. 28; rows dx, dy, theta_x, theta_y) against its own feature:

.. math::
    k_j = \\frac{\\partial u_j}{\\partial x_j} \\quad [\\mathrm{N/m}\\ \\text{offsets},
    \\ \\mathrm{N/rad}\\ \\text{tilts}],

where ``x`` are the robot's measured features (with a compliant holder, the series stiffness of
holder and contact: what the command actually meets).

**Model and estimator.** Per plane (XOZ: dx and theta_y; YOZ: dy and theta_x), a recursive
least-squares fit with exponential forgetting of the increments from one sample to the next:

.. math::
    \\begin{bmatrix}\\Delta u_d \\\\ \\Delta u_\\theta\\end{bmatrix}
    = J \\begin{bmatrix}\\Delta d \\\\ \\Delta\\theta\\end{bmatrix} + b\\,\\Delta l + c,

``J`` the plane's local 2×2 stiffness (its diagonal the rows' own stiffness k_j, its
off-diagonal the coupling the direction matrix leaves: in a two-point contact an offset moves the
tilt row and a tilt the offset row), ``b`` the rows' sensitivity to the depth (the insertion
itself presses the peg harder into the wall), ``c`` the slow drift. Both rows of a plane share the
regressors, hence one covariance. Increments remove the unknown hole deviation (the operating
point) and the sensor bias; ``b`` keeps the depth motion from being read as stiffness. Excitation
comes from the controller's own adjustments and a small dither at a frequency of its own per row
(:mod:`fbcc_ros.core.control.robust`), so the regressors are not collinear.

**Gating and bounds.** The fit is updated only in contact (Fz or a row above its noise), so the
free-space samples of a clearance fit do not pull the stiffness to zero; the covariance is
bounded (its trace), so it does not wind up while the excitation is poor. The estimate the law
uses is bounded below by a model floor for the softest contact the command meets, the part's
material in series with the grip (``stiffness_min``, eq. 8's k in Pa) at the current depth, and
falls no faster than the release time constant: an underestimate raises the loop gain, so the
estimate must err stiff.

Model floor, from finite differences of the contact model (eq. 5-13) at k = 1 GPa, both fits,
depths 1-10 mm (``test_the_floor_is_below_the_models_stiffness_in_contact`` pins it as a
lower bound):
``k_offset >= 0.3 k l`` [N/m], ``k_tilt >= 1.5 k l^3`` [N/rad] (the smallest slopes seen over
random offsets and tilts in contact were 0.38 and 2.4).

**Friction.** With Coulomb friction the axial force is ``Fz = mu * sum of normal forces``
(eq. 11) and the lateral force is at most that sum, so ``Fz / |(Fx, Fy)| >= mu``. The estimate
is the lower envelope of that ratio (with a slow upward drift so an early low value can be
corrected): an upper bound on mu. For a peg pressed on one side the pressure spreads over an arc
and the bound is ~16 % above mu (pinned by a test); in a centred interference fit the ratio
stays large and the estimate stays at its prior.

**The lever's friction.** Eq. 24's lever puts the axial friction's moment at μR; a part whose
μ is not the scenario's leaves cos γ Δμ of every lateral force in its tilt row. While the peg
slides in (the depth rising), one contact on one side has ``Fz = μ |F_lat|`` and a moment whose
lever ``-Mx/Fy = My/Fx`` is that contact's height plus μR; a wedged contact (both sides) reads
Fz/|F_lat| of several times μ and a lever millimetres off the engaged wall, and is not counted
(:func:`one_contact_friction`). The estimate the lever uses is the lower envelope of the
filtered ratio over runs of such samples (:func:`lever_friction_update`); until one, the
scenario's μ. The published ``friction`` above is the other, always-on bound.

The interface the rest of the package uses is :class:`ContactEstimate`.
"""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np

from fbcc_ros.core.arrays import FloatArray

#: The controlled rows of A(l) F: features dx, dy, theta_x, theta_y (indices into 5-vectors).
ROWS = (0, 1, 3, 4)
#: The planes as (offset row, tilt row), indices into ROWS: XOZ (dx, theta_y), YOZ (dy, theta_x).
PLANES = ((0, 3), (1, 2))
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

#: The lever's friction (module doc): samples count while the depth rises at this share of the
#: insertion speed or more (sliding: Fz = mu |F_lat|), past this depth [m] (off the top face),
#: with a lateral force over this [N]; a run of LEVER_SAMPLES such samples, low-passed over
#: LEVER_FILTER [s], gives a value; a contact height more than LEVER_MARGIN [m], or
#: LEVER_MARGIN_PER_RADIUS times R if more, beyond the engaged wall is not one contact (the
#: pressure spread and a tilt move it by tenths of mm, a wedge by millimetres; the ratio's
#: reading over μ on an arc moves it in proportion to R: a 10 mm peg read 0.4 mm off).
LEVER_SLIDE = 0.3
LEVER_MIN_DEPTH = 1e-4
LEVER_MIN_FORCE = 2.0
LEVER_SAMPLES = 10
LEVER_FILTER = 0.01
LEVER_MARGIN = 3e-4
LEVER_MARGIN_PER_RADIUS = 0.059  # 0.3 mm at the study's R of 5.05 mm
LEVER_FRICTION_MIN = 0.05
#: Columns of the lever's friction state: the estimate (0 until one), the filtered ratio, the
#: samples of the current run.
N_LEVER = 3

#: Regressors of a plane's fit: its offset and tilt increments, the depth's, and 1.
N_REG = 4
#: Columns of one plane's identifier state: theta (2 outputs x N_REG, row-major), P
#: (N_REG x N_REG), the used stiffness of its two rows.
_THETA, _P, _USED = 0, 2 * N_REG, 2 * N_REG + N_REG * N_REG
N_STATE = _USED + 2


_ROW_NAMES = ("dx", "dy", "theta_x", "theta_y")
#: The estimate as a flat row (the controller's ``fbcc/contact_estimate`` topic, after a stamp).
ESTIMATE_FIELDS = (
    *(f"k_{r}" for r in _ROW_NAMES), *(f"coupling_{r}" for r in _ROW_NAMES),
    *(f"depth_gain_{r}" for r in _ROW_NAMES), "friction", "lever_friction", "in_contact",
    "guard_trips",
)  # fmt: skip


@dataclasses.dataclass(frozen=True)
class ContactEstimate:
    """What the identification knows of the contact (one trial, one instant).

    Attributes:
        stiffness: Local stiffness of the rows (dx, dy, theta_x, theta_y) as the law uses it:
            [N/m, N/m, N/rad, N/rad] in units of ``A(l) F`` (bounded, released slowly; the
            robust law raises a tilt row further to its share of the coupling, see
            :mod:`fbcc_ros.core.control.robust`).
        raw_stiffness: The least-squares diagonal of J before the floor and release (may be
            <= 0 when the data say nothing).
        coupling: Off-diagonal of J per row: d u_dx/d theta_y, d u_dy/d theta_x [N/rad],
            d u_theta_x/d dy, d u_theta_y/d dx [N/m].
        depth_gain: d u_j / d l of each row [N/m].
        friction: Estimated friction coefficient (an upper bound; see the module doc).
        lever_friction: The friction coefficient eq. 24's lever uses now: the lower envelope of
            the one-contact samples (the lever's friction, module doc); the nominal μ until one.
        in_contact: Whether the last sample was counted as contact.
    """

    stiffness: FloatArray
    raw_stiffness: FloatArray
    coupling: FloatArray
    depth_gain: FloatArray
    friction: float
    lever_friction: float
    in_contact: bool

    def as_row(self, trips: int = 0) -> list[float]:
        """The values in :data:`ESTIMATE_FIELDS` order (after the stamp); ``trips`` the
        oscillation guard's trips so far."""
        return [*self.stiffness, *self.coupling, *self.depth_gain, self.friction,
                self.lever_friction, float(self.in_contact), float(trips)]  # fmt: skip

    def as_dict(self) -> dict[str, object]:
        """JSON-ready."""
        return {
            "stiffness": self.stiffness.tolist(),
            "raw_stiffness": self.raw_stiffness.tolist(),
            "coupling": self.coupling.tolist(),
            "depth_gain": self.depth_gain.tolist(),
            "friction": self.friction,
            "lever_friction": self.lever_friction,
            "in_contact": self.in_contact,
        }


def reset_planes(state: FloatArray, floor: FloatArray) -> None:
    """Initial identifier state of every trial: state (N, 2, N_STATE); ``floor`` (4,) the
    stiffness of the rows (dx, dy, theta_x, theta_y) the law starts from."""
    state[:] = 0.0
    for r in range(N_REG):
        state[:, :, _P + r * (N_REG + 1)] = P0
    for plane, rows in enumerate(PLANES):
        state[:, plane, _USED] = floor[rows[0]]
        state[:, plane, _USED + 1] = floor[rows[1]]


@numba.njit(cache=True)  # type: ignore[misc]
def floor_row(depth: float, stiffness_min: float, out: FloatArray) -> None:
    """The model floor of the four rows at ``depth`` [m] for eq. 8's k = ``stiffness_min``."""
    l = max(depth, FLOOR_MIN_DEPTH)
    out[0] = out[1] = OFFSET_FLOOR * stiffness_min * l  # [N/m]
    out[2] = out[3] = TILT_FLOOR * stiffness_min * l * l * l  # [N/rad]


@numba.njit(cache=True)  # type: ignore[misc]
def rls_plane(s: FloatArray, phi: FloatArray, y0: float, y1: float, forget: float) -> None:
    """One RLS update of one plane's state ``s`` (N_STATE,): both outputs y = theta phi share
    the regressors phi (N_REG,) and the covariance P."""
    pp = np.zeros(N_REG)  # P phi
    for a in range(N_REG):
        acc = 0.0
        for b in range(N_REG):
            acc += s[_P + a * N_REG + b] * phi[b]
        pp[a] = acc
    den = forget
    for a in range(N_REG):
        den += phi[a] * pp[a]
    for out, y in ((0, y0), (1, y1)):
        err = y
        for a in range(N_REG):
            err -= s[_THETA + out * N_REG + a] * phi[a]
        for a in range(N_REG):
            s[_THETA + out * N_REG + a] += pp[a] / den * err
    # P = (P - (P phi)(P phi)^T / den) / forget; its trace bounded (no wind-up)
    trace = 0.0
    for a in range(N_REG):
        for b in range(N_REG):
            s[_P + a * N_REG + b] = (s[_P + a * N_REG + b] - pp[a] * pp[b] / den) / forget
        trace += s[_P + a * (N_REG + 1)]
    if trace > P_TRACE_MAX:
        for i in range(_P, _P + N_REG * N_REG):
            s[i] *= P_TRACE_MAX / trace


@numba.njit(cache=True)  # type: ignore[misc]
def identify_planes(
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
    """Advance both planes' identifiers of one trial (s: (2, N_STATE)) by one sample.

    d_rows: increments of the measured features dx, dy, theta_x, theta_y; d_depth of l;
    d_u: of the direction rows (same order). ``release`` is exp(-dt / T_release) (1 holds the
    used stiffness from falling); ``backoff``
    (4,) >= 1 multiplies the used stiffness (the oscillation guard's back-off). The used
    stiffness of a row is max(max(raw diagonal, floor) * backoff, previous * release).
    """
    phi = np.zeros(N_REG)
    for plane in range(2):
        r_d, r_t = PLANES[plane]
        if in_contact:
            phi[0] = d_rows[r_d] / ROW_SCALE[r_d]
            phi[1] = d_rows[r_t] / ROW_SCALE[r_t]
            phi[2] = d_depth / DEPTH_SCALE
            phi[3] = 1.0
            rls_plane(s[plane], phi, d_u[r_d], d_u[r_t], forget)
        for k, r in ((0, r_d), (1, r_t)):
            raw = s[plane, _THETA + k * N_REG + k] / ROW_SCALE[r]
            held = s[plane, _USED + k] * release
            s[plane, _USED + k] = max(max(raw, floor[r]) * backoff[r], held)


@numba.njit(cache=True)  # type: ignore[misc]
def back_off(s: FloatArray, row: int, factor: float) -> None:
    """Multiply the used stiffness of ``row`` (0-3: dx, dy, theta_x, theta_y) by ``factor``
    now, whatever the fit says: the oscillation guard's back-off acts on the gain in use even
    when the fit is held or has fallen below it. s: one trial's state (2, N_STATE)."""
    for plane in range(2):
        for k in range(2):
            if PLANES[plane][k] == row:
                s[plane, _USED + k] *= factor


@numba.njit(cache=True)  # type: ignore[misc]
def used_matrix(s: FloatArray, plane: int, max_coupling: float, out: FloatArray) -> float:
    """The plane's Jacobian J the law inverts, [[N/m, N/rad], [N/m, N/rad]]: the used diagonal
    and the fitted off-diagonal, the latter shrunk so that |J01 J10| <= max_coupling J00 J11
    (the determinant stays >= (1 - max_coupling) J00 J11 > 0). out: (4,) as J00, J01, J10,
    J11; s the plane's state (N_STATE,). Returns the fitted J01 (d u_offset / d theta [N/rad])
    before that shrinking."""
    r_d, r_t = PLANES[plane]
    out[0], out[3] = s[_USED], s[_USED + 1]
    out[1] = fitted = s[_THETA + 1] / ROW_SCALE[r_t]  # d u_d / d theta
    out[2] = s[_THETA + N_REG] / ROW_SCALE[r_d]  # d u_theta / d d
    cross = abs(out[1] * out[2])
    limit = max_coupling * out[0] * out[3]
    if cross > limit:
        shrink = math.sqrt(limit / cross)
        out[1] *= shrink
        out[2] *= shrink
    return fitted


def estimate_of(state: FloatArray, friction: float, lever_friction: float,
                in_contact: bool) -> ContactEstimate:  # fmt: skip
    """The :class:`ContactEstimate` of one trial's identifier state (2, N_STATE)."""
    used, raw, coupling, depth = (np.zeros(4) for _ in range(4))
    for plane, (r_d, r_t) in enumerate(PLANES):
        s = state[plane]
        used[r_d], used[r_t] = s[_USED], s[_USED + 1]
        raw[r_d] = s[_THETA] / ROW_SCALE[r_d]
        raw[r_t] = s[_THETA + N_REG + 1] / ROW_SCALE[r_t]
        coupling[r_d] = s[_THETA + 1] / ROW_SCALE[r_t]
        coupling[r_t] = s[_THETA + N_REG] / ROW_SCALE[r_d]
        depth[r_d] = s[_THETA + 2] / DEPTH_SCALE
        depth[r_t] = s[_THETA + N_REG + 2] / DEPTH_SCALE
    return ContactEstimate(used, raw, coupling, depth, float(friction), float(lever_friction),
                           bool(in_contact))  # fmt: skip


@numba.njit(cache=True)  # type: ignore[misc]
def plane_depth_gain(s: FloatArray, row: int) -> float:
    """d u_row / d l [N/m] from a trial's identifier state s (2, N_STATE)."""
    for plane in range(2):
        for k in range(2):
            if PLANES[plane][k] == row:
                return s[plane, _THETA + k * N_REG + 2] / DEPTH_SCALE
    return 0.0


@numba.njit(cache=True)  # type: ignore[misc]
def friction_update(mu: float, fz: float, f_lat: float, f_min: float, dt: float) -> float:
    """The friction estimate after one sample: the lower envelope of Fz/|F_lat| (see the module
    doc), drifting up by FRICTION_DRIFT per second; unchanged while |F_lat| <= f_min."""
    if f_lat <= f_min or fz <= 0.0:
        return mu
    return min(mu * (1.0 + FRICTION_DRIFT * dt), fz / f_lat)


@numba.njit(cache=True)  # type: ignore[misc]
def one_contact_friction(w: FloatArray, depth: float, wall: float, radius: float) -> float:
    """Fz/|F_lat| of the wrench w (Fx, Fy, Fz, Mx, My) when its moment puts one contact on the
    engaged wall, else -1. ``wall`` is the lever of eq. 24 without its friction term (the mean
    height of the engaged wall, ``depth`` long), ``radius`` R [m]."""
    f2 = w[0] * w[0] + w[1] * w[1]
    if f2 <= 0.0 or w[2] <= 0.0:
        return -1.0
    mu = w[2] / math.sqrt(f2)
    lever = (w[4] * w[0] - w[3] * w[1]) / f2  # -Mx/Fy = My/Fx, both planes at once
    margin = max(LEVER_MARGIN, LEVER_MARGIN_PER_RADIUS * radius)
    if abs(lever - mu * radius - wall) > depth / 2.0 + margin:
        return -1.0
    return mu


@numba.njit(cache=True)  # type: ignore[misc]
def lever_friction(s: FloatArray, nominal: float) -> float:
    """The friction the lever uses from its state s (N_LEVER,): the estimate once there is one,
    else the ``nominal`` μ."""
    return s[0] if s[0] > 0.0 else nominal


@numba.njit(cache=True)  # type: ignore[misc]
def lever_friction_update(s: FloatArray, sample: float, dt: float, friction_max: float) -> None:
    """Advance the lever's friction state s (N_LEVER,) by one sample's ratio (< 0: none): a run
    of LEVER_SAMPLES low-passed ratios under ``friction_max`` lowers the estimate to it."""
    if sample < 0.0:
        s[2] = 0.0
        return
    if s[2] == 0.0:
        s[1] = sample
    s[1] += (1.0 - math.exp(-dt / LEVER_FILTER)) * (sample - s[1])
    s[2] += 1.0
    if s[2] >= LEVER_SAMPLES and s[1] <= friction_max:
        value = max(s[1], LEVER_FRICTION_MIN)
        s[0] = value if s[0] == 0.0 else min(s[0], value)


def forgetting(window: float, dt: float) -> float:
    """The RLS forgetting factor for a memory of ``window`` seconds at period dt."""
    return math.exp(-dt / window)
