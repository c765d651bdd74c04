"""The compiled damped Newton iteration of :class:`fbcc_ros.core.sim.holder_solver.HolderSolver`,
one row at a time (the solver's module doc describes the steps; ``HolderSolver._batched`` runs
the same steps in numpy for any response callable): numpy's per-call overhead over 4x4 (5x5
with the rim) blocks of a 128-row batch would cost several times the contact kernel itself.
Residuals are scaled by the tolerances, so "converged" means ``|residual| <= 1`` in every
coordinate."""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact import kernel as contact_kernel
from fbcc_ros.core.contact import rim as contact_rim
from fbcc_ros.core.contact import sliding
from fbcc_ros.core.sim.holder import BoolArray

#: Forward-difference steps of the Jacobian: u_x, u_y [m], phi_x, phi_y [rad], and u_l [m] where
#: the pair has the rim. Small against the microns the peg moves, large against rounding (3e9
#: N/m × 1e-9 m = 3 N vs ~1e-8 N noise).
FD_STEP = np.array([1e-9, 1e-9, 1e-7, 1e-7, 1e-9])
#: The largest Newton step of a row with the rim, per coordinate: u_x, u_y [m], phi_x, phi_y
#: [rad], u_l [m]. A face contact's equilibria lie microns apart (on the face, or tipped into
#: the hole); a longer step from a Jacobian taken on one can land on another.
TRUST = np.array([1e-6, 1e-6, 2e-5, 2e-5, 1e-6])
#: Coordinates of a row: the lateral and angular four, and the depth's where the pair has the
#: rim (the face pushes along the axis; the paper's wall alone leaves the depth rigid).
N_LATERAL, N_AXIAL = 4, 5
#: Sufficient decrease of the squared scaled residual for a step to be accepted (Armijo).
ARMIJO = 1e-4
#: A step that leaves more than this fraction of the squared residual asks for a fresh Jacobian.
SLOW = 0.25
#: Smallest step fraction of the line search: below it a row gives up for this call.
T_MIN = 1e-10
#: Bisections for the contact's onset between a deflection off the wall and none (2^-40 of a
#: deflection of microns to millimetres: under a picometre).
ONSET_BISECTIONS = 40


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def _sin_cos_tilt(theta_x: float, theta_y: float) -> tuple[float, float]:
    """sin and cos of the total tilt of the projected tilts (tan = |(tan thy, tan thx)|)."""
    tan_t = math.hypot(math.tan(theta_y), math.tan(theta_x))
    cos_t = 1.0 / math.sqrt(1.0 + tan_t * tan_t)
    return tan_t * cos_t, cos_t


@numba.njit(cache=True, error_model="numpy")  # type: ignore[misc]
def _row_residual(
    xr: FloatArray, h: float, q: FloatArray, tab: FloatArray, peg_top: bool,
    ca: FloatArray, sa: FloatArray, rim_ca: FloatArray, rim_sa: FloatArray, last: FloatArray,
    inv_dt: float, vbuf: FloatArray, work: FloatArray, k: FloatArray,
    tol: FloatArray, fbuf: FloatArray, wbuf: FloatArray, r: FloatArray, n_q: int,
) -> float:  # fmt: skip
    """Features of deflection q into fbuf[0], wrench into wbuf[0], scaled residual into r (its
    first ``n_q`` coordinates); returns the squared residual."""
    fbuf[0, 0] = xr[0] + q[0] - h * q[3]
    fbuf[0, 1] = xr[1] + q[1] + h * q[2]
    fbuf[0, 2] = xr[2]
    fbuf[0, 3] = xr[3] + q[2]
    fbuf[0, 4] = xr[4] + q[3]
    if n_q == N_AXIAL:
        # turned about its grip, the peg's tip centre keeps its depth (h phi^2 / 2 neglected,
        # as laterally) and the depth l of its end face's lowest point follows the tilt
        # (:mod:`~fbcc_ros.core.contact.features`): the face feels the tip, not l
        rad = tab[1, 0]
        s_r, c_r = _sin_cos_tilt(xr[3], xr[4])
        s_n, c_n = _sin_cos_tilt(fbuf[0, 3], fbuf[0, 4])
        fbuf[0, 2] = (xr[2] * c_r - rad * s_r + rad * s_n) / c_n + q[4]
    contact_kernel.response_kernel(fbuf, tab, peg_top, ca, sa, wbuf, work)
    if n_q == N_AXIAL:
        # the rim's and the wall's friction (:mod:`~fbcc_ros.core.contact.sliding`): the
        # regularised Coulomb law on each element's motion since the last period, implicit in
        # the pose solved for (a peg that moves less than SLIDE_EPS a second there sticks)
        sliding.peg_velocity_row(fbuf[0], last, tab[1, 0], inv_dt, vbuf[0])
        contact_rim.rim_kernel(fbuf, vbuf, tab, peg_top, rim_ca, rim_sa, wbuf)
        sliding.wall_friction_kernel(fbuf, vbuf, tab, peg_top, ca, sa, wbuf, work)
    fx, fy, fz, mx, my = wbuf[0, 0], wbuf[0, 1], wbuf[0, 2], wbuf[0, 3], wbuf[0, 4]
    if not peg_top:  # moments from (0, 0, -(L + H)) to the grip point (module doc)
        pl, rad, depth = tab[6, 0], tab[1, 0], tab[4, 0] + tab[5, 0]
        tx, ty = math.tan(fbuf[0, 4]), -math.tan(fbuf[0, 3])
        tan2 = tx * tx + ty * ty
        cos_t = 1.0 / math.sqrt(1.0 + tan2)
        sin_t = math.sqrt(tan2) * cos_t
        along = (pl - 0.5 * xr[2]) * cos_t
        x_g, y_g = fbuf[0, 0] + along * tx, fbuf[0, 1] + along * ty
        hz = (rad * sin_t + pl - xr[2]) * cos_t + depth
        mx, my = mx + y_g * fz + hz * fy, my - hz * fx - x_g * fz
    r[0] = (k[0] * q[0] + fx) / tol[0]
    r[1] = (k[1] * q[1] + fy) / tol[1]
    r[2] = (k[2] * q[2] + mx) / tol[2]
    r[3] = (k[3] * q[3] + my) / tol[3]
    if n_q == N_AXIAL:  # the face pushes the peg out, the axial spring back in: k u_l + Fz = 0
        r[4] = (k[4] * q[4] + fz) / tol[4]
    merit = r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]
    if n_q == N_AXIAL:
        merit += r[4] * r[4]
    return float(merit)


@numba.njit(cache=True, error_model="numpy")  # type: ignore[misc]
def _touches_nothing(wbuf: FloatArray) -> bool:
    """Whether the wrench in wbuf[0] is exactly zero (the kernel's "no contact")."""
    for m in range(5):
        if wbuf[0, m] != 0.0:
            return False
    return True


@numba.njit(cache=True, error_model="numpy")  # type: ignore[misc]
def _is_off_wall(q: FloatArray, wbuf: FloatArray) -> bool:
    """Whether deflection q touches nothing with the holder deflected (one row; the wrench in
    wbuf[0]): no equilibrium, see :mod:`fbcc_ros.core.sim.holder_solver`."""
    if not _touches_nothing(wbuf):
        return False
    return bool(q[0] != 0.0 or q[1] != 0.0 or q[2] != 0.0 or q[3] != 0.0 or q[4] != 0.0)


@numba.njit(cache=True, error_model="numpy")  # type: ignore[misc]
def _converged(r: FloatArray, n_q: int) -> bool:
    """Whether every scaled residual of a row's n_q coordinates is within 1."""
    for m in range(n_q):
        if not abs(r[m]) <= 1.0:
            return False
    return True


@numba.njit(cache=True, error_model="numpy")  # type: ignore[misc]
def _solve(a_in: FloatArray, b: FloatArray, a: FloatArray, out: FloatArray, n: int) -> None:
    """out = a_in^-1 b on the first n coordinates by Gaussian elimination with partial
    pivoting (a: scratch as large); a singular or non-finite system gives out = b."""
    for i in range(n):
        out[i] = b[i]
        for j in range(n):
            a[i, j] = a_in[i, j]
    for c in range(n):
        p = c
        for i in range(c + 1, n):
            if abs(a[i, c]) > abs(a[p, c]):
                p = i
        piv = a[p, c]
        if not (abs(piv) > 1e-300 and math.isfinite(piv)):
            for i in range(n):
                out[i] = b[i]
            return
        if p != c:
            for j in range(n):
                a[c, j], a[p, j] = a[p, j], a[c, j]
            out[c], out[p] = out[p], out[c]
        for i in range(c + 1, n):
            f = a[i, c] / piv
            for j in range(c, n):
                a[i, j] -= f * a[c, j]
            out[i] -= f * out[c]
    for c in range(n - 1, -1, -1):
        s = out[c]
        for j in range(c + 1, n):
            s -= a[c, j] * out[j]
        out[c] = s / a[c, c]
    for i in range(n):
        if not math.isfinite(out[i]):
            for m in range(n):
                out[m] = b[m]
            return


@numba.njit(cache=True, error_model="numpy")  # type: ignore[misc]
def solve_rows(
    xr: FloatArray, h: FloatArray, q: FloatArray, back: FloatArray, jac: FloatArray,
    have: BoolArray, table: FloatArray, peg_top: bool, ca: FloatArray, sa: FloatArray,
    rim_ca: FloatArray, rim_sa: FloatArray, last: FloatArray, inv_dt: float,
    k_rows: FloatArray, tol: FloatArray, max_iter: int,
    fd: FloatArray, x_out: FloatArray, w_out: FloatArray, conv: BoolArray,
    evals: NDArray[np.int64], iters: NDArray[np.int64],
) -> None:  # fmt: skip
    n = xr.shape[0]
    tab = np.empty((contact_kernel.TABLE_ROWS, 1))
    work = np.empty((contact_kernel.WORK_ROWS, 1))  # the contact kernel's scratch
    fbuf, wbuf = np.empty((1, 5)), np.empty((1, 5))
    fbuf_t, wbuf_t = np.empty((1, 5)), np.empty((1, 5))
    vbuf = np.zeros((1, sliding.SLIDE))  # the peg's velocity, for the friction
    r, rt, qt, s, neg = (np.zeros(N_AXIAL), np.zeros(N_AXIAL), np.zeros(N_AXIAL),
                         np.zeros(N_AXIAL), np.zeros(N_AXIAL))  # fmt: skip
    dz, dr, jdz = np.empty(N_AXIAL), np.empty(N_AXIAL), np.empty(N_AXIAL)
    scratch = np.empty((N_AXIAL, N_AXIAL))
    for i in range(n):
        c = i if table.shape[1] > 1 else 0
        for m in range(contact_kernel.TABLE_ROWS):
            tab[m, 0] = table[m, c]
        qi, ji, li = q[i], jac[i], last[i]
        k = k_rows[i if k_rows.shape[0] > 1 else 0]  # the row's holder, or the one of all
        n_q = N_AXIAL if tab[8, 0] > 0.0 else N_LATERAL
        merit = _row_residual(xr[i], h[i], qi, tab, peg_top, ca, sa, rim_ca, rim_sa, li,
                              inv_dt, vbuf, work, k, tol, fbuf, wbuf, r, n_q)  # fmt: skip
        n_eval = 1
        for fallback in range(2):  # off the wall: start from the last solution, then from 0
            if not _is_off_wall(qi, wbuf):
                break
            for m in range(n_q):
                qi[m] = back[i, m] if fallback == 0 else 0.0
            merit = _row_residual(xr[i], h[i], qi, tab, peg_top, ca, sa, rim_ca, rim_sa, li,
                                  inv_dt, vbuf, work, k, tol, fbuf, wbuf, r, n_q)  # fmt: skip
            n_eval += 1
            if fallback == 1 and not _touches_nothing(wbuf):
                # the last solution touches nothing and no deflection is in contact: the peg
                # released moves toward the hand until it meets the solid, so start at that
                # onset on the way, not deep in it (a hand pressed 0.1 mm past a face it slid
                # off: kN that the trust region's micron steps never leave)
                held, free = 0.0, 1.0  # fractions of the last deflection: in contact, not
                for _ in range(ONSET_BISECTIONS):
                    mid = 0.5 * (held + free)
                    for m in range(n_q):
                        qt[m] = mid * back[i, m]
                    _row_residual(xr[i], h[i], qt, tab, peg_top, ca, sa, rim_ca, rim_sa, li,
                                  inv_dt, vbuf, work, k, tol, fbuf_t, wbuf_t, rt, n_q)  # fmt: skip
                    if _touches_nothing(wbuf_t):
                        free = mid
                    else:
                        held = mid
                for m in range(n_q):
                    qi[m] = held * back[i, m]
                merit = _row_residual(xr[i], h[i], qi, tab, peg_top, ca, sa, rim_ca, rim_sa,
                                      li, inv_dt, vbuf, work, k, tol, fbuf, wbuf, r,
                                      n_q)  # fmt: skip
                n_eval += ONSET_BISECTIONS + 1
        it, t, fresh = 0, 1.0, False
        done = _converged(r, n_q)
        while not done and it < max_iter:
            it += 1
            if not have[i]:  # forward differences in scaled units
                for j in range(n_q):
                    for m in range(n_q):
                        qt[m] = qi[m]
                    qt[j] += fd[j]
                    _row_residual(xr[i], h[i], qt, tab, peg_top, ca, sa, rim_ca, rim_sa, li,
                                  inv_dt, vbuf, work, k, tol, fbuf_t, wbuf_t, rt, n_q)  # fmt: skip
                    for m in range(n_q):
                        ji[m, j] = (rt[m] - r[m]) / (fd[j] * k[j] / tol[j])
                n_eval += 4
                have[i] = fresh = True
            for m in range(n_q):
                neg[m] = -r[m]
            _solve(ji, neg, scratch, s, n_q)
            reach = 1.0
            if n_q == N_AXIAL:  # a trust region: the peg moves on along the equilibrium it is on
                for m in range(n_q):
                    reach = max(reach, abs(s[m] * tol[m] / k[m]) / TRUST[m])
            for m in range(n_q):
                qt[m] = qi[m] + t * s[m] * tol[m] / k[m] / reach
            mt = _row_residual(xr[i], h[i], qt, tab, peg_top, ca, sa, rim_ca, rim_sa, li,
                               inv_dt, vbuf, work, k, tol, fbuf_t, wbuf_t, rt, n_q)  # fmt: skip
            n_eval += 1
            if _is_off_wall(qt, wbuf_t):  # no equilibrium there: no deflection, or back
                for m in range(n_q):
                    qt[m] = 0.0
                mt = _row_residual(xr[i], h[i], qt, tab, peg_top, ca, sa, rim_ca, rim_sa, li,
                                   inv_dt, vbuf, work, k, tol, fbuf_t, wbuf_t, rt,
                                   n_q)  # fmt: skip
                n_eval += 1
                if not _touches_nothing(wbuf_t):
                    mt = math.inf
            if mt < (1.0 - ARMIJO * t) * merit:  # False for NaN
                den = 0.0
                for m in range(n_q):
                    dz[m] = (qt[m] - qi[m]) * k[m] / tol[m]
                    dr[m] = rt[m] - r[m]
                    den += dz[m] * dz[m]
                if den > 0.0:  # Broyden's rank-one update
                    for m in range(n_q):
                        jdz[m] = 0.0
                        for j in range(n_q):
                            jdz[m] += ji[m, j] * dz[j]
                    for m in range(n_q):
                        for j in range(n_q):
                            v = ji[m, j] + (dr[m] - jdz[m]) * dz[j] / den
                            if math.isfinite(v):
                                ji[m, j] = v
                if mt > SLOW * merit:
                    have[i] = False
                for m in range(n_q):
                    qi[m], r[m] = qt[m], rt[m]
                for m in range(5):
                    fbuf[0, m], wbuf[0, m] = fbuf_t[0, m], wbuf_t[0, m]
                merit, t, fresh = mt, 1.0, False
            elif fresh:  # a fresh Jacobian's step failed: halve it
                t *= 0.5
                if t < T_MIN:
                    break
            else:  # a stale Jacobian's: refresh it
                have[i] = False
            done = _converged(r, n_q)
        for m in range(5):
            x_out[i, m], w_out[i, m] = fbuf[0, m], wbuf[0, m]
        conv[i], evals[i], iters[i] = done, n_eval, it
