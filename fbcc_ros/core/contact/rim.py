"""The hole's rim in the contact model: its top face, a 45° chamfer and its bottom, pressing on the
peg's end face. Eq. 5-13 (:mod:`.kernel`) are the wall alone: a peg beside the hole touches
nothing, so finding the hole was never part of the paper's problem. A real hole block is solid
around and under the bore; with ``PegHole(rim=True)`` the model adds, in {H} (ρ the distance from
the hole's axis):

* the **top face**, z = 0 for ρ ≥ R + W, outward normal ẑ;
* a 45° **chamfer** of width W (0: a sharp edge), the cone z = -(R + W - ρ) for R ≤ ρ < R + W,
  outward normal (ẑ - ρ̂)/√2: it pushes a peg on it up and toward the axis;
* the **bottom**, z = -L under the bore, outward normal ẑ.

**Contact law.** Eq. 8's form, on the peg's end face: an element dA that lies g inside the
solid (along the surface's normal) carries ``p = k g / h`` along the normal, with the wall's k
and the depth :data:`FACE_DEPTH` for eq. 8's R. Eq. 8 spreads a wall's overlap over the whole
ring of radius R; an edge on a face compresses the material only about as deep as the contact is
wide, tens of microns at these clearances: an elastic line contact is about E N/m per metre of
edge, 3e9 N/m on 15 mm of steel, against 1.7e7 N/m of ``k g / R`` on the crescent below (MuJoCo's
face, ~1e9 N/m). An element beside the bore and under the wall's top
(ρ > R, z < -W) that lies deeper under the face than it overlaps the wall (ρ - R) is the wall's:
the solid pushes it out the shorter way, as a convex collision does (MuJoCo's too). The wall in
turn leaves out the overlaps deeper than they lie under the wall's top: all of an overlap under
its depth d counts, none over 2 d, linearly between, so that the wrench stays continuous in the
pose (:func:`~.kernel.response_kernel`). So a peg standing 0.1 mm off a 10 µm hole is held up
by the face on a crescent 90 µm wide, the wall pushes it only at the crescent's two tips, and
the support's moment, about 0.8 r times Fz, tips it toward the hole.

**Friction.** Coulomb on every element, against the peg's own sliding there
(:mod:`.sliding`, which the bore's wall shares with the rim): a peg at rest on the face feels
no friction there.

**Quadrature.** The end face in polar coordinates about its centre, ``ρ' dρ' dφ``:
:data:`RAYS_PER_WALL_RAY` times ``n_angles`` rays fixed in the peg's frame, each cut exactly
wherever its integrand has a kink (:data:`~.kernel.GL_ORDER` Gauss-Legendre nodes per piece):
where it crosses ρ = R and ρ = R + W, the chamfer's surface,
the two face-or-wall boundaries (all roots of a quadratic in ρ') and z = 0, -W, -L (linear).
The crescent above is 90 µm wide on a 5 mm face, which a uniform grid would miss; an aligned
peg on the chamfer touches it on a sliver microns wide.

The response is the wrench on the hole in the model's convention (:meth:`~.model.PegHole.
response`): ``Fz`` positive when the peg pushes the hole along -z, moments about the pair's
acting point.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.features import axis_and_tip
from fbcc_ros.core.contact.kernel import GL_NODES, GL_ORDER, GL_WEIGHTS
from fbcc_ros.core.contact.sliding import add_force, friction_on_hole

#: Rays of the end face per ray of the wall: a face contact is a crescent or a patch at an edge,
#: far narrower than the wall's band. Fixed in the peg's frame, so that the wrench is continuous
#: in the pose (the holder's Newton iteration needs that): a tilted edge's point contact between
#: two rays is missed until it is r (1 - cos(pi / rays)) sin(tilt) deep, 0.02 µm at 2°.
RAYS_PER_WALL_RAY = 4
#: The depth of material an edge compresses on a face [m]: the face's ``p = k g / FACE_DEPTH``
#: (module doc), the order of the contact widths of a peg at micron clearances.
FACE_DEPTH = 1.0e-4
#: 1/√2: the 45° chamfer's normal components and its depth-to-normal factor.
_HALF_SQRT2 = math.sqrt(0.5)
#: 1 - 1/√2: rho's factor where the chamfer's depth equals the overlap with the wall.
_WALL_CONE = 1.0 - _HALF_SQRT2


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def _radius_roots(a: float, b: float, c0: float, alpha: float, beta: float, out: FloatArray,
                  n: int) -> int:  # fmt: skip
    """Append to ``out`` the ρ' where a ray ``c + ρ' d`` (``a = |d_xy|²``, ``b = c·d_xy``,
    ``c0 = |c_xy|²``) lies ``alpha + beta ρ'`` from the axis (a circle: beta = 0; a cone's
    surface: the height along the ray is linear in ρ'); returns the new count."""
    qa, qb, qc = a - beta * beta, b - alpha * beta, c0 - alpha * alpha
    if abs(qa) < 1e-12:
        if qb != 0.0:
            out[n] = -0.5 * qc / qb
            return n + 1
        return n
    disc = qb * qb - qa * qc
    if disc > 0.0:
        root = math.sqrt(disc)
        out[n] = (-qb - root) / qa
        out[n + 1] = (-qb + root) / qa
        return n + 2
    return n


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def _depth(ex: float, ey: float, ez: float, R: float, W: float, L: float
           ) -> tuple[float, float, float, float]:  # fmt: skip
    """How deep the point (ex, ey, ez) of the end face lies in the rim's solid, and the
    surface's outward normal there (module doc): ``(gap, nx, ny, nz)``, gap <= 0 outside."""
    rho = math.hypot(ex, ey)
    gap, nx, ny, nz = 0.0, 0.0, 0.0, 1.0
    if rho > R:
        if rho >= R + W:  # the top face
            gap = -ez
        else:  # the chamfer: depth under the cone, along its normal
            gap = (-(R + W - rho) - ez) * _HALF_SQRT2
            nx, ny, nz = -ex / rho * _HALF_SQRT2, -ey / rho * _HALF_SQRT2, _HALF_SQRT2
        if ez < -W and rho - R < gap:  # nearer the bore's wall: the wall's
            gap = 0.0
    elif ez < -L:  # the bottom
        gap = -L - ez
    return gap, nx, ny, nz


@numba.njit(cache=True, error_model="numpy")  # type: ignore[misc]
def rim_kernel(
    f: FloatArray,
    slide: FloatArray,
    table: FloatArray,
    peg_top: bool,
    ca: FloatArray,
    sa: FloatArray,
    out: FloatArray,
) -> None:
    """Add the rim's wrench on the hole (module doc) to ``out`` (N, 5), for feature rows ``f``
    (N, 5), any depth, the peg's velocity ``slide`` (N, :data:`~.sliding.SLIDE`), row i with
    pair i of ``table`` (:data:`~.kernel.TABLE_ROWS`, N) or its only one; rows whose pair has
    no rim are left as they are. ``ca``, ``sa``: the rays' angles (:func:`~.kernel.angle_table`).
    The friction is :func:`~.sliding.friction_on_hole`'s, on each element's own motion."""
    n_a = ca.shape[0]
    per_row = table.shape[1] > 1
    cuts = np.empty(16)
    acc = np.zeros(5)  # the row's wrench on the hole
    for i in range(f.shape[0]):
        c = i if per_row else 0
        if table[8, c] <= 0.0:
            continue
        R, r, mu, k = table[0, c], table[1, c], table[2, c], table[3, c]
        L, H, peg_length, W = table[4, c], table[5, c], table[6, c], table[7, c]
        ax, ay, az, px, py, pz = axis_and_tip(f[i, 0], f[i, 1], f[i, 2], f[i, 3], f[i, 4], r)
        # the end face lies within r sin(theta) of its centre's height: skip what is clear of
        # the face, the chamfer and the bottom (most rows of an insertion)
        reach = r * math.sqrt(ax * ax + ay * ay)
        if pz - reach > 0.0 or (pz - reach > -L and math.hypot(px, py) + r < R):
            continue
        # the end face's axes u, v: the swing rotation's first two columns (features._swing)
        q = 1.0 / (1.0 + az)
        ux, uy, uz = 1.0 - ax * ax * q, -ax * ay * q, -ax
        vx, vy, vz = -ax * ay * q, 1.0 - ay * ay * q, -ay
        if peg_top:  # the acting point: the grip point on the axis, or the hole bottom's centre
            gx, gy, gz = px + peg_length * ax, py + peg_length * ay, pz + peg_length * az
        else:
            gx, gy, gz = 0.0, 0.0, -(L + H)
        acc[:] = 0.0
        w_ray = k / FACE_DEPTH * (2.0 * math.pi / n_a)
        for j in range(n_a):
            dx, dy, dz = ca[j] * ux + sa[j] * vx, ca[j] * uy + sa[j] * vy, ca[j] * uz + sa[j] * vz
            a2, b, c0 = dx * dx + dy * dy, px * dx + py * dy, px * px + py * py
            # the ray's pieces: [0, r] cut where it crosses the circles and the planes
            n_cut = 0
            cuts[n_cut] = 0.0
            cuts[n_cut + 1] = r
            n_cut = _radius_roots(a2, b, c0, R, 0.0, cuts, n_cut + 2)
            n_cut = _radius_roots(a2, b, c0, R + W, 0.0, cuts, n_cut)
            # the chamfer's surface, rho = R + W + z, and where the face's or the chamfer's
            # depth equals the overlap with the wall: rho - R = -z, and
            # rho - R = (z_cone - z) / sqrt(2)
            n_cut = _radius_roots(a2, b, c0, R + W + pz, dz, cuts, n_cut)
            n_cut = _radius_roots(a2, b, c0, R - pz, -dz, cuts, n_cut)
            n_cut = _radius_roots(a2, b, c0, (R - (R + W + pz) * _HALF_SQRT2) / _WALL_CONE,
                                  -dz * _HALF_SQRT2 / _WALL_CONE, cuts, n_cut)  # fmt: skip
            if dz != 0.0:
                for z_cut in (0.0, -W, -L):
                    cuts[n_cut] = (z_cut - pz) / dz
                    n_cut += 1
            for m in range(1, n_cut):  # insertion sort of a handful of numbers
                x, p = cuts[m], m - 1
                while p >= 0 and cuts[p] > x:
                    cuts[p + 1] = cuts[p]
                    p -= 1
                cuts[p + 1] = x
            for m in range(n_cut - 1):
                lo = cuts[m] if cuts[m] > 0.0 else 0.0
                hi = cuts[m + 1] if cuts[m + 1] < r else r
                if hi <= lo:
                    continue
                half, mid = 0.5 * (hi - lo), 0.5 * (hi + lo)
                for g_node in range(GL_ORDER):
                    rho_p = mid + half * GL_NODES[g_node]
                    ex, ey, ez = px + rho_p * dx, py + rho_p * dy, pz + rho_p * dz
                    gap, nx, ny, nz = _depth(ex, ey, ez, R, W, L)
                    if gap <= 0.0:
                        continue
                    dn = w_ray * GL_WEIGHTS[g_node] * half * rho_p * gap  # p dA
                    # the force on the hole: minus the normal push and the friction on the peg
                    hx, hy, hz = friction_on_hole(dn, mu, slide[i], ex - px, ey - py, ez - pz,
                                                  nx, ny, nz)  # fmt: skip
                    add_force(acc, hx - dn * nx, hy - dn * ny, hz - dn * nz, ex - gx, ey - gy,
                              ez - gz)  # fmt: skip
        for m in range(5):
            out[i, m] += acc[m]
