"""The holder solver's damped Newton iteration batched in numpy, for any response callable
(analytic springs in the tests, a contact model other than :class:`ContactBatch`).

The same iteration as the compiled :func:`fbcc_ros.core.sim.holder_kernel.solve_rows` (which
serves a ContactBatch row by row): :class:`fbcc_ros.core.sim.holder_solver.HolderSolver`'s doc
states it; a test checks that both give the same equilibria.
"""

from __future__ import annotations

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import InputError
from fbcc_ros.core.sim import holder_kernel
from fbcc_ros.core.sim.holder import BoolArray, Grip, Response, grip_moments


def solve_rows(
    xr: FloatArray,
    h: FloatArray,
    q: FloatArray,
    back: FloatArray,
    jac: FloatArray,
    have: BoolArray,
    response: Response,
    grip: Grip,
    k: FloatArray,
    tol: FloatArray,
    max_iter: int,
) -> tuple[FloatArray, FloatArray, BoolArray, int, int]:
    """Every row's equilibrium from the deflection ``q`` (N, 4), updated in place with the
    Jacobians ``jac`` and their validity ``have``; returns features, wrench, converged, the
    rows evaluated and the most iterations of a row. Arguments as ``solve_rows`` of
    :mod:`fbcc_ros.core.sim.holder_kernel`."""
    n = len(xr)
    # physical units per scaled unit, per row (k: one holder's (4,), or each row's (1 or N, 4))
    scale = np.broadcast_to(tol / k, (n, 4))

    def features(qq: FloatArray) -> FloatArray:
        x = xr.copy()
        x[:, 0] += qq[:, 0] - h * qq[:, 3]
        x[:, 1] += qq[:, 1] + h * qq[:, 2]
        x[:, 2:] += np.column_stack([np.zeros(n), qq[:, 2:]])
        return x

    def residual(qq: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        x = features(qq)
        w = call(response, x)
        mgx, mgy = grip_moments(x, w, grip)
        load = np.column_stack([w[:, 0], w[:, 1], mgx, mgy])
        return x, w, (k * qq + load) / tol

    x, w, r = residual(q)
    evals = n
    for fallback in (back, np.zeros((n, 4))):  # off the wall: fall back
        off = _off_wall(q, w)
        if not off.any():
            break
        q[off] = fallback[off]
        x2, w2, r2 = residual(q)
        evals += n
        x[off], w[off], r[off] = x2[off], w2[off], r2[off]
    merit = np.einsum("ij,ij->i", r, r)
    conv = np.abs(r).max(axis=1) <= 1.0
    t = np.ones(n)
    fresh = np.zeros(n, dtype=bool)  # the Jacobian was evaluated at the current point
    gave_up = np.zeros(n, dtype=bool)
    iters = np.zeros(n, dtype=np.int64)
    for _ in range(max_iter):
        act = ~conv & ~gave_up
        if not act.any():
            break
        iters[act] += 1
        need = act & ~have
        if need.any():
            for j in range(4):
                qj = q.copy()
                qj[:, j] += holder_kernel.FD_STEP[j]
                rj = residual(qj)[2]
                step_j = holder_kernel.FD_STEP[j] / scale[need, j]  # in scaled units
                jac[need, :, j] = (rj[need] - r[need]) / step_j[:, None]
            evals += 4 * n
            have[need] = fresh[need] = True
        step = np.zeros((n, 4))
        step[act] = _solve4_rows(jac[act], -r[act])
        qt = q + t[:, None] * step * scale
        xt, wt, rt = residual(qt)
        evals += n
        off = act & _off_wall(qt, wt)  # no equilibrium there: no deflection, or back
        if off.any():
            qt[off] = 0.0
            x0, w0, r0 = residual(qt)
            evals += n
            xt[off], wt[off], rt[off] = x0[off], w0[off], r0[off]
        mt = np.einsum("ij,ij->i", rt, rt)
        mt[off & (np.abs(wt) > 0.0).any(axis=1)] = np.inf
        acc = act & (mt < (1.0 - holder_kernel.ARMIJO * t) * merit)  # False for NaN
        rej = act & ~acc
        if acc.any():
            dz = (qt[acc] - q[acc]) / scale[acc]
            jac[acc] = _broyden(jac[acc], dz, rt[acc] - r[acc])
            have[acc & (mt > holder_kernel.SLOW * merit)] = False  # slow: refresh next time
            q[acc], x[acc], w[acc] = qt[acc], xt[acc], wt[acc]
            r[acc], merit[acc] = rt[acc], mt[acc]
            t[acc] = 1.0
            fresh[acc] = False
        # a fresh Jacobian's step failed: halve it; a stale one: refresh the Jacobian
        damp = rej & fresh
        t[damp] *= 0.5
        gave_up |= damp & (t < holder_kernel.T_MIN)
        have[rej & ~fresh] = False
        conv = np.abs(r).max(axis=1) <= 1.0
    return x, w, conv, evals, int(iters.max(initial=0))


def _off_wall(q: FloatArray, w: FloatArray) -> BoolArray:
    """Rows that touch nothing (an exactly zero wrench) with the holder deflected: never an
    equilibrium, and a region where the Jacobian (the holder alone) knows nothing of the wall."""
    return np.asarray((w == 0.0).all(axis=1) & (q != 0.0).any(axis=1))


def call(response: Response, x: FloatArray) -> FloatArray:
    w = np.asarray(response(x), dtype=float)
    if w.shape != x.shape:
        raise InputError("response", f"an array of shape {w.shape}", f"shape {x.shape}")
    return w


def _solve4_rows(jac: FloatArray, b: FloatArray) -> FloatArray:
    """Solve each row's 4×4 system; a singular or non-finite row takes the step ``b`` (the
    Newton step of the holder alone: J = I in scaled units)."""
    s = np.empty_like(b)
    for i in range(len(b)):
        try:
            s[i] = np.linalg.solve(jac[i], b[i])
        except np.linalg.LinAlgError:
            s[i] = b[i]
    bad = ~np.isfinite(s).all(axis=1)
    s[bad] = b[bad]
    return s


def _broyden(jac: FloatArray, dz: FloatArray, dr: FloatArray) -> FloatArray:
    """Broyden's ("good") rank-one update per row: J += (dr - J dz) dz^T / (dz^T dz)."""
    den = np.einsum("ij,ij->i", dz, dz)
    resid = dr - np.einsum("ijk,ik->ij", jac, dz)
    upd = resid[:, :, None] * dz[:, None, :] / np.where(den > 0, den, np.inf)[:, None, None]
    out = jac + upd
    bad = ~np.isfinite(out).all(axis=(1, 2))
    out[bad] = jac[bad]
    return np.asarray(out, dtype=float)
