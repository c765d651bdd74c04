"""Inverse kinematics of the peg frame: a damped-least-squares closed-loop IK (CLIK), warm-started
from the current joints, that keeps every iterate inside the joint position limits and, for one
control period ``dt``, inside the velocity limits. It never returns a pose it did not reach:
when the target is out of reach or needs a joint beyond a limit it raises :class:`IkError`.
"""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import FbccError, InputError
from fbcc_ros.core.kinematics.robot import RobotModel


class IkError(FbccError):
    """The IK did not reach its target within the limits. Nothing is commanded.

    Attributes:
        reason: What stopped it, in words (the joints held at a limit, or out of reach).
        position_error: Remaining distance of the peg frame from its target [m].
        rotation_error: Remaining rotation angle [rad].
        iterations: Iterations spent.
    """

    def __init__(
        self, reason: str, position_error: float, rotation_error: float, iterations: int
    ) -> None:
        self.reason = reason
        self.position_error = position_error
        self.rotation_error = rotation_error
        self.iterations = iterations
        super().__init__(
            f"IK failed after {iterations} iterations, {position_error:.3g} m and "
            f"{rotation_error:.3g} rad from the target: {reason}"
        )


@dataclasses.dataclass(frozen=True)
class IkSettings:
    """Damped-least-squares CLIK settings.

    Attributes:
        tolerance: Convergence on both the position error [m] and the rotation error [rad];
            10 nm and 10 nrad, a hundred times inside the round-trip target of 1e-6.
        max_iterations: Iterations before giving up; a warm-started 1 ms step needs 1-3.
        damping: lambda of the DLS step [m or rad]; tiny against the arm's singular values, so
            it only matters near singularities, where it bounds the joint step.
        max_step: Largest joint step per iteration [rad], so cold solves do not overshoot.
    """

    tolerance: float = 1e-8
    max_iterations: int = 200
    damping: float = 1e-4
    max_step: float = 0.2


@dataclasses.dataclass(frozen=True)
class IkSolution:
    """A solved configuration and how it was reached."""

    q: FloatArray
    iterations: int
    position_error: float
    rotation_error: float


def solve_ik(
    robot: RobotModel,
    peg_in_base: pin.SE3,
    q_start: ArrayLike,
    dt: float | None = None,
    settings: IkSettings = IkSettings(),
) -> IkSolution:
    """Joints that put the peg frame at ``peg_in_base``, by damped least squares from ``q_start``.

    Each iterate stays within the position limits and, when ``dt`` is given, within
    ``|q - q_start| <= v_max dt`` (one control period at the joint velocity limits). A target that
    needs more than that raises :class:`IkError` naming the joints held at their bounds.

    .. math::
        e = \\log_6(T_{base,P}(q)^{-1} T^*_{base,P}), \\quad
        J_e = -J_{\\log_6} J_{P}^{local}, \\quad
        \\Delta q = -J_e^T (J_e J_e^T + \\lambda^2 I)^{-1} e
    """
    return clik(robot, peg_in_base, checked_start(robot, q_start, dt), dt, settings)


def checked_start(robot: RobotModel, q_start: ArrayLike, dt: float | None, field: str = "q_start"
                   ) -> FloatArray:  # fmt: skip
    """The IK's start as a float array: finite, within the position limits; and ``dt`` > 0."""
    q0 = robot.check_joints(q_start, field)
    if not robot.within_limits(q0):
        limits = zip(robot.joint_names, q0, robot.lower, robot.upper, strict=True)
        outside = [name for name, v, lo, hi in limits if not lo <= v <= hi]
        raise InputError(field, q0.tolist(), f"joints within their position limits {outside}")
    if dt is not None and not (dt > 0.0 and math.isfinite(dt)):
        raise InputError("dt", dt, "a control period > 0 [s]")
    return q0


def clik(
    robot: RobotModel, peg_in_base: pin.SE3, q0: FloatArray, dt: float | None, settings: IkSettings
) -> IkSolution:
    """The CLIK loop of :func:`solve_ik` on checked inputs."""
    model, data, fid = robot.model, robot.data, robot.peg_id
    lower, upper = robot.lower, robot.upper
    if dt is not None:
        reach = robot.velocity_limit * dt
        lower, upper = np.maximum(lower, q0 - reach), np.minimum(upper, q0 + reach)
    damping2, tol2 = settings.damping**2, settings.tolerance**2
    free = np.zeros(q0.size, dtype=np.bool_)
    q = q0.copy()
    for iteration in range(settings.max_iterations + 1):
        pin.forwardKinematics(model, data, q)
        target_in_peg = pin.updateFramePlacement(model, data, fid).actInv(peg_in_base)
        # Error twist in the peg frame, e = log6(T(q)^-1 T*).
        err = pin.log6(target_in_peg).vector
        e0, e1, e2, e3, e4, e5 = err.tolist()
        pos2, rot2 = e0 * e0 + e1 * e1 + e2 * e2, e3 * e3 + e4 * e4 + e5 * e5
        if pos2 <= tol2 and rot2 <= tol2:
            return IkSolution(q, iteration, math.sqrt(pos2), math.sqrt(rot2))
        if iteration == settings.max_iterations:
            break
        # d e / d q = -Jlog6(T*^-1 T) J_local (Pinocchio's CLIK example); the joint Jacobians
        # reuse the placements of forwardKinematics above.
        pin.computeJointJacobians(model, data)
        jac = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
        jlog = pin.Jlog6(target_in_peg.inverse())
        args = (q, jlog, jac, err, lower, upper)
        step, q_next, clipped = _dls_update(*args, free, damping2, settings.max_step)
        if clipped:
            # Active set: joints pinned at a bound that the step pushes further are taken out
            # of the Jacobian, so the others (a redundant arm's null space) carry the correction.
            blocked = ((q <= lower) & (step < 0.0)) | ((q >= upper) & (step > 0.0))
            if blocked.any():
                step, q_next, _ = _dls_update(*args, blocked, damping2, settings.max_step)
            if float(np.abs(q_next - q).max()) < _STALLED:
                break  # every useful direction is blocked by a bound: fail now, not in 200 steps
        q = q_next
    pos_err, rot_err = math.sqrt(pos2), math.sqrt(rot2)
    raise IkError(_why(robot, q, lower, upper, q0, dt), pos_err, rot_err, iteration)


@numba.njit(cache=True)  # type: ignore[misc]
def _dls_update(
    q: FloatArray,
    jlog: FloatArray,
    jac: FloatArray,
    err: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    blocked: NDArray[np.bool_],
    damping2: float,
    max_step: float,
) -> tuple[FloatArray, FloatArray, bool]:
    """One damped-least-squares step, compiled (numpy's per-call overhead was ~8 µs of it):

    .. math::
        J_e = -J_{\\log_6} J, \\quad
        \\Delta q = -J_e^T (J_e J_e^T + \\lambda^2 I)^{-1} e

    with the ``blocked`` joints' columns of ``J_e`` zeroed, ``Delta q`` scaled to at most
    ``max_step`` per joint. Returns ``(Delta q, clip(q + Delta q, lower, upper), clipped)``.
    """
    n = q.size
    jac_e = np.zeros((6, n))
    for i in range(6):
        for j in range(n):
            if not blocked[j]:
                acc = 0.0
                for k in range(6):
                    acc += jlog[i, k] * jac[k, j]
                jac_e[i, j] = -acc
    # A = J_e J_e^T + lambda^2 I is symmetric positive definite: Cholesky, A = L L^T
    chol = np.zeros((6, 6))
    for i in range(6):
        for j in range(i + 1):
            acc = 0.0
            for k in range(n):
                acc += jac_e[i, k] * jac_e[j, k]
            if i == j:
                acc += damping2
            for k in range(j):
                acc -= chol[i, k] * chol[j, k]
            chol[i, j] = math.sqrt(acc) if i == j else acc / chol[j, j]
    # A w = e: L y = e forward, then L^T w = y backward
    w = np.empty(6)
    for i in range(6):
        acc = err[i]
        for k in range(i):
            acc -= chol[i, k] * w[k]
        w[i] = acc / chol[i, i]
    for i in range(5, -1, -1):
        acc = w[i]
        for k in range(i + 1, 6):
            acc -= chol[k, i] * w[k]
        w[i] = acc / chol[i, i]
    step = np.empty(n)
    largest = 0.0
    for j in range(n):
        acc = 0.0
        for i in range(6):
            acc -= jac_e[i, j] * w[i]
        step[j] = acc
        largest = max(largest, abs(acc))
    if largest > max_step:
        step *= max_step / largest
    q_next = np.empty(n)
    clipped = False
    for j in range(n):
        unclipped = q[j] + step[j]
        q_next[j] = min(max(unclipped, lower[j]), upper[j])
        clipped = clipped or q_next[j] != unclipped
    return step, q_next, clipped


def preload_ik(n: int) -> None:
    """Loads the compiled step now (from numba's cache, or compiled on a machine's first run),
    not inside the first control period. A zero error: nothing to solve."""
    zeros, eye = np.zeros(n), np.eye(6)
    _dls_update(zeros, eye, np.zeros((6, n)), np.zeros(6), zeros - 1.0, zeros + 1.0,
                np.zeros(n, dtype=np.bool_), 1e-8, 0.2)  # fmt: skip


#: A clipped step smaller than this [rad] means the solver is pinned against its bounds.
_STALLED = 1e-12


def _why(
    robot: RobotModel,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    q0: FloatArray,
    dt: float | None,
) -> str:
    """Which bounds held the solver, in words."""
    held = []
    for i, name in enumerate(robot.joint_names):
        for bound, limit, side in (
            (lower[i], robot.lower[i], "lower"),
            (upper[i], robot.upper[i], "upper"),
        ):
            if abs(q[i] - bound) > 1e-9:
                continue
            if bound == limit:
                held.append(f"{name} at its {side} position limit {bound:.4g} rad")
            else:  # the one-period box around the start, narrower than the position limits
                held.append(
                    f"{name} at its velocity limit ({robot.velocity_limit[i]:.4g} rad/s: "
                    f"{abs(bound - q0[i]):.3g} rad in dt={dt} s)"
                )
    if held:
        return "held by " + "; ".join(held)
    return "no joint is at a bound: the target is out of reach or at a singularity"
