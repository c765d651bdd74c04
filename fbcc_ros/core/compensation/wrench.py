"""Wrenches between frames, the response vector on the wire, and the virtual sensor.

A wrench here is ``(fx, fy, fz, tx, ty, tz)``: a force and the moment about a stated point, both
in a stated frame's axes, right-handed (DESIGN §3).

The controller's response vector ``(Fx, Fy, Fz, Mx, My)`` differs from the wire wrench in one
component only: ``Fz`` is eq. (11)'s axial friction resultant, positive while the peg is pushed in,
whereas the force on the hole then points along -z of {H}. So ``Fz = -fz``; this module is the one
place that maps between the two.
"""

from __future__ import annotations

import functools

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import ConfigError, InputError


def transfer(
    wrench: ArrayLike, source_in_target: pin.SE3, point: ArrayLike = (0, 0, 0)
) -> FloatArray:
    """A wrench given in {source} axes about the source origin, in {target} axes about ``point``.

    Args:
        wrench: (6,) in {source}, moment about the origin of {source}.
        source_in_target: ``T_target_source``.
        point: The new moment point, in {target} coordinates [m].
    """
    return transfer_matrix(source_in_target, point) @ np.asarray(wrench, dtype=float)


def transfer_matrix(source_in_target: pin.SE3, point: ArrayLike = (0, 0, 0)) -> FloatArray:
    """The (6, 6) matrix of :func:`transfer`, for a transform used again and again (a sensor
    that does not move):

    .. math::
        f_T = R f_S, \\quad \\tau_A = R \\tau_S + (p_S - p_A) \\times f_T, \\quad
        X = \\begin{pmatrix} R & 0 \\\\ [p_S - p_A]_\\times R & R \\end{pmatrix}

    with ``R, p_S`` the rotation and origin of ``T_target_source``: Pinocchio's dual action
    matrix of the source frame seen from a frame at ``point`` with the target's axes.
    """
    at_point = pin.SE3(np.eye(3), -np.asarray(point, dtype=float)) * source_in_target
    return at_point.toDualActionMatrix()


def response_from_wrench(wrench: ArrayLike, acting_point: ArrayLike | None = None) -> FloatArray:
    """``(Fx, Fy, Fz, Mx, My)`` from a wire wrench in {H}: ``Fz = -fz`` (eq. 11), mz dropped.

    With ``acting_point`` (in {H} [m]), the wire wrench's moments are about the {H} origin (the
    ROS convention for a wrench in frame ``hole``) and are moved to that point:
    ``tau_A = tau_O - p_A x f``."""
    w = np.asarray(wrench, dtype=float)
    if acting_point is not None:
        w = _to_point(tuple(np.asarray(acting_point, dtype=float).tolist())) @ w
    return np.array([w[0], w[1], -w[2], w[3], w[4]])


@functools.lru_cache(maxsize=8)
def _to_point(point: tuple[float, ...]) -> FloatArray:
    """:func:`transfer_matrix` from {H}'s origin to ``point``, computed once per point (the
    controller moves every sample's moments to its one acting point)."""
    return transfer_matrix(pin.SE3.Identity(), point)


def wrench_from_response(
    response: ArrayLike, mz: float = 0.0, acting_point: ArrayLike | None = None
) -> FloatArray:
    """The wire wrench in {H} for a response vector: ``fz = -Fz``; the model has no ``mz``.
    With ``acting_point`` (where the response's moments are), the wrench's moments are about the
    {H} origin: ``tau_O = tau_A + p_A x f`` (the inverse of :func:`response_from_wrench`)."""
    r = np.asarray(response, dtype=float)
    wrench = np.array([r[0], r[1], -r[2], r[3], r[4], mz])
    if acting_point is None:
        return wrench
    return transfer(wrench, pin.SE3(np.eye(3), np.asarray(acting_point, dtype=float)))


def virtual_wrench(jacobian: ArrayLike, external_torques: ArrayLike, damping: float) -> FloatArray:
    """The wrench at a frame from the external joint torques: a virtual force/torque sensor.

    With ``tau_ext = J^T w`` (``w`` the wrench the environment exerts on the arm at the frame,
    ``J`` the frame's (6, n) Jacobian), the damped least-squares solution is

    .. math::
        w = (J J^T + \\lambda^2 E)^{-1} J \\tau_{ext}

    which is exact away from singularities when ``lambda = 0`` and stays bounded near them.
    The wrench comes out in the axes the Jacobian uses, with the moment about the frame's origin.
    """
    jac = np.asarray(jacobian, dtype=float)
    tau = np.asarray(external_torques, dtype=float)
    if jac.ndim != 2 or jac.shape[0] != 6 or tau.shape != (jac.shape[1],):
        raise InputError(
            "external_torques", tau.shape, f"{jac.shape[-1]} values, one per joint of the Jacobian"
        )
    if not np.isfinite(tau).all():
        raise InputError("external_torques", tau.tolist(), "finite joint torques [N m]")
    if not (np.isfinite(damping) and damping >= 0.0):
        raise ConfigError("virtual_sensor.damping", damping, "a damping >= 0")
    # w = (J J^T + lambda^2 E)^-1 J tau
    return np.linalg.solve(jac @ jac.T + damping**2 * np.eye(6), jac @ tau)
