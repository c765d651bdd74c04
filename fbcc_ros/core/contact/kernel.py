"""The contact model's compiled core: eq. (5)-(13) for rows of features, by quadrature over rays
around the peg (the angle table) and Gauss-Legendre nodes along them. :class:`ContactBatch` of
:mod:`fbcc_ros.core.contact.model` calls it; the closed-loop simulator does so once per 1 ms
step, where numpy's per-call overhead alone would cost ~80 us.
"""

from __future__ import annotations

import functools
import math
import types
from typing import Any

import numba
import numpy as np

from fbcc_ros.core.arrays import FloatArray

# Gauss-Legendre nodes and weights on [-1, 1] for the integral along s on each contact interval.
GL_NODES, GL_WEIGHTS = np.polynomial.legendre.leggauss(3)


@functools.lru_cache(maxsize=8)
def angle_table(n_angles: int) -> tuple[FloatArray, FloatArray]:
    """cos and sin of the ray angles: uniform periodic midpoint rule over alpha in [-pi, pi)."""
    alpha = -math.pi + (np.arange(n_angles) + 0.5) * (2.0 * math.pi / n_angles)
    return np.cos(alpha), np.sin(alpha)


@numba.njit(cache=True, fastmath=False)  # type: ignore[misc]
def response_kernel(
    f: FloatArray,
    table: FloatArray,
    peg_top: bool,
    ca: FloatArray,
    sa: FloatArray,
    gl_x: FloatArray,
    gl_w: FloatArray,
    out: FloatArray,
) -> None:
    n_a = ca.shape[0]
    for i in range(f.shape[0]):
        c = i if table.shape[1] > 1 else 0  # the pair of this row
        R, r, mu, k = table[0, c], table[1, c], table[2, c], table[3, c]
        L, H, peg_length = table[4, c], table[5, c], table[6, c]
        w = k * (2.0 * math.pi / n_a)
        dx, dy, l, thx, thy = f[i, 0], f[i, 1], f[i, 2], f[i, 3], f[i, 4]
        # Lean of the axis per unit height, t = (tan theta_y, -tan theta_x) (right-hand
        # theta_x). The 1e-300 picks e = +x for an untilted peg without a branch; it is below
        # rounding otherwise.
        tx, ty = math.tan(thy) + 1e-300, -math.tan(thx)
        tan_t = math.hypot(tx, ty)
        ex, ey = tx / tan_t, ty / tan_t
        cos_t = 1.0 / math.sqrt(1.0 + tan_t * tan_t)
        sin_t = tan_t * cos_t
        cos2 = cos_t * cos_t

        # Midpoint offset in the lean frame (e along the lean, e_perp = z x e across it).
        m_e = dx * ex + dy * ey
        m_p = dy * ex - dx * ey
        # eq. (5) along e: o_e(s) = a0 + s tan(theta), a0 = m_e - (l/2 + r sin theta) sin theta
        a0 = m_e - (0.5 * l + r * sin_t) * sin_t
        s_u = l * cos_t  # top face of the hole, s_u = l cos(theta)
        s_lo = max(0.0, s_u - L)  # no wall below the hole's depth L

        # Equivalent acting point (z_A, x_A, y_A) in {H}.
        if peg_top:
            # On the axis, peg_length from the tip centre. By eq. (5) the tip centre sits at
            # s_tip = r sin(theta) cos(theta) and the axis crosses (dx, dy) l/2 further along
            # it, so the acting point is (peg_length - l/2) along the axis from (dx, dy).
            along = peg_length - 0.5 * l
            z_a = r * sin_t * cos_t + peg_length * cos_t - s_u
            x_a, y_a = dx + along * sin_t * ex, dy + along * sin_t * ey
        else:
            z_a, x_a, y_a = -(L + H), 0.0, 0.0
        # lever arm of eq. (12)-(13): z - z_A + mu R, with the slice height z = s - s_u
        arm = mu * R - s_u - z_a

        sum_c = sum_s = sum_g0 = lev_c = lev_s = 0.0
        for j in range(n_a):
            d_e = ca[j] * ex + sa[j] * ey  # ray direction along e
            d_p = sa[j] * ex - ca[j] * ey  # and across it
            # Contact interval in s: the wall point R d lies inside the slice ellipse (eq. 6-7),
            #   (R d_e - o_e(s))^2 cos^2(theta) + (R d_p - m_p)^2 <= r^2,
            # i.e. |R d_e - a0 - s tan(theta)| <= half tan(theta). For an untilted peg
            # tan(theta) is ~1e-300 and the interval is all of [s_lo, s_u] or empty.
            across = r * r - (R * d_p - m_p) ** 2
            if across <= 0.0:
                continue
            half = math.sqrt(across) / sin_t  # = sqrt(across) / cos(theta) / tan(theta)
            centre = (R * d_e - a0) / tan_t
            s1 = max(centre - half, s_lo)
            s2 = min(centre + half, s_u)
            if s2 <= s1:
                continue  # the ray misses the peg
            half_len, mid = 0.5 * (s2 - s1), 0.5 * (s1 + s2)
            g0 = g1s = 0.0  # ∫ (rho - R) ds and ∫ (rho - R) s ds along the ray
            for q in range(gl_x.shape[0]):
                s = mid + half_len * gl_x[q]
                o_e = a0 + s * tan_t
                # Far intersection of the ray with the ellipse: A rho^2 - 2 B rho + C = 0.
                qa = d_e * d_e * cos2 + d_p * d_p
                qb = d_e * o_e * cos2 + d_p * m_p
                qc = o_e * o_e * cos2 + (m_p * m_p - r * r)
                rho = (qb + math.sqrt(max(qb * qb - qa * qc, 0.0))) / qa
                if rho > R:
                    g0 += gl_w[q] * (rho - R)
                    g1s += gl_w[q] * (rho - R) * s
            g0 *= half_len
            g1s *= half_len
            lever = g1s + arm * g0
            # eq. (8) times the area element R d(alpha) ds: p dA = k (rho - R) d(alpha) ds
            sum_g0 += g0
            sum_c += g0 * ca[j]
            sum_s += g0 * sa[j]
            lev_c += lever * ca[j]
            lev_s += lever * sa[j]
        out[i, 0] = w * sum_c  # eq. (9)
        out[i, 1] = w * sum_s  # eq. (10)
        out[i, 2] = mu * w * sum_g0  # eq. (11)
        # eq. (12) with the right-hand sign: Mx = -∫(z - z_A + mu R) p R sin(alpha) + mu A_y ∫p R
        out[i, 3] = -w * lev_s + mu * y_a * w * sum_g0
        # eq. (13): My = ∫(z - z_A + mu R) p R cos(alpha) - mu A_x ∫p R
        out[i, 4] = w * lev_c - mu * x_a * w * sum_g0


#: Floating-point liberties for a measurement model whose last bits do not matter (the deviation
#: filter's, whose likelihood floors are 2-5 %): fused multiply-adds, reciprocals and
#: approximate functions; not reordering, nor assuming no NaN or infinity (an untilted peg's
#: interval is infinite). About 25 % less CPU than the strict kernel (4000 particles in contact,
#: 3.4 → 2.5 ms), with responses within 1e-14 of its own, relative. The simulator keeps the
#: strict kernel, so that its documented results reproduce to the bit.
LOOSE_MATH = frozenset({"contract", "arcp", "afn"})


def _loose(kernel: Any) -> Any:
    """``kernel`` compiled with :data:`LOOSE_MATH`, under a name of its own: numba's cache keys
    a compiled function by its name and code, not by its flags."""
    py = kernel.py_func
    clone = types.FunctionType(py.__code__, py.__globals__, f"{py.__name__}_loose",
                               py.__defaults__, py.__closure__)  # fmt: skip
    clone.__qualname__ = clone.__name__
    clone.__doc__ = f"{py.__name__} under LOOSE_MATH."
    return numba.njit(cache=True, fastmath=set(LOOSE_MATH))(clone)


loose_response_kernel = _loose(response_kernel)
