"""Coulomb friction against the peg's own sliding, where the hole block is solid
(``PegHole(rim=True)``): on the rim's faces (:mod:`.rim`) and on the bore's wall.

Eq. 11-13 take the wall's friction as μ dN along the axis, always, as if the peg were pushed in:
a peg in two-point contact then turns and slides sideways on the wall without friction, and
Whitney's wedge cannot form. With the rim the wall's friction is instead, as the faces':

    dF_t = -μ dN v_t / max(|v_t|, SLIDE_EPS)   (on the peg)

at each quadrature point of the contact, with ``v_t`` the tangential part (to the surface it
touches) of the peg's material velocity there, ``v_tip + ω × (p - tip)``: the tip centre's
velocity and the peg's angular velocity, the :data:`SLIDE` columns. A peg at rest feels no
friction; one that turns in two-point contact rubs both contacts against the turn, and one
pulled back is held by the wall, not pushed.

The quasi-static model has no velocity of its own: its caller gives it. The plant's holder
gives it the peg's motion over the period (:func:`peg_velocity_row`) of the pose it solves for,
so the regularised law is implicit there: an element whose point moves less than
:data:`SLIDE_EPS` sticks, with the law's slope; the others slide, each its own way.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.features import axis_and_tip
from fbcc_ros.core.contact.kernel import (
    GL_NODES,
    GL_ORDER,
    GL_WEIGHTS,
    ray_span,
    row_geometry,
    wall_gap,
)

#: The sliding speed below which friction is proportional to the speed [m/s]: 0.1 mm/s, a
#: fiftieth of the insertion speed, above the µm-per-period drift of a held peg.
SLIDE_EPS = 1.0e-4
#: Columns of a peg's velocity: its tip centre's (vx, vy, vz) [m/s] in {H} and its angular
#: velocity (ωx, ωy) [rad/s] about {H}'s x and y (no spin: the peg is a body of revolution).
SLIDE = 5


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def friction_on_hole(dn: float, mu: float, slide: FloatArray, rx: float, ry: float, rz: float,
                     nx: float, ny: float, nz: float) -> tuple[float, float, float]:  # fmt: skip
    """The friction force on the hole (hx, hy, hz) of a contact element carrying ``dn`` along
    the surface's normal ``n``, at ``r`` from the tip centre of a peg moving at ``slide``
    (:data:`SLIDE`)."""
    vx = slide[0] + slide[4] * rz  # v_tip + ω × r, ω = (ωx, ωy, 0)
    vy = slide[1] - slide[3] * rz
    vz = slide[2] + slide[3] * ry - slide[4] * rx
    vn = vx * nx + vy * ny + vz * nz
    tx, ty, tz = vx - vn * nx, vy - vn * ny, vz - vn * nz
    speed = math.sqrt(tx * tx + ty * ty + tz * tz)
    fric = mu * dn / (speed if speed > SLIDE_EPS else SLIDE_EPS)
    return fric * tx, fric * ty, fric * tz  # the peg drags the hole along its sliding


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def add_force(acc: FloatArray, hx: float, hy: float, hz: float, rx: float, ry: float,
              rz: float) -> None:  # fmt: skip
    """Add to ``acc`` (Fx, Fy, Fz, Mx, My, in the model's convention) a force h on the hole at
    r from the acting point."""
    acc[0] += hx
    acc[1] += hy
    acc[2] -= hz  # Fz > 0 drags the hole along -z
    acc[3] += ry * hz - rz * hy
    acc[4] += rz * hx - rx * hz


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def peg_velocity_row(now: FloatArray, before: FloatArray, peg_radius: float, inv_dt: float,
                     out: FloatArray) -> None:  # fmt: skip
    """``out`` (:data:`SLIDE`) the velocity of a peg at features ``now`` that was at ``before``
    a period 1 / ``inv_dt`` ago: its tip centre's displacement, and the turn from the old axis
    to the new (a × a' ≈ ω dt)."""
    ax, ay, az, px, py, pz = axis_and_tip(now[0], now[1], now[2], now[3], now[4], peg_radius)
    bx, by, bz, qx, qy, qz = axis_and_tip(before[0], before[1], before[2], before[3], before[4],
                                          peg_radius)  # fmt: skip
    out[0], out[1], out[2] = (px - qx) * inv_dt, (py - qy) * inv_dt, (pz - qz) * inv_dt
    out[3] = (by * az - bz * ay) * inv_dt
    out[4] = (bz * ax - bx * az) * inv_dt


@numba.njit(cache=True)  # type: ignore[misc]
def peg_velocity(now: FloatArray, before: FloatArray, peg_radius: FloatArray, inv_dt: float,
                 out: FloatArray) -> None:  # fmt: skip
    """:func:`peg_velocity_row` of every row (N, 5) into ``out`` (N, :data:`SLIDE`), row i with
    ``peg_radius[i]`` or its only one."""
    per_row = peg_radius.shape[0] > 1
    for i in range(now.shape[0]):
        peg_velocity_row(now[i], before[i], peg_radius[i if per_row else 0], inv_dt, out[i])


@numba.njit(cache=True, error_model="numpy")  # type: ignore[misc]
def wall_friction_kernel(
    f: FloatArray,
    slide: FloatArray,
    table: FloatArray,
    peg_top: bool,
    ca: FloatArray,
    sa: FloatArray,
    out: FloatArray,
    work: FloatArray,
) -> None:
    """Add the bore wall's friction against the peg's sliding (module doc) to ``out`` (N, 5)
    for the rows whose pair has the rim (eq. 11-13's axial friction is left out of theirs,
    :func:`~.kernel.wall_friction`); the others are left as they are. The wall's normal
    pressure and quadrature are eq. 8's (:func:`~.kernel.response_kernel`, its rays ``ca``,
    ``sa``), and so is its acting point. ``work`` (WORK_ROWS, N) is
    scratch; ``slide`` (N, :data:`SLIDE`)."""
    n_a = ca.shape[0]
    per_row = table.shape[1] > 1
    acc = np.zeros(5)
    for i in range(f.shape[0]):
        c = i if per_row else 0
        if table[8, c] <= 0.0:
            continue
        row_geometry(f, table, peg_top, work, i, c)
        R, r, mu = table[0, c], table[1, c], table[2, c]
        _, _, _, px, py, pz = axis_and_tip(f[i, 0], f[i, 1], f[i, 2], f[i, 3], f[i, 4], r)
        # eq. 12-13's acting point (response_kernel's): on the axis where it crosses the top
        # face (its height from the lever arm, eq. 11's mu R left out), or the hole bottom's
        s_u = work[7, i]
        gz = -s_u - work[11, i]
        gx = gy = 0.0
        if peg_top:
            along = (table[6, c] - 0.5 * f[i, 2]) * work[5, i]
            gx, gy = f[i, 0] + along * work[0, i], f[i, 1] + along * work[1, i]
        w = table[3, c] * (2.0 * math.pi / n_a)
        acc[:] = 0.0
        for j in range(n_a):
            half_len, mid, hits, d_e, d_p, qa = ray_span(ca[j], sa[j], work, i)
            if not hits:
                continue
            x, y = R * ca[j], R * sa[j]  # the wall point, outward normal (ca, sa, 0)
            for q in range(GL_ORDER):
                s = mid + half_len * GL_NODES[q]
                gap = wall_gap(s, d_e, d_p, qa, work, i)
                if gap <= 0.0:
                    continue
                dn = w * GL_WEIGHTS[q] * half_len * gap  # eq. (8): k (rho - R) d(alpha) ds
                z = s - s_u
                hx, hy, hz = friction_on_hole(dn, mu, slide[i], x - px, y - py, z - pz, ca[j],
                                              sa[j], 0.0)  # fmt: skip
                add_force(acc, hx, hy, hz, x - gx, y - gy, z - gz)
        for m in range(5):
            out[i, m] += acc[m]


def as_slide(slide: FloatArray | None, n: int) -> FloatArray:
    """(N, :data:`SLIDE`) velocities of ``slide`` (None: at rest; 3 columns: no turn)."""
    v = np.zeros((n, SLIDE))
    if slide is not None:
        v[:, : slide.shape[1]] = slide
    return v
