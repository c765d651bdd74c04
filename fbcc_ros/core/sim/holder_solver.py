"""The quasi-static equilibrium of a compliant holder in series with the contact
(:mod:`fbcc_ros.core.sim.holder` models the holder, its grip point and typical stiffness).

**Solver.** The contact is ~1e7-1e9 N/m stiff (or more) against a holder of 1e4-1e7 N/m, so a
fixed-point iteration ``u <- -F(u)/k`` diverges. :class:`HolderSolver` runs a damped Newton
iteration per row on the four coordinates (u_x, u_y, phi_x, phi_y), and the axial u_l where the
pair has the rim, in units scaled by the tolerances (so that the holder's spring is the identity
and "converged" means ``|residual| <= 1`` in every coordinate):

* the Jacobian comes from forward differences (4 extra evaluations of the row), is kept between
  steps and refined by Broyden updates, and is recomputed only where a step fails to cut the
  squared residual by 4;
* a step is accepted only if it decreases the squared residual (Armijo); a step of a fresh
  Jacobian that does not is halved, down to 1e-10 (past a stiff wall the right fraction can be
  1e-4), where the row gives up this call;
* each step starts from the last solution extrapolated linearly in time (``2 q_k - q_{k-1}``),
  or from a given ``delta0``;
* a start that touches nothing with the holder deflected is no equilibrium, and there the
  Jacobian is the holder's alone, which knows nothing of the wall: such a start falls back on
  the last solution, then on no deflection (the solution if that touches nothing), or, where no
  deflection is in contact, on the contact's onset between the two (the peg let go moves toward
  the hand until it meets the solid: a peg that slid off a face it was pressed on by 0.1 mm
  started deep in the hole's block, where the micron steps below never got out of kN);
* so is a trial point of the iteration that touches nothing with the holder deflected (a
  Newton step from deep in a stiff wall can land there with a smaller residual, a peg tilted
  by degrees in its grasp with no force on it): it is replaced by no deflection, the exact
  solution if that touches nothing, and refused otherwise (the step is halved toward the wall);
* where the pair has the rim, the peg turned about its grip keeps its tip centre's depth (its
  features' l, the end face's lowest point, follows the tilt); each Newton step is bounded
  (:data:`~.holder_kernel.TRUST`: a face contact's equilibria, on the face or tipped into the
  hole, lie microns apart, and a longer step lands on another); and the friction of the face
  and the wall (:mod:`~fbcc_ros.core.contact.sliding`) is the regularised Coulomb law on each
  element's motion since the last period, implicit in the pose solved for: an element moving
  slower than :data:`~fbcc_ros.core.contact.sliding.SLIDE_EPS` sticks with the law's slope;
* rows that do not converge within ``max_iter`` iterations keep their best point and are
  flagged in ``converged``; nothing raises inside the iteration. At the edge of a stiff contact
  against a soft grasp that happens often, and the best point can be off balance by newtons
  (``test_no_step_leaves_the_peg_deflected_against_nothing``'s setting run over 16 pairs of
  1500 steps, measured outside the tests: 77 % of the steps unconverged, the lateral force of
  an unconverged one p99 3.5 N, at most 42 N; the simulator uses them as they are).

For a :class:`ContactBatch` (or its bound ``response``) the iteration is compiled (numba,
:mod:`fbcc_ros.core.sim.holder_kernel`) and calls the contact kernel one row at a time, so each row
costs only the evaluations it needs; any other response callable runs the same iteration
batched in numpy (all N rows per call, :mod:`fbcc_ros.core.sim.holder_batched`).

A cold start deep in the wall (kN of rigid force) against a soft grasp can stall at the edge of
a stiff edge contact, where the equilibrium lies within a nanometre of the contact's onset and
the contact force grows faster than linearly: :func:`solve` then continues the failed rows from a
1000 times stiffer holder down to the real one. In a closed loop the warm start keeps each step
small; rows that still fail are flagged, and the next step starts from their best point.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact import kernel as contact_kernel
from fbcc_ros.core.contact import sliding
from fbcc_ros.core.contact.model import ContactBatch, as_rows
from fbcc_ros.core.contact.rim import RAYS_PER_WALL_RAY
from fbcc_ros.core.contact.sliding import SLIDE
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.sim import holder_batched, holder_kernel
from fbcc_ros.core.sim.holder import (
    BoolArray,
    Equilibrium,
    Grip,
    Holder,
    Response,
    per_row,
)


def _contact_of(response: Response | ContactBatch) -> ContactBatch | None:
    """The ContactBatch behind a response (the batch itself or its bound ``response``)."""
    if isinstance(response, ContactBatch):
        return response
    owner = getattr(response, "__self__", None)
    if isinstance(owner, ContactBatch) and getattr(response, "__func__", None) is (
        ContactBatch.response
    ):
        return owner
    return None


def _check_options(max_iter: int, force_tol: float, moment_tol: float) -> None:
    if isinstance(max_iter, bool) or not isinstance(max_iter, int) or max_iter < 1:
        raise ConfigError("holder.max_iter", max_iter, "an integer >= 1")
    for field, v in (("holder.force_tol", force_tol), ("holder.moment_tol", moment_tol)):
        ok = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)
        if not (ok and v > 0):
            raise ConfigError(field, v, "a finite tolerance > 0 (N or N·m)")


class HolderSolver:
    """The quasi-static equilibrium of a holder in series with the contact, warm started.

    Keeps each row's deflection and Jacobian between calls of :meth:`step` and starts each step
    from the last two solutions extrapolated linearly; a change in the number of rows starts
    afresh (so does :meth:`reset`).

    Args:
        holder: The holder; ``None`` or :meth:`Holder.rigid` is rigid (delta = 0, one call);
            or one holder per row (a Monte Carlo's drawn grips), all compliant.
        grip: Where the response's moments are taken, for a response callable that is no
            ContactBatch (a ContactBatch or its bound ``response`` always uses
            :meth:`Grip.of` itself).
        max_iter: Newton iterations per step and row (each costs one evaluation of the row,
            plus four where its Jacobian is refreshed).
        force_tol: Force balance ``|k_l u + F|`` that counts as converged [N].
        moment_tol: Moment balance ``|k_a phi + M_G|`` that counts as converged [N·m].
        extrapolate: Start from ``2 q_k - q_{k-1}`` (else from the last solution ``q_k``).

    After each step, :attr:`evaluations` is the number of contact evaluations of single rows
    it took (N for a rigid holder; the numpy iteration of a plain callable evaluates all N rows
    per call) and :attr:`iterations` the most Newton iterations of a row.
    """

    def __init__(
        self,
        holder: Holder | Sequence[Holder] | None,
        grip: Grip | None = None,
        *,
        max_iter: int = 12,
        force_tol: float = 1e-3,
        moment_tol: float = 1e-5,
        extrapolate: bool = True,
    ) -> None:
        if holder is None or isinstance(holder, Holder):
            holders = [holder or Holder.rigid()]
        else:
            holders = list(holder) if isinstance(holder, (list, tuple)) else []
            if not holders or not all(isinstance(k, Holder) and not k.is_rigid
                                      for k in holders):  # fmt: skip
                raise ConfigError("holder", holder, "a Holder, None (rigid), or compliant "
                                  "Holders, one per row")  # fmt: skip
        _check_options(max_iter, force_tol, moment_tol)
        #: the holder (the first of per-row ones: all compliant)
        self.holder = holders[0]
        self.grip = grip
        self.max_iter = max_iter
        self.extrapolate = extrapolate
        self._tol = np.array([force_tol, force_tol, moment_tol, moment_tol, force_tol])
        # (1 or N, 5): each row's spring constants
        self._k = np.array([[k.lateral, k.lateral, k.angular, k.angular, k.axial]
                            for k in holders])
        # (N, 5) u_x, u_y, phi_x, phi_y, u_l of the last step (u_l only where the rim is)
        self._q: FloatArray | None = None
        self._q_prev: FloatArray | None = None  # and of the step before
        self._jac: FloatArray | None = None  # (N, 5, 5) in scaled units
        self._have: BoolArray | None = None  # whether a row's Jacobian is usable
        self.evaluations = 0
        self.iterations = 0

    def reset(self) -> None:
        """Forget the warm start (deflections and Jacobians)."""
        self._q = self._q_prev = self._jac = self._have = None

    def step(
        self,
        x_robot: ArrayLike,
        response: Response | ContactBatch,
        *,
        delta0: ArrayLike | None = None,
        last: FloatArray | None = None,
        dt: float = 0.0,
    ) -> Equilibrium:
        """Solve one equilibrium.

        Args:
            x_robot: The peg's features if the holder were rigid (the robot's belief plus the
                hole's deviation), (N, 5) or (5,) [m, rad]. Depths must suit ``response``
                (the simulator clamps them at 0).
            response: The contact: a ContactBatch, its ``response``, or any callable
                ``features (N, 5) -> wrench (N, 5)`` (then ``grip`` must be given).
            delta0: An initial feature delta (N, 5) to start from instead of the warm start.
            last: The pegs' true features a period ``dt`` [s] ago (N, 5), for the rim's friction
                against the peg's own sliding (None: at rest; :mod:`fbcc_ros.core.contact.rim`).

        Returns:
            :class:`Equilibrium` (features, wrench, delta, converged), rows as given.
        """
        xr, single = as_rows(x_robot, "x_robot", "features (dx, dy, l, theta_x, theta_y)")
        n = len(xr)
        contact = _contact_of(response)
        if contact is not None and len(contact) not in (1, n):
            raise InputError("x_robot", f"{n} rows", f"{len(contact)} rows, one per pair")
        if len(self._k) not in (1, n):
            raise InputError("x_robot", f"{n} rows", f"{len(self._k)} rows, one per holder")
        if self.holder.is_rigid:
            if contact is not None:
                radii = np.broadcast_to(contact.table[1], (n,))
                w = contact.response(xr, _velocity(xr, last, dt, radii))
            else:
                w = holder_batched.call(response, xr)  # type: ignore[arg-type]
            self.evaluations, self.iterations = n, 0
            out = Equilibrium(xr.copy(), w, np.zeros_like(xr), np.ones(n, dtype=bool))
            return _squeeze(out) if single else out
        grip = Grip.of(contact) if contact is not None else self.grip
        if grip is None:
            raise ConfigError("grip", None, "a Grip for a response that is no ContactBatch")
        pl = per_row(grip.peg_length, n, "grip.peg_length")
        h = pl - 0.5 * xr[:, 2]  # from the feature point up to the grip point, along the axis
        q = self._start(n, h, delta0)
        # the fallback start where q lands off the wall: the last solution (then q = 0)
        back = self._q.copy() if self._q is not None else np.zeros((n, 5))
        if contact is not None:
            x, w, conv, evals, iters = self._compiled(xr, h, q, back, contact, last, dt)
        else:
            x, w, conv, evals, iters = self._batched(xr, h, q, back, response, grip)  # type: ignore[arg-type]
        self._q_prev, self._q = self._q, q
        self.evaluations, self.iterations = evals, iters
        out = Equilibrium(x, w, x - xr, conv)
        return _squeeze(out) if single else out

    def _start(self, n: int, h: FloatArray, delta0: ArrayLike | None) -> FloatArray:
        """The starting deflection: delta0, else the warm start, else none."""
        if self._q is None or len(self._q) != n:
            self.reset()
            self._jac = np.tile(np.eye(5), (n, 1, 1))
            self._have = np.zeros(n, dtype=bool)
            q0 = np.zeros((n, 5))
        elif self.extrapolate and self._q_prev is not None:
            q0 = 2.0 * self._q - self._q_prev
        else:
            q0 = self._q.copy()
        if delta0 is not None:
            d, _ = as_rows(delta0, "delta0", "feature deltas")
            if len(d) != n:
                raise InputError("delta0", f"{len(d)} rows", f"{n} rows, as x_robot")
            q0 = np.column_stack([d[:, 0] + h * d[:, 4], d[:, 1] - h * d[:, 3], d[:, 3:5],
                                  d[:, 2]])  # fmt: skip
        return q0

    def _compiled(
        self, xr: FloatArray, h: FloatArray, q: FloatArray, back: FloatArray,
        contact: ContactBatch, last: FloatArray | None, dt: float,
    ) -> tuple[FloatArray, FloatArray, BoolArray, int, int]:  # fmt: skip
        """The compiled iteration. Where the pair has the rim and the peg moved, the friction
        of its faces and its wall is on each element's motion since ``last``, implicit in the
        pose solved for (:mod:`~fbcc_ros.core.contact.sliding`)."""
        moving = last is not None and dt > 0.0
        before = np.ascontiguousarray(last if moving else xr, dtype=float)
        return self._solve_rows(np.arange(len(xr)), xr, h, q, back, contact, before,
                                1.0 / dt if moving else 0.0)

    def _solve_rows(
        self, rows: np.ndarray, xr: FloatArray, h: FloatArray, q: FloatArray,
        back: FloatArray, contact: ContactBatch, last: FloatArray, inv_dt: float,
    ) -> tuple[FloatArray, FloatArray, BoolArray, int, int]:  # fmt: skip
        """:func:`~.holder_kernel.solve_rows` on ``rows`` of the step (their deflections,
        Jacobians and validity updated in place)."""
        assert self._jac is not None and self._have is not None
        m = len(rows)
        whole = m == len(xr)
        table = contact.table if len(contact) == 1 or whole else contact.table[:, rows]
        k = self._k if len(self._k) == 1 or whole else self._k[rows]
        qs, jac, have = (q, self._jac, self._have) if whole else (
            q[rows], self._jac[rows], self._have[rows])  # fmt: skip
        x, w = np.empty((m, 5)), np.empty((m, 5))
        conv = np.empty(m, dtype=np.bool_)
        evals, iters = np.empty(m, dtype=np.int64), np.empty(m, dtype=np.int64)
        ca, sa = contact_kernel.angle_table(contact.n_angles)
        rim_ca, rim_sa = contact_kernel.angle_table(RAYS_PER_WALL_RAY * contact.n_angles)
        holder_kernel.solve_rows(
            np.ascontiguousarray(xr[rows]), h[rows], qs, np.ascontiguousarray(back[rows]), jac,
            have, np.ascontiguousarray(table), contact.peg_top, ca, sa, rim_ca, rim_sa,
            np.ascontiguousarray(last[rows]), inv_dt,
            np.ascontiguousarray(k), self._tol, self.max_iter, holder_kernel.FD_STEP, x, w,
            conv, evals, iters,
        )  # fmt: skip
        if not whole:
            q[rows], self._jac[rows], self._have[rows] = qs, jac, have
        return x, w, conv, int(evals.sum()), int(iters.max(initial=0))

    def _batched(
        self,
        xr: FloatArray,
        h: FloatArray,
        q: FloatArray,
        back: FloatArray,
        response: Response,
        grip: Grip,
    ) -> tuple[FloatArray, FloatArray, BoolArray, int, int]:
        assert self._jac is not None and self._have is not None
        # a plain callable has no rim: the four lateral and angular coordinates
        lat = slice(0, holder_kernel.N_LATERAL)
        return holder_batched.solve_rows(xr, h, q[:, lat], back[:, lat],
                                         self._jac[:, lat, lat], self._have, response, grip,
                                         self._k[:, lat], self._tol[lat],
                                         self.max_iter)  # fmt: skip


def _velocity(x: FloatArray, last: FloatArray | None, dt: float,
              peg_radius: FloatArray) -> FloatArray | None:  # fmt: skip
    """The velocities (N, :data:`~fbcc_ros.core.contact.sliding.SLIDE`) of pegs of radii
    ``peg_radius`` (N or 1) at features ``x`` that were at ``last`` a period ``dt`` ago; None
    without a last."""
    if last is None or dt <= 0.0:
        return None
    v = np.empty((len(x), SLIDE))
    sliding.peg_velocity(np.ascontiguousarray(x), np.ascontiguousarray(last, dtype=float),
                         np.ascontiguousarray(peg_radius, dtype=float), 1.0 / dt, v)  # fmt: skip
    return v


def _squeeze(e: Equilibrium) -> Equilibrium:
    return Equilibrium(e.features[0], e.wrench[0], e.delta[0], e.converged.reshape(()))


#: The stiffest stage of :func:`solve`'s continuation, as a multiple of the holder's stiffness.
CONTINUATION_SPAN = 1e3


def solve(
    holder: Holder | None,
    x_robot: ArrayLike,
    response: Response | ContactBatch,
    grip: Grip | None = None,
    *,
    delta0: ArrayLike | None = None,
    max_iter: int = 20,
    force_tol: float = 1e-3,
    moment_tol: float = 1e-5,
    continuation: int = 8,
) -> Equilibrium:
    """One equilibrium from ``delta0`` (default: the rigid pose), for a cold start.

    Rows that this leaves unconverged are solved again by continuation: ``continuation + 1``
    stages of a holder softened geometrically from :data:`CONTINUATION_SPAN` times stiffer
    (close to the rigid pose, where the contact's Jacobian is well sampled) down to the holder
    itself, each started from the last stage's solution (0: no second attempt). A cold start
    deep in the wall against a soft grasp (a stiff edge contact, whose equilibrium lies within
    a fraction of a nanometre of the contact's edge) can otherwise stall there. Other arguments
    as :class:`HolderSolver`; in a loop keep a :class:`HolderSolver` instead.
    """
    if isinstance(continuation, bool) or not isinstance(continuation, int) or continuation < 0:
        raise ConfigError("holder.continuation", continuation, "an integer >= 0")
    options = {"max_iter": max_iter, "force_tol": force_tol, "moment_tol": moment_tol}
    eq = HolderSolver(holder, grip, **options).step(x_robot, response, delta0=delta0)  # type: ignore[arg-type]
    if continuation == 0 or holder is None or bool(np.all(eq.converged)):
        return eq
    xr, single = as_rows(x_robot, "x_robot", "features (dx, dy, l, theta_x, theta_y)")
    bad = np.flatnonzero(~np.atleast_1d(eq.converged))
    contact = _contact_of(response)
    if contact is not None:  # only the rows that failed
        rows, path_response = bad, contact
        if len(contact) > 1:
            table = np.ascontiguousarray(contact.table[:, bad])
            path_response = ContactBatch(table, contact.peg_top, contact.n_angles)
    else:  # a plain callable takes every row
        rows, path_response = np.arange(len(xr)), response  # type: ignore[assignment]
    stage_delta = None
    for j in range(continuation + 1):
        a = CONTINUATION_SPAN ** ((continuation - j) / continuation)
        stage = holder.scaled(a)
        last = HolderSolver(stage, grip, **options).step(  # type: ignore[arg-type]
            xr[rows], path_response, delta0=stage_delta
        )
        stage_delta = last.delta
    pick = np.isin(rows, bad)  # the path's rows that replace a failed one
    merged = []
    for a_eq, b in zip(eq, last, strict=True):
        c = np.array(a_eq, ndmin=2 if a_eq.dtype != np.bool_ else 1)
        c[rows[pick]] = b[pick]
        merged.append(c)
    result = Equilibrium(merged[0], merged[1], merged[2], merged[3])
    return _squeeze(result) if single else result
