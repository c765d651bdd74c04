"""The contact model's compiled core: eq. (5)-(13) for rows of features, by quadrature over rays
around the peg (the angle table) and Gauss-Legendre nodes along them. :class:`ContactBatch` of
:mod:`fbcc_ros.core.contact.model` calls it; the closed-loop simulator does so once per 1 ms
step, where numpy's per-call overhead alone would cost ~80 us.

The rows are the inner loop of each ray, so that it vectorises: a SIMD instruction takes 4-8
rows (a Monte Carlo batch, a filter's particles) at once. Inside that loop nothing branches on a
row's values (a ray that misses the peg contributes an exact 0 by a select), the number of
nodes along s is a compile-time constant (:data:`GL_ORDER`), and a division carries no
zero check (``error_model="numpy"``). The floating-point operations per row are those of a
row-by-row loop, in the same order, so the responses are the same to the last bit; on a
deviation filter's 4000 particles that loop takes 5.7× as long.
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np

from fbcc_ros.core.arrays import FloatArray

#: Gauss-Legendre nodes and weights on [-1, 1] for the integral along s on each contact interval.
GL_ORDER = 3
GL_NODES, GL_WEIGHTS = np.polynomial.legendre.leggauss(GL_ORDER)
#: Scratch rows :func:`response_kernel` needs per feature row (its ``work``, (WORK_ROWS, N)).
WORK_ROWS = 20
#: Rows of a pair table (:class:`~fbcc_ros.core.contact.model.ContactBatch`): R, r, mu, k, L, H,
#: peg_length, chamfer W, rim (1.0: the hole has its top face and bottom, :mod:`.rim`).
TABLE_ROWS = 9


#: Under a 45° chamfer, the overlap g with the wall at a depth d under its top that the rim
#: leaves to the wall: g < (d + g) / √2, the chamfer's depth there.
_CHAMFER_SHARE = 1.0 / (math.sqrt(2.0) - 1.0)


@functools.lru_cache(maxsize=8)
def angle_table(n_angles: int) -> tuple[FloatArray, FloatArray]:
    """cos and sin of the ray angles: uniform periodic midpoint rule over alpha in [-pi, pi)."""
    alpha = -math.pi + (np.arange(n_angles) + 0.5) * (2.0 * math.pi / n_angles)
    return np.cos(alpha), np.sin(alpha)


@numba.njit(cache=True, error_model="numpy", inline="always")  # type: ignore[misc]
def _overlap(s: float, a0: float, tan_t: float, d_e: float, d_p: float, m_p: float,
             cos2: float, r2: float, qa: float, hole: float) -> float:  # fmt: skip
    """rho - R where the slice at s reaches past the wall along the ray, else 0: rho the far
    intersection of the ray with the slice ellipse, A rho^2 - 2 B rho + C = 0."""
    o_e = a0 + s * tan_t  # eq. (5) along e
    qb = d_e * o_e * cos2 + d_p * m_p
    qc = o_e * o_e * cos2 + (m_p * m_p - r2)
    disc = qb * qb - qa * qc
    rho = (qb + math.sqrt(disc if disc > 0.0 else 0.0)) / qa
    return rho - hole if rho > hole else 0.0


@numba.njit(cache=True, error_model="numpy", inline="always")  # type: ignore[misc]
def wall_friction(table: FloatArray, c: int) -> float:
    """The μ of eq. 11-13 for pair c: its own, or 0 where it has the rim, whose wall rubs
    against the peg's own sliding instead (:mod:`.sliding`)."""
    return table[2, c] if table[8, c] <= 0.0 else 0.0  # type: ignore[no-any-return]


@numba.njit(cache=True, error_model="numpy", inline="always")  # type: ignore[misc]
def row_geometry(f: FloatArray, table: FloatArray, peg_top: bool, work: FloatArray, i: int,
                 c: int) -> None:  # fmt: skip
    """Row i's lean frame, slice geometry of eq. (5) and lever arm into column i of ``work``
    (:func:`response_kernel`'s layout; its sums zeroed), with pair c of ``table``."""
    e_x, e_y, m_p, a0, tan_t, sin_t = work[0], work[1], work[2], work[3], work[4], work[5]
    cos2, s_u, s_lo, hole, r2, arm = work[6], work[7], work[8], work[9], work[10], work[11]
    s_w, rim, low_e = work[17], work[18], work[19]
    R, r, mu = table[0, c], table[1, c], wall_friction(table, c)
    L, H, peg_length = table[4, c], table[5, c], table[6, c]
    dx, dy, l, thx, thy = f[i, 0], f[i, 1], f[i, 2], f[i, 3], f[i, 4]
    # Lean of the axis per unit height, t = (tan theta_y, -tan theta_x) (right-hand
    # theta_x). The 1e-300 picks e = +x for an untilted peg without a branch; it is below
    # rounding otherwise.
    tx, ty = math.tan(thy) + 1e-300, -math.tan(thx)
    tan_t[i] = math.hypot(tx, ty)
    e_x[i], e_y[i] = tx / tan_t[i], ty / tan_t[i]
    cos_t = 1.0 / math.sqrt(1.0 + tan_t[i] * tan_t[i])
    sin_t[i] = tan_t[i] * cos_t
    cos2[i] = cos_t * cos_t
    # Midpoint offset in the lean frame (e along the lean, e_perp = z x e across it).
    m_e = dx * e_x[i] + dy * e_y[i]
    m_p[i] = dy * e_x[i] - dx * e_y[i]
    # eq. (5) along e: o_e(s) = a0 + s tan(theta), a0 = m_e - (l/2 + r sin theta) sin theta
    a0[i] = m_e - (0.5 * l + r * sin_t[i]) * sin_t[i]
    s_u[i] = l * cos_t  # top face of the hole, s_u = l cos(theta)
    s_lo[i] = max(0.0, s_u[i] - L)  # no wall below the hole's depth L
    # with the rim: the overlap, in depths under the wall's top, up to which the whole of it is
    # the wall's; the rim gives the end face to the wall up to there (:func:`.rim._depth`):
    # g < d under a sharp edge's top face, g < d / (√2 - 1) under a 45° chamfer
    rim[i] = 0.0 if table[8, c] <= 0.0 else (1.0 if table[7, c] <= 0.0 else _CHAMFER_SHARE)
    s_w[i] = s_u[i] - table[7, c]  # the wall's top, under the chamfer (W = 0 without rim)
    # the end face's lowest point along e, at s = 0: the slice ellipse's far end there
    low_e[i] = a0[i] + r / math.sqrt(cos2[i])
    hole[i], r2[i] = R, r * r
    # Height of the equivalent acting point z_A in {H}: on the axis, peg_length from the
    # tip centre (which eq. 5 puts at s_tip = r sin(theta) cos(theta)), or the hole bottom.
    if peg_top:
        z_a = r * sin_t[i] * cos_t + peg_length * cos_t - s_u[i]
    else:
        z_a = -(L + H)
    # lever arm of eq. (12)-(13): z - z_A + mu R, with the slice height z = s - s_u
    arm[i] = mu * R - s_u[i] - z_a
    work[12, i] = work[13, i] = work[14, i] = work[15, i] = work[16, i] = 0.0


@numba.njit(cache=True, error_model="numpy", inline="always")  # type: ignore[misc]
def ray_span(cj: float, sj: float, work: FloatArray, i: int
             ) -> tuple[float, float, bool, float, float, float]:  # fmt: skip
    """Where the ray at angle (cos, sin) = (cj, sj) in {H} meets row i's peg (``work`` filled
    by :func:`row_geometry`): ``(half_len, mid, hits, d_e, d_p, qa)``, the contact interval's
    half length and centre in s, whether there is one, the ray's direction along the lean e
    and across it, and the slice ellipse's quadratic coefficient along it."""
    e_x, e_y, m_p, a0 = work[0, i], work[1, i], work[2, i], work[3, i]
    tan_t, sin_t, hole, r2 = work[4, i], work[5, i], work[9, i], work[10, i]
    d_e = cj * e_x + sj * e_y  # ray direction along e
    d_p = sj * e_x - cj * e_y  # and across it
    # Contact interval in s: the wall point R d lies inside the slice ellipse (eq. 6-7),
    #   (R d_e - o_e(s))^2 cos^2(theta) + (R d_p - m_p)^2 <= r^2,
    # i.e. |R d_e - a0 - s tan(theta)| <= half tan(theta). For an untilted peg
    # tan(theta) is ~1e-300 and the interval is all of [s_lo, s_u] or empty.
    t = hole * d_p - m_p
    across = r2 - t * t
    hits = across > 0.0
    half = math.sqrt(across if hits else 0.0) / sin_t  # sqrt(across) / cos / tan
    centre = (hole * d_e - a0) / tan_t
    lo, hi = centre - half, centre + half
    # with the rim, the end face cuts the slices: the wall point lies above it only
    # from s = (low_e - R d_e) tan(theta) up (eq. 5's slices are whole ellipses,
    # which at the entry puts a tilted peg's missing corner against the wall)
    cut = (work[19, i] - hole * d_e) * tan_t if work[18, i] > 0.0 else work[8, i]
    lo = lo if lo > cut else cut
    s1 = lo if lo > work[8, i] else work[8, i]
    s2 = hi if hi < work[17, i] else work[17, i]
    hits = hits & (s2 > s1)  # else the ray misses the peg
    qa = d_e * d_e * work[6, i] + d_p * d_p
    return 0.5 * (s2 - s1), 0.5 * (s1 + s2), hits, d_e, d_p, qa


@numba.njit(cache=True, error_model="numpy", inline="always")  # type: ignore[misc]
def wall_gap(s: float, d_e: float, d_p: float, qa: float, work: FloatArray, i: int) -> float:
    """The wall's overlap rho - R at height s along a ray (:func:`ray_span`) of row i."""
    gap = _overlap(s, work[3, i], work[4, i], d_e, d_p, work[2, i], work[6, i], work[10, i], qa,
                   work[9, i])  # fmt: skip
    # with the rim, an overlap deeper than the slice lies under the wall's top is
    # pushed out the shorter way, up by the face (:mod:`.rim`): the wall's share
    # fades from all of it (overlap <= depth) to none (overlap >= 2 depth), so
    # that the wrench stays continuous in the pose
    fade = 2.0 * work[18, i] * (work[17, i] - s) - gap
    return (fade if fade > 0.0 else 0.0) if work[18, i] > 0.0 and fade < gap else gap  # type: ignore[no-any-return]


@numba.njit(cache=True, error_model="numpy")  # type: ignore[misc]
def response_kernel(
    f: FloatArray,
    table: FloatArray,
    peg_top: bool,
    ca: FloatArray,
    sa: FloatArray,
    out: FloatArray,
    work: FloatArray,
) -> None:
    """The wall's wrench on the hole (N, 5) into ``out`` for feature rows ``f`` (N, 5), row i
    with pair i of ``table`` (TABLE_ROWS, N) or its only one; ``work`` (WORK_ROWS, N) is
    scratch. With the rim (:mod:`.rim`) the wall starts under the chamfer, at z = -W, an overlap
    deeper than its slice lies under that top fades out (the face's), and the end face cuts the
    slices (a tilted peg's lowest 2 r sin(theta) are not whole ellipses)."""
    n_a = ca.shape[0]
    per_row = table.shape[1] > 1
    e_x, e_y, sin_t, arm = work[0], work[1], work[5], work[11]
    sum_g0, sum_c, sum_s, lev_c, lev_s = work[12], work[13], work[14], work[15], work[16]
    for i in range(f.shape[0]):  # per row: the lean frame, eq. (5)'s slices, the lever's arm
        row_geometry(f, table, peg_top, work, i, i if per_row else 0)

    for j in range(n_a):
        for i in range(f.shape[0]):  # vectorised: selects only
            half_len, mid, hits, d_e, d_p, qa = ray_span(ca[j], sa[j], work, i)
            g0 = g1s = 0.0  # ∫ (rho - R) ds and ∫ (rho - R) s ds along the ray
            for q in range(GL_ORDER):
                s = mid + half_len * GL_NODES[q]
                gap = wall_gap(s, d_e, d_p, qa, work, i)
                g0 += GL_WEIGHTS[q] * gap
                g1s += GL_WEIGHTS[q] * gap * s
            g0 = g0 * half_len if hits else 0.0
            g1s = g1s * half_len if hits else 0.0
            lever = g1s + arm[i] * g0
            # eq. (8) times the area element R d(alpha) ds: p dA = k (rho - R) d(alpha) ds
            sum_g0[i] += g0
            sum_c[i] += g0 * ca[j]
            sum_s[i] += g0 * sa[j]
            lev_c[i] += lever * ca[j]
            lev_s[i] += lever * sa[j]

    for i in range(f.shape[0]):
        c = i if per_row else 0
        mu = wall_friction(table, c)
        w = table[3, c] * (2.0 * math.pi / n_a)
        # Equivalent acting point (x_A, y_A): (peg_length - l/2) along the axis from (dx, dy),
        # where the axis crosses the top face, or the hole bottom's centre.
        if peg_top:
            along = table[6, c] - 0.5 * f[i, 2]
            x_a = f[i, 0] + along * sin_t[i] * e_x[i]
            y_a = f[i, 1] + along * sin_t[i] * e_y[i]
        else:
            x_a = y_a = 0.0
        out[i, 0] = w * sum_c[i]  # eq. (9)
        out[i, 1] = w * sum_s[i]  # eq. (10)
        out[i, 2] = mu * w * sum_g0[i]  # eq. (11)
        # eq. (12) with the right-hand sign: Mx = -∫(z - z_A + mu R) p R sin(alpha) + mu A_y ∫p R
        out[i, 3] = -w * lev_s[i] + mu * y_a * w * sum_g0[i]
        # eq. (13): My = ∫(z - z_A + mu R) p R cos(alpha) - mu A_x ∫p R
        out[i, 4] = w * lev_c[i] - mu * x_a * w * sum_g0[i]
