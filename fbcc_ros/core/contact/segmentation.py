"""Contact states (Fig. 4, eq. 14-17) and boundary mapping into response space (eq. 18-25).

Per plane there are nine states: the subscript is the sign of the offset (dx in XOZ, dy in YOZ:
``1``, ``0``, ``-1``), the letter the tilt (theta_y in XOZ, theta_x in YOZ): ``P`` for zero tilt
(planar contact), ``D`` for a positive tilt, ``D^`` for a negative one. ``P0`` is the ideal
state: for a clearance fit the whole no-contact region of eq. (15), for an interference fit the
single point of eq. (17).

Signs in YOZ. The tilts are right-hand rotations (DESIGN §3), so theta_x > 0 leans the peg's top
toward -y while theta_y > 0 leans it toward +x, and Mx = -lever·Fy while My = +lever·Fx. Both
signs flip together, so in the normalised plane (Fy/Fz, Mx/(R Fz)) the image of theta_x = 0 is the
line of slope ``-tan(gamma)`` and "D above the line, D^ below" holds in both planes. A 90° rotation
about z therefore carries a ``D`` state of XOZ to a ``D^`` state of YOZ (theta_x' = -theta_y).

Boundary mapping (DESIGN §5 on eq. 21, 24, 28-29). In the normalised plane of Fig. 6,
``u = Fx/Fz``, ``v = My/(R Fz)``:

* the offset is judged from ``u`` alone (eq. 21: dx = 0 maps to Fx = 0);
* the tilt from the signed distance to the image of theta_y = 0, the line ``v = u tan(gamma)``
  (eq. 24), ``sigma = v cos(gamma) - u sin(gamma)``, with
  ``tan(gamma) = (-l/2 + L + H + mu R) / R`` (eq. 29 read in the normalised plane);
* a response inside the band ``|u| <= offset_band`` is on the offset boundary, inside
  ``|sigma| <= tilt_band`` on the tilt boundary; both, or an axial force below ``fz_min``, is
  ``P0`` (eq. 25).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole, as_rows
from fbcc_ros.core.errors import ConfigError, InputError

#: The nine states of one plane, in the order of Fig. 4.
STATES = ("P0", "P1", "P-1", "D0", "D1", "D-1", "D^0", "D^1", "D^-1")

#: Default half-widths of the on-boundary bands in feature space.
OFFSET_TOL = 1e-6  # [m]
TILT_TOL = 1e-4  # [rad]
#: Default half-widths of the on-boundary bands in the normalised response plane (dimensionless).
#: Sized from the model (docs/boundary-mapping.md): dx = 0 maps to |Fx/Fz| ~ 0.1 (median; eq. 20
#: holds only to first order), while off-boundary samples sit at |Fx/Fz| > 0.25 (99 %); the tilt
#: signature is weaker: theta = 0 leaks to |sigma| ~ 0.003 through the other plane, while
#: off-boundary samples sit at |sigma| > 0.005 (95 %).
OFFSET_BAND = 0.1
TILT_BAND = 0.005
#: Default axial force under which a response counts as "no contact" [N].
FZ_MIN = 0.05

#: What feature_state and response_state return: two strings for one vector, two arrays of
#: strings for a batch.
StatePair = tuple[str, str] | tuple[NDArray[np.object_], NDArray[np.object_]]

_LETTER = {1: "D", 0: "P", -1: "D^"}
#: The index into :data:`STATES` of each pair of signs: ``[tilt sign + 1, offset sign + 1]``.
STATE_INDEX = np.array([[STATES.index(f"{_LETTER[t]}{d}") for d in (-1, 0, 1)]
                        for t in (-1, 0, 1)])  # fmt: skip
#: (offset sign, tilt sign) of each state of :data:`STATES`.
SIGNS = tuple((d, t) for name in STATES for t in (-1, 0, 1) for d in (-1, 0, 1)
              if f"{_LETTER[t]}{d}" == name)  # fmt: skip
_NAMES = np.asarray(STATES, dtype=object)


def _labels(offset_sign: NDArray[np.int64], tilt_sign: NDArray[np.int64]) -> NDArray[np.object_]:
    return _NAMES[STATE_INDEX[tilt_sign + 1, offset_sign + 1]]  # type: ignore[no-any-return]


def _banded_sign(x: FloatArray, tol: float) -> NDArray[np.int64]:
    """Sign of x, with 0 inside the band |x| <= tol."""
    return np.where(x > tol, 1, np.where(x < -tol, -1, 0))


def _result(xoz: NDArray[np.object_], yoz: NDArray[np.object_], single: bool) -> StatePair:
    if single:
        return str(xoz[0]), str(yoz[0])
    return xoz, yoz


def plane_state_index(
    offset: FloatArray,
    tilt: FloatArray,
    depth: FloatArray,
    hole_radius: float | FloatArray,
    peg_radius: float | FloatArray,
    offset_tol: float = OFFSET_TOL,
    tilt_tol: float = TILT_TOL,
) -> NDArray[np.int64]:
    """The state of one plane (Fig. 4, eq. 15-17) as an index into :data:`STATES`, for arrays
    of its offset, tilt and depth; the radii scalars or one per row (a clearance fit where
    r < R)."""
    index = STATE_INDEX[_banded_sign(tilt, tilt_tol) + 1, _banded_sign(offset, offset_tol) + 1]
    # eq. (15): no contact while |d ± l sin(theta)/2 ± r cos(theta)| <= R for every sign
    reach = np.abs(offset) + depth * np.abs(np.sin(tilt)) / 2 + peg_radius * np.cos(tilt)
    inside = (np.asarray(peg_radius) < np.asarray(hole_radius)) & (reach <= hole_radius)
    # an interference fit: P0 only at the point d = 0, theta = 0 (eq. 17), the bands above
    return np.where(inside, STATES.index("P0"), index)  # type: ignore[no-any-return]


def _plane_feature_state(
    offset: FloatArray,
    tilt: FloatArray,
    depth: FloatArray,
    ph: PegHole,
    offset_tol: float,
    tilt_tol: float,
) -> NDArray[np.object_]:
    return _NAMES[plane_state_index(offset, tilt, depth, ph.hole_radius, ph.peg_radius,
                                    offset_tol, tilt_tol)]  # type: ignore[no-any-return]


def feature_state(
    features: ArrayLike,
    peghole: PegHole,
    *,
    offset_tol: float = OFFSET_TOL,
    tilt_tol: float = TILT_TOL,
) -> StatePair:
    """Contact state per plane from the features (Fig. 4, eq. 15-17).

    Args:
        features: (dx, dy, l, theta_x, theta_y), shape (5,) or (N, 5) [m, rad].
        peghole: The geometry; its fit type selects eq. (15) or eq. (17) for P0.
        offset_tol: Half-width of the band around d = 0 counted as on the boundary [m].
        tilt_tol: Half-width of the band around theta = 0 counted as on the boundary [rad].

    Returns:
        ``(state_xoz, state_yoz)``: two strings for one feature vector, two arrays of strings
        for a batch.
    """
    rows, single = as_rows(features, "features", "values")
    dx, dy, depth, thx, thy = rows.T
    xoz = _plane_feature_state(dx, thy, depth, peghole, offset_tol, tilt_tol)
    yoz = _plane_feature_state(dy, thx, depth, peghole, offset_tol, tilt_tol)
    return _result(xoz, yoz, single)


def tilt_boundary_angle(depth: ArrayLike, peghole: PegHole) -> FloatArray:
    """gamma of eq. (29): the angle of the image of theta = 0 in the normalised plane [rad].

    ``tan(gamma) = lever / R`` with the lever of eq. (24) (:meth:`PegHole.boundary_lever`):
    eq. (29) gives the lever itself, a length; Fig. 6 plots My/(R Fz) against Fx/Fz.
    """
    return np.arctan(peghole.boundary_lever(depth) / peghole.hole_radius)  # type: ignore[no-any-return]


def direction_matrix(depth: ArrayLike, peghole: PegHole) -> FloatArray:
    """The direction matrix A(l) of eq. (28), shape (5, 5) or (N, 5, 5) for N depths.

    Read per DESIGN §5 from the boundary mapping (eq. 21, 24): the offsets are judged from the
    lateral forces alone; each tilt from the signed distance of the response to the image of
    theta = 0 in the plane of Fig. 6, scaled by Fz (so ``A F`` needs no division):

    .. math::
        A(l) = \\begin{bmatrix} 1 & & & & \\\\ & 1 & & & \\\\ & & 1 & & \\\\
               & \\sin\\gamma & & \\cos\\gamma / R & \\\\
               -\\sin\\gamma & & & & \\cos\\gamma / R \\end{bmatrix}

    with rows (dx, dy, l, theta_x, theta_y) and columns (Fx, Fy, Fz, Mx, My). The paper's
    layout is garbled; its theta_x row has ``-sin(gamma)`` because its eq. (12) flips the sign
    of Mx. With right-hand moments (DESIGN §3) both Mx and the image of theta_x = 0 flip sign,
    hence ``+sin(gamma)`` here; the 90° rotation test of ``response_state`` pins it.
    """
    sg, cg_r = _direction_terms(depth, peghole)
    a = np.zeros((*np.shape(sg), 5, 5))
    a[..., 0, 0] = a[..., 1, 1] = a[..., 2, 2] = 1.0
    a[..., 3, 1], a[..., 3, 3] = sg, cg_r  # theta_x: sin(gamma) Fy + cos(gamma) Mx / R
    a[..., 4, 0], a[..., 4, 4] = -sg, cg_r  # theta_y: -sin(gamma) Fx + cos(gamma) My / R
    return a


def apply_direction(response: FloatArray, depth: FloatArray, peghole: PegHole) -> FloatArray:
    """``A(l) F`` for responses (N, 5) at depths (N,), without building A: the rows the
    controller's compiled step computes (:func:`direct_row`), equal to
    :func:`direction_matrix` times F, which a test pins."""
    w = np.ascontiguousarray(response, dtype=float)
    l = np.ascontiguousarray(np.broadcast_to(depth, (len(w),)), dtype=float)
    out = np.empty_like(w)
    base, per_depth = peghole.lever_terms()
    for i in range(len(w)):
        direct_row(w[i], l[i], base, per_depth, peghole.hole_depth, peghole.hole_radius, out[i])
    return out


@numba.njit(cache=True)  # type: ignore[misc]
def lever_at(depth: float, base: float, per_depth: float, hole_depth: float) -> float:
    """Eq. 24's lever at ``depth`` [m] from ``PegHole.lever_terms`` (as
    ``PegHole.boundary_lever``, for the compiled steps)."""
    return base - min(depth, hole_depth) / 2.0 + per_depth * depth


@numba.njit(cache=True)  # type: ignore[misc]
def tilt_terms(lever: float, hole_radius: float) -> tuple[float, float]:
    """sin(gamma) and cos(gamma) / R of eq. (28)-(29) for eq. 24's ``lever``:
    tan(gamma) = lever / R."""
    gamma = math.atan(lever / hole_radius)
    return math.sin(gamma), math.cos(gamma) / hole_radius


@numba.njit(cache=True)  # type: ignore[misc]
def direct_row(
    w: FloatArray,
    depth: float,
    base: float,
    per_depth: float,
    hole_depth: float,
    hole_radius: float,
    out: FloatArray,
) -> None:
    """One row of ``A(l) F`` into ``out`` (5,); the lever is ``PegHole.lever_terms``'s."""
    sg, cg_r = tilt_terms(lever_at(depth, base, per_depth, hole_depth), hole_radius)
    out[0], out[1], out[2] = w[0], w[1], w[2]
    out[3] = sg * w[1] + cg_r * w[3]  # theta_x: sin(gamma) Fy + cos(gamma) Mx / R
    out[4] = -sg * w[0] + cg_r * w[4]  # theta_y: -sin(gamma) Fx + cos(gamma) My / R


def _direction_terms(depth: ArrayLike, peghole: PegHole) -> tuple[FloatArray, FloatArray]:
    """sin(gamma) and cos(gamma) / R of eq. (28)-(29), from tan(gamma) = lever / R without a
    trigonometric function: sin = tan / sqrt(1 + tan^2), cos = 1 / sqrt(1 + tan^2)."""
    tan_g = np.asarray(peghole.boundary_lever(depth) / peghole.hole_radius)
    secant = np.sqrt(1.0 + tan_g * tan_g)
    return tan_g / secant, 1.0 / (secant * peghole.hole_radius)


def normalised_coordinates(
    response: ArrayLike, depth: ArrayLike, peghole: PegHole
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The offset and tilt indicators of both planes in the normalised plane of Fig. 6.

    Returns ``(u_x, sigma_x, u_y, sigma_y)``: ``u = F/Fz`` and ``sigma`` the signed distance to
    the image of theta = 0, positive when the tilt of that plane is positive:

    * XOZ: ``u_x = Fx/Fz``, ``sigma_x = cos(gamma) My/(R Fz) - sin(gamma) Fx/Fz``
    * YOZ: ``u_y = Fy/Fz``, ``sigma_y = cos(gamma) Mx/(R Fz) + sin(gamma) Fy/Fz``

    That is ``A(l) F / Fz`` with A of :func:`direction_matrix`. Rows with Fz <= 0 give NaN.
    """
    if peghole.friction <= 0:
        raise ConfigError(
            "friction", peghole.friction, "> 0: the normalised plane of Fig. 6 divides by Fz"
        )
    w = np.asarray(response, dtype=float)
    sg, cg_r = _direction_terms(depth, peghole)
    fx, fy, fz, mx, my = (w[..., i] for i in range(5))
    # Rows with a vanishing Fz may overflow to inf or NaN here; callers treat them as no contact.
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = np.where(fz > 0, 1.0 / fz, np.nan)
        # A's rows theta_y and theta_x, without building A (9x faster for 4000 rows)
        return fx * inv, (-sg * fx + cg_r * my) * inv, fy * inv, (sg * fy + cg_r * mx) * inv


def response_state(
    response: ArrayLike,
    depth: ArrayLike,
    peghole: PegHole,
    *,
    offset_band: float = OFFSET_BAND,
    tilt_band: float = TILT_BAND,
    fz_min: float = FZ_MIN,
) -> StatePair:
    """Contact state per plane from a response, by the boundary mapping (eq. 21, 24, 25).

    Only the nominal geometry enters (R, L, H, mu through gamma): this is the point of boundary
    mapping, which the robustness study in ``docs/`` measures.

    Args:
        response: (Fx, Fy, Fz, Mx, My) in {H}, shape (5,) or (N, 5) [N, N·m].
        depth: insertion depth l [m], a scalar or shape (N,).
        peghole: The nominal geometry.
        offset_band: Half-width of the band around Fx/Fz = 0 (resp. Fy/Fz) that counts as d = 0.
        tilt_band: Half-width of the band around the tilted line that counts as theta = 0.
        fz_min: Axial force below which the response counts as no contact (P0) [N].

    Returns:
        ``(state_xoz, state_yoz)`` as :func:`feature_state`.
    """
    rows, single = as_rows(response, "response", "values")
    depth_in = np.asarray(depth, dtype=float)
    if depth_in.shape not in ((), (1,), (len(rows),)):
        raise InputError(
            "depth",
            f"array of shape {depth_in.shape}",
            f"a scalar or shape ({len(rows)},), one depth per response",
        )
    depth_arr = np.broadcast_to(depth_in, (len(rows),))
    if not np.all(np.isfinite(depth_arr)) or np.any(depth_arr < 0):
        raise InputError("depth", np.asarray(depth).tolist(), "finite insertion depths >= 0 in m")
    u_x, s_x, u_y, s_y = normalised_coordinates(rows, depth_arr, peghole)
    no_contact = ~(rows[:, 2] > fz_min)
    states = []
    for u, sigma in ((u_x, s_x), (u_y, s_y)):
        u0 = np.where(no_contact, 0.0, u)
        s0 = np.where(no_contact, 0.0, sigma)
        states.append(_labels(_banded_sign(u0, offset_band), _banded_sign(s0, tilt_band)))
    # _labels gives "P0" for (0, 0): both bands, or no contact at all (eq. 25)
    return _result(states[0], states[1], single)
