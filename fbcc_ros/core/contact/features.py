"""The feature vector (paper eq. 1-3) and its conversion to and from the peg's pose in {H}.

Frames (DESIGN §3):

* {H}, the hole frame: origin at the centre of the hole's top face, z along the hole axis pointing
  out of the hole.
* {P}, the peg (tool) frame: origin at the centre of the peg's end face (the tip), z along the peg
  axis pointing out of the robot's flange, i.e. the approach direction. Aligned and inserted, {P}
  is {H} turned half a turn about x: ``R_HP = diag(1, -1, -1)``.

The peg's upward axis (from the tip toward the flange) is ``a = -z_P``; with
``a = (a_x, a_y, a_z)`` the projected tilts of eq. 3 (read with eq. 14, DESIGN §5) are

    theta_y = atan2(a_x, a_z),   theta_x = atan2(-a_y, a_z),

so ``theta_y > 0`` leans the peg's top toward +x and ``theta_x > 0`` toward -y, and the total tilt
``theta`` has ``cos theta = a_z``.

Depth and offsets follow the contact model's reading of eq. 5 exactly (``docs/contact-model.md``),
so that the response ``PegHole.response(features)`` describes the physical peg at this pose:

* the end face's lowest point lies at depth ``l cos theta`` below the top face; it is
  ``r sin theta`` below the tip centre, so ``l = (depth_tip + r sin theta) / cos theta``;
* ``(dx, dy)`` is where eq. 5 puts the slice centre ``O_p``: the axis point at ``l/2`` along the
  axis from the tip, plus ``r sin²theta (1 - 1/cos theta)`` along the lean (a term of order
  ``r theta⁴``, 7 nm at 2° for r = 5 mm, kept so the conversion is exact).

Aligned (theta = 0) this is the plain reading of DESIGN §3: ``l`` is the depth of the tip and
``(dx, dy)`` the axis offset at depth ``l/2``. Tilted, the literal reading "tip depth; axis offset
at depth l/2" would differ by ``r sin theta`` in ``l`` (0.18 mm at 2°, r = 5 mm) and by about
``r sin theta tan theta`` in ``dx, dy`` (6 µm) — a third of the 20 µm success tolerance, which is
why the peg radius is part of the conversion.

The features leave the peg's spin about its own axis free (five features, six pose coordinates).
:func:`pose_from_features` takes the spin as an argument and :func:`spin_of` reads it back:
the spin is the twist left after the minimal ("swing") rotation that tilts the aligned peg.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import InputError
from fbcc_ros.core.vector_math import arctan

#: Orientation of {P} in {H} when the peg is aligned with the hole, at zero spin.
R_ALIGNED = np.diag([1.0, -1.0, -1.0])


Rows = tuple[tuple[float, float, float], ...]


def _swing(axis: tuple[float, float, float]) -> Rows:
    """The minimal rotation taking z to the unit vector ``axis`` (Rodrigues, closed form), as
    rows of floats.

    .. math::
        S = \\begin{pmatrix} 1 - a_x^2/(1+a_z) & -a_x a_y/(1+a_z) & a_x \\\\
                             -a_x a_y/(1+a_z) & 1 - a_y^2/(1+a_z) & a_y \\\\
                             -a_x & -a_y & a_z \\end{pmatrix}
    """
    ax, ay, az = axis
    c = 1.0 / (1.0 + az)
    return (
        (1.0 - ax * ax * c, -ax * ay * c, ax),
        (-ax * ay * c, 1.0 - ay * ay * c, ay),
        (-ax, -ay, az),
    )


def _check_tilted_less_than_90(rotation_peg_in_hole: FloatArray) -> float:
    a_z = -float(rotation_peg_in_hole[2, 2])
    if not a_z > 1e-9:
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, a_z))))
        raise InputError(
            "rotation_peg_in_hole",
            f"a peg tilted {tilt:.1f} deg from the hole axis",
            "a peg pointing into the hole (tilt below 90 deg: the peg's z axis along -z of {H})",
        )
    return a_z


@numba.njit(cache=True)  # type: ignore[misc]
def axis_and_tip(
    dx: float, dy: float, depth: float, theta_x: float, theta_y: float, peg_radius: float
) -> tuple[float, float, float, float, float, float]:
    """The peg's upward axis ``a`` and its tip centre in {H}, ``(a_x, a_y, a_z, p_x, p_y, p_z)``,
    of features (the inverse of :func:`_features_of`)."""
    # Upward axis from the projected tilts (eq. 3): a ∝ (tan theta_y, -tan theta_x, 1).
    tx, ty = math.tan(theta_y), -math.tan(theta_x)
    norm = math.sqrt(1.0 + tx * tx + ty * ty)
    a_x, a_y, a_z = tx / norm, ty / norm, 1.0 / norm
    sin_t = math.hypot(a_x, a_y)
    along = 0.5 * depth + peg_radius * sin_t * (1.0 - 1.0 / a_z)
    return a_x, a_y, a_z, dx - along * a_x, dy - along * a_y, -(depth * a_z - peg_radius * sin_t)


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def _features_of(
    a_x: float, a_y: float, a_z: float, p_x: float, p_y: float, p_z: float, peg_radius: float,
    exact: bool,
) -> tuple[float, float, float, float, float]:  # fmt: skip
    """Features of the peg with upward axis ``a`` and tip centre ``p`` in {H}. Not ``exact``:
    the tilts by :func:`~fbcc_ros.core.vector_math.arctan` of a_x/a_z (a_z > 0) instead of
    libm's atan2, within 2 ulp of it, and sin(θ) by a square root instead of hypot, so that a
    loop over many holes vectorises (the deviation filter's particles; the plant's features
    stay exact)."""
    sin_t = math.hypot(a_x, a_y) if exact else math.sqrt(a_x * a_x + a_y * a_y)
    # Lowest point of the end face at depth l cos(theta) (eq. 5, s = 0): it is r sin(theta)
    # below the tip centre, which is at depth -p_z.
    depth = (-p_z + peg_radius * sin_t) / a_z
    # O_p of eq. 5 at the slice through the axis point l/2 from the tip; a_xy = sin(theta) e.
    along = 0.5 * depth + peg_radius * sin_t * (1.0 - 1.0 / a_z)
    x, y = p_x + along * a_x, p_y + along * a_y
    if exact:
        return x, y, depth, math.atan2(-a_y, a_z), math.atan2(a_x, a_z)
    return x, y, depth, arctan(-a_y / a_z), arctan(a_x / a_z)


def features_from_pose(
    rotation_peg_in_hole: ArrayLike, position_peg_in_hole: ArrayLike, peg_radius: float
) -> FloatArray:
    """Features ``(dx, dy, l, theta_x, theta_y)`` of the peg frame {P} posed in {H} [m, rad].

    Args:
        rotation_peg_in_hole: ``R_HP``, (3, 3).
        position_peg_in_hole: ``p_HP``, the tip centre in {H} [m], (3,).
        peg_radius: r [m].
    """
    rot = np.asarray(rotation_peg_in_hole, dtype=float)
    pos = np.asarray(position_peg_in_hole, dtype=float)
    a_z = _check_tilted_less_than_90(rot)
    return np.array(_features_of(-float(rot[0, 2]), -float(rot[1, 2]), a_z, float(pos[0]),
                                 float(pos[1]), float(pos[2]), peg_radius, True))  # fmt: skip


def pose_from_features(
    features: ArrayLike, peg_radius: float, spin: float = 0.0
) -> tuple[FloatArray, FloatArray]:
    """The pose ``(R_HP, p_HP)`` of the peg frame in {H} with these features; inverse of
    :func:`features_from_pose` for any spin.

    Args:
        features: ``(dx, dy, l, theta_x, theta_y)`` [m, rad]; tilts within (-90°, 90°).
        peg_radius: r [m].
        spin: Rotation of the peg about its own axis [rad], see :func:`spin_of`.
    """
    values = np.asarray(features, dtype=float)
    if values.shape != (5,):
        raise InputError("features", features, "5 values (dx, dy, l, theta_x, theta_y)")
    dx, dy, depth, theta_x, theta_y = values.tolist()
    if not (abs(theta_x) < 0.5 * math.pi and abs(theta_y) < 0.5 * math.pi):
        raise InputError(
            "features (theta_x, theta_y)", (theta_x, theta_y), "tilts within (-pi/2, pi/2) rad"
        )
    a_x, a_y, a_z, tip_x, tip_y, tip_z = axis_and_tip(dx, dy, depth, theta_x, theta_y,
                                                       peg_radius)  # fmt: skip
    c, s = math.cos(spin), math.sin(spin)
    # R_HP = S(a) R_aligned R_z(spin) = S(a) [[c, -s, 0], [-s, -c, 0], [0, 0, -1]], multiplied
    # out on floats (no 3x3 products at 1 kHz).
    rotation = np.array(
        [[s0 * c - s1 * s, -s0 * s - s1 * c, -s2] for s0, s1, s2 in _swing((a_x, a_y, a_z))]
    )
    return rotation, np.array([tip_x, tip_y, tip_z])


def spin_of(rotation_peg_in_hole: ArrayLike) -> float:
    """The peg's rotation about its own axis [rad]: ``R_HP = S(a) R_aligned R_z(spin)``, with
    ``S(a)`` the minimal rotation tilting z to the upward axis ``a``."""
    rot = np.asarray(rotation_peg_in_hole, dtype=float)
    a_z = _check_tilted_less_than_90(rot)
    # First column of R_z(spin) = R_aligned^T S(a)^T x_P, written out (S from _swing, a = -z_P).
    a_x, a_y = -float(rot[0, 2]), -float(rot[1, 2])
    x0, x1, x2 = (float(v) for v in rot[:, 0])
    c = 1.0 / (1.0 + a_z)
    cos_spin = (1.0 - a_x * a_x * c) * x0 - a_x * a_y * c * x1 - a_x * x2
    sin_spin = -(-a_x * a_y * c * x0 + (1.0 - a_y * a_y * c) * x1 - a_y * x2)
    return math.atan2(sin_spin, cos_spin)


@numba.njit(cache=True)  # type: ignore[misc]
def in_deviated_hole(
    pose: FloatArray, deviation: FloatArray, r_nominal: float, r_true: float, out: FloatArray
) -> None:
    """Features into ``out`` (5,) of the peg at ``pose`` (5,) of the believed hole, in the hole
    at ``deviation`` (5,) (see :func:`true_features`)."""
    b_x, b_y, b_z, q_x, q_y, q_z = _hole_frame(deviation, r_nominal)
    a_x, a_y, a_z, p_x, p_y, p_z = axis_and_tip(pose[0], pose[1], pose[2], pose[3], pose[4],
                                                 r_nominal)  # fmt: skip
    out[0], out[1], out[2], out[3], out[4] = _in_hole(
        a_x, a_y, a_z, p_x, p_y, p_z, b_x, b_y, b_z, q_x, q_y, q_z, r_true, True)


@numba.njit(cache=True)  # type: ignore[misc]
def _hole_frame(
    deviation: FloatArray, r_nominal: float
) -> tuple[float, float, float, float, float, float]:
    """T_{H_true H} = P(x_dev) P(0)^-1 = (S(b), q) of the hole at ``deviation`` (5,): the axis
    b and tip q of P(x_dev), ``(b_x, b_y, b_z, q_x, q_y, q_z)``."""
    return axis_and_tip(deviation[0], deviation[1], 0.0, deviation[3], deviation[4], r_nominal)


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def _in_hole(
    a_x: float, a_y: float, a_z: float, p_x: float, p_y: float, p_z: float,
    b_x: float, b_y: float, b_z: float, q_x: float, q_y: float, q_z: float,
    r_true: float, exact: bool,
) -> tuple[float, float, float, float, float]:  # fmt: skip
    """Features of the peg with axis ``a`` and tip ``p`` in the believed hole, in the hole
    whose P(x_dev) has axis ``b`` and tip ``q`` (``exact``: as :func:`_features_of`)."""
    c = 1.0 / (1.0 + b_z)  # S(b), the rows of _swing
    s00, s01, s02 = 1.0 - b_x * b_x * c, -b_x * b_y * c, b_x
    s11, s12 = 1.0 - b_y * b_y * c, b_y
    # the axis turns with S(b); the tip also moves by q
    return _features_of(
        s00 * a_x + s01 * a_y + s02 * a_z,
        s01 * a_x + s11 * a_y + s12 * a_z,
        -b_x * a_x - b_y * a_y + b_z * a_z,
        s00 * p_x + s01 * p_y + s02 * p_z + q_x,
        s01 * p_x + s11 * p_y + s12 * p_z + q_y,
        -b_x * p_x - b_y * p_y + b_z * p_z + q_z,
        r_true,
        exact,
    )


@numba.njit(cache=True)  # type: ignore[misc]
def true_rows(
    pose: FloatArray, deviation: FloatArray, r_nominal: float, r_true: FloatArray,
    out: FloatArray,
) -> None:  # fmt: skip
    """:func:`true_features` into ``out`` (N, 5), on arrays the caller prepared: pose and
    deviation (N, 5) and the true radii (N,), all contiguous float64 (the simulator's loop)."""
    for i in range(pose.shape[0]):
        in_deviated_hole(pose[i], deviation[i], r_nominal, r_true[i], out[i])


@numba.njit(cache=True)  # type: ignore[misc]
def hole_frames(deviation: FloatArray, r_nominal: float, out: FloatArray) -> None:
    """Into ``out`` (6, N), per hole at ``deviation`` (N, 5): the axis b and tip q of P(x_dev)
    (:func:`in_deviated_hole`), what :func:`true_rows_at` needs of it, one row per
    coordinate."""
    for i in range(deviation.shape[0]):
        out[0, i], out[1, i], out[2, i], out[3, i], out[4, i], out[5, i] = _hole_frame(
            deviation[i], r_nominal)


@numba.njit(cache=True, error_model="numpy")  # type: ignore[misc]
def true_rows_at(pose: FloatArray, frames: FloatArray, r_nominal: float, r_true: float,
                 out: FloatArray) -> None:  # fmt: skip
    """:func:`true_rows` of one pose (5,) in many holes, given by their frames (6, N,
    :func:`hole_frames`), with one true r, into ``out`` (5, N), one row per feature (the
    deviation filter's particles, whose holes move less often than the peg). The pose's axis
    and tip are found once; the loop over the holes vectorises, each one's tilts within 2 ulp
    (:func:`_features_of` not exact)."""
    a_x, a_y, a_z, p_x, p_y, p_z = axis_and_tip(pose[0], pose[1], pose[2], pose[3], pose[4],
                                                 r_nominal)  # fmt: skip
    for i in range(frames.shape[1]):
        out[0, i], out[1, i], out[2, i], out[3, i], out[4, i] = _in_hole(
            a_x, a_y, a_z, p_x, p_y, p_z, frames[0, i], frames[1, i], frames[2, i],
            frames[3, i], frames[4, i], frames[5, i], r_true, False)


def true_features(
    pose: ArrayLike, deviation: ArrayLike, peg_radius: float, true_radius: ArrayLike | None = None
) -> FloatArray:
    """Features in the true hole of a peg at features ``pose`` of the believed hole, (N, 5).

    The true hole sits at the deviation ``x_dev = (dx, dy, ·, theta_x, theta_y)`` (its depth
    ignored): a peg at the believed features 0 has the true features ``x_dev``, so
    ``T_{H H_true} = P(0) P(x_dev)^-1`` with ``P(x)`` the peg pose of features x (spin 0). The
    plant of the simulator and the mock cell (:mod:`fbcc_ros.core.sim.mock_cell`).

    Args:
        pose: (N, 5) or (5,), features in the believed hole.
        deviation: (N, 5) or (5,), the true hole's deviation.
        peg_radius: Nominal r [m], with which the robot reads its pose as features.
        true_radius: The true r per trial [m] (default: the nominal one).
    """
    x = np.ascontiguousarray(np.atleast_2d(np.asarray(pose, dtype=float)))
    dev = np.ascontiguousarray(np.broadcast_to(np.asarray(deviation, dtype=float), x.shape))
    r_true = np.broadcast_to(
        np.asarray(peg_radius if true_radius is None else true_radius, dtype=float), len(x)
    )
    out = np.empty_like(x)
    true_rows(x, dev, float(peg_radius), np.ascontiguousarray(r_true), out)
    return out
