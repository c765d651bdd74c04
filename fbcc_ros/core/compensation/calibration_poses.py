"""Poses for the static calibration: how well a set of them excites the fit, and a set that does.

At rest the reading is linear in ten parameters (:func:`payload.calibrate_static`):

.. math::
    F = m g + b_F, \\qquad \\tau = -[g]_\\times (m c) + b_\\tau

with g the gravity in the sensor frame {S}. Only the *changes* of g between poses separate the
payload from the bias. Write ``u_k`` for gravity's direction at pose k, ``δ_k = u_k − ū`` its
change from the mean, and ``S = Σ δ_k δ_kᵀ / K`` their scatter, with eigenvalues
``σ1² ≥ σ2² ≥ σ3²`` along ``e1, e2, e3``:

* the mass is told from the force bias by any change of g: it needs ``σ1 > 0``;
* the centre of mass is seen through ``δ_k × (m c)``, whose information matrix is
  ``tr(S) E − S``: its component along e1 (the direction gravity changed *most*) is seen only
  through the changes across it, ``σ2² + σ3²``. Gravity changing along one direction only leaves
  the centre of mass along that direction unseen, however far it swung.

So three poses with gravity in three distinct directions determine the fit, and the
condition number (:func:`condition`, column-scaled as :func:`payload.calibrate` computes it)
grows as the poses bunch together: about 480 for tilts of 0.01 rad about two axes, 48 for
0.1 rad, 3.6 for 1 rad (four poses around a vertical gravity). :func:`explain` turns a bad set
into what is missing and which joint would supply it (the joint whose rotation moves gravity in
{S} along the missing direction most, at one of the poses already held; wrist joints first, they
tilt the sensor without moving the arm far).

:func:`calibration_poses` chooses a set for a calibration motion: the robot's home, then
candidates with the last three joints (an LBR's A5, A6, A7) offset from home, within the joint
limits and with the flange at most 1 cm lower than at home (toward the table). After home comes
the candidate whose gravity is furthest from home's (any pair is singular), then candidates are
added greedily, each time the one that leaves the set's condition number lowest. For the iiwa14
with the sensor aligned with the flange, 12 poses reach a condition number of 1.64
(``test/core/compensation/test_calibration_data.py`` pins it); 12 uniformly random orientations
give 1.1 to 2.4, 12 random configurations within ±1 rad of home 1.7 to 4.1 (50 draws each). The
poses come back ordered for a short motion (nearest next, by the largest joint change).
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.payload import GRAVITY_BASE, Motion, regressor
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.kinematics.robot import RobotModel

#: Names of the static fit's ten parameters, in the regressor's column order.
PARAMETERS = ("mass", "m c_x", "m c_y", "m c_z", "bias F_x", "bias F_y", "bias F_z",
              "bias T_x", "bias T_y", "bias T_z")  # fmt: skip

#: Below this spread (rms, in units of g: about 3° of tilt) :func:`explain` says gravity "did
#: not change" along a direction. Tilts of 0.01 rad about two axes give a condition number of
#: about 480, 0.03 rad 160: a set refused at 1e3 has changed by well under 0.05 g.
SPREAD_MIN = 0.05

#: Leave-one-out ratios: without a pose *needed* by the set, its condition number at least
#: doubles; without a *redundant* one it grows by under 5 % (the pose still averages the noise
#: down; it adds no direction the others lack). Between the two, the pose *adds* excitation.
NEEDED_RATIO = 2.0
REDUNDANT_RATIO = 1.05

#: Offsets from home of the last three joints (A5, A6, A7 of an LBR) that calibration_poses
#: combines [rad]. A6 tilts the flange by up to 0.9 rad (52°), A5 turns the plane of that tilt,
#: A7 turns the sensor about the flange's axis, which moves gravity in {S} once tilted.
WRIST_OFFSETS = ((-1.0, 0.0, 1.0), (-0.9, -0.45, 0.0, 0.45, 0.9), (-2.4, -1.2, 0.0, 1.2, 2.4))

#: How far below its height at home a candidate may put the flange [m].
MAX_DROP = 0.01


def gravity_in_frame(robot: RobotModel, q: ArrayLike, frame: str) -> FloatArray:
    """Gravity in ``frame``'s axes at joint positions ``q`` [m/s²]: ``R_base_frameᵀ g``."""
    return robot.frame_in_base(q, frame).rotation.T @ GRAVITY_BASE  # type: ignore[no-any-return]


def static_regressor(gravities: ArrayLike) -> FloatArray:
    """The (6K, 10) matrix of the static fit for K poses, gravity ``(K, 3)`` in {S} [m/s²]:
    ``(m, m c)`` from :func:`payload.regressor`, then the six biases."""
    g = np.asarray(gravities, dtype=float).reshape(-1, 3)
    rows = np.zeros((len(g), 6, 10))
    for row, gk in zip(rows, g, strict=True):
        row[:, :4] = regressor(Motion(gk))[:, :4]
        row[:, 4:] = np.eye(6)
    return rows.reshape(6 * len(g), 10)


def _scaled_singular_values(a: FloatArray) -> NDArray[np.floating[Any]]:
    """Of ``a`` with its columns scaled to unit norm (units differ: kg, kg m, N, N m)."""
    scale = np.linalg.norm(a, axis=0)
    return np.linalg.svd(a / np.where(scale > 0.0, scale, 1.0), compute_uv=False)


def condition(gravities: ArrayLike) -> float:
    """Condition number of the static fit's column-scaled regressor, as
    :func:`payload.calibrate` computes it (infinite for fewer than 3 poses or a parameter
    nothing excites)."""
    g = np.asarray(gravities, dtype=float).reshape(-1, 3)
    if len(g) == 0:
        return float("inf")
    a = static_regressor(g)
    s = _scaled_singular_values(a)
    if len(s) < a.shape[1]:  # one pose: 6 rows for 10 parameters
        return float("inf")
    return float(s[0] / s[-1]) if s[-1] > 1e-12 * s[0] else float("inf")


@dataclasses.dataclass(frozen=True)
class Spread:
    """How gravity's direction in {S} changed over the poses.

    Attributes:
        mean: Mean direction ū (not normalised; |ū| < 1 when gravity changed).
        sigma: rms change along ``axes`` (descending) [g].
        axes: (3, 3), row i the direction of ``sigma[i]`` in {S}.
        low: Smallest component of the direction per sensor axis (x, y, z) [g].
        high: Largest, likewise.
    """

    mean: FloatArray
    sigma: FloatArray
    axes: FloatArray
    low: FloatArray
    high: FloatArray


def spread(gravities: ArrayLike) -> Spread:
    """The changes of gravity's direction over the poses (``(K, 3)`` in {S}, K >= 1)."""
    g = np.asarray(gravities, dtype=float).reshape(-1, 3)
    u = g / np.linalg.norm(g, axis=1, keepdims=True)
    mean = u.mean(axis=0)
    d = u - mean
    values, vectors = np.linalg.eigh(d.T @ d / len(u))
    order = np.argsort(values)[::-1]
    sigma = np.sqrt(np.maximum(values[order], 0.0))
    return Spread(mean, sigma, vectors[:, order].T, u.min(axis=0), u.max(axis=0))


@dataclasses.dataclass(frozen=True)
class Excitation:
    """How well K poses excite the static fit.

    Attributes:
        condition: Of all the poses together (:func:`condition`).
        without: (K,) the condition number without each pose.
        roles: Per pose ``"needed"``, ``"adds"`` or ``"redundant"`` (see :data:`NEEDED_RATIO`).
        spread: Gravity's changes over the poses.
    """

    condition: float
    without: FloatArray
    roles: tuple[str, ...]
    spread: Spread


def excitation(gravities: ArrayLike) -> Excitation:
    """The condition number of all poses, and what each pose adds (leave-one-out)."""
    g = np.asarray(gravities, dtype=float).reshape(-1, 3)
    if len(g) == 0:
        raise ConfigError("gravities", "no poses", "at least one pose")
    full = condition(g)
    without = np.array([condition(np.delete(g, k, axis=0)) for k in range(len(g))])
    roles = tuple(_role(w, full) for w in without)
    return Excitation(full, without, roles, spread(g))


def _role(without: float, full: float) -> str:
    if not np.isfinite(full) or without >= NEEDED_RATIO * full:
        return "needed"
    return "redundant" if without <= REDUNDANT_RATIO * full else "adds"


def direction(v: ArrayLike) -> str:
    """A direction in {S} in words: ``sensor +x`` if within 18° of an axis, else its
    components."""
    u = np.asarray(v, dtype=float)
    u = u / np.linalg.norm(u)
    i = int(np.argmax(np.abs(u)))
    if abs(u[i]) >= 0.95:
        return f"sensor {'+' if u[i] > 0 else '-'}{'xyz'[i]}"
    return "sensor [" + ", ".join(f"{x:.2f}" for x in u) + "]"


def _line(v: ArrayLike) -> str:
    """The line of a direction: ``z`` for ±z, else its components."""
    name = direction(v)[len("sensor ") :]
    return name[1:] if name[0] in "+-" else name


def _axes(mask: NDArray[np.bool_]) -> str:
    names = ["xyz"[i] for i in np.flatnonzero(mask)]
    return " or ".join(names)


def explain(
    gravities: ArrayLike,
    robot: RobotModel | None = None,
    qs: ArrayLike | None = None,
    frame: str | None = None,
) -> str:
    """Why K poses (gravity ``(K, 3)`` in {S}) leave the static fit ill-conditioned, and, given
    the ``robot`` and the poses' joint positions ``qs`` (``frame``: the sensor's), which joint
    to rotate. One or two sentences a user can act on."""
    g = np.asarray(gravities, dtype=float).reshape(-1, 3)
    if len(g) == 0:
        return "no pose held still: hold at least three poses with the sensor tilted differently"
    s = spread(g)
    mean = s.mean / max(float(np.linalg.norm(s.mean)), 1e-12)
    if s.sigma[0] < SPREAD_MIN:
        absent = np.abs(s.high - s.low) < SPREAD_MIN
        absent &= np.maximum(np.abs(s.high), np.abs(s.low)) < SPREAD_MIN
        never = f"it never had a component along sensor {_axes(absent)}; " if absent.any() else ""
        why = (f"gravity stayed along {direction(mean)} in every pose (its direction changed by "
               f"{s.sigma[0]:.2g} g rms): {never}the mass cannot be told from the force bias, "
               f"nor the centre of mass along {_line(mean)} from the torque bias. "
               "Tilt the sensor")  # fmt: skip
        missing = _perpendicular(mean)
    elif s.sigma[1] < SPREAD_MIN:
        e1 = s.axes[0]
        along = _line(e1)
        why = (f"gravity changed only along {direction(e1)} ({s.sigma[0]:.2g} g rms; "
               f"{s.sigma[1]:.2g} g across it): the centre of mass along {along} is unseen. "
               f"Tilt the sensor so that gravity also changes across {along}")  # fmt: skip
        missing = np.cross(mean, e1)
        if np.linalg.norm(missing) < 0.1:  # gravity swung through 90°+: any direction across
            missing = s.axes[1]
    else:
        return _weakest(g, s)
    return why + _which_joint(robot, qs, frame, g, missing) + "."


def _perpendicular(u: FloatArray) -> FloatArray:
    """A direction across ``u`` (the one in the plane of the axis least aligned with u)."""
    axis = np.eye(3)[int(np.argmin(np.abs(u)))]
    return np.cross(u, axis)  # type: ignore[no-any-return]


def _which_joint(
    robot: RobotModel | None, qs: ArrayLike | None, frame: str | None, g: FloatArray,
    missing: FloatArray,
) -> str:  # fmt: skip
    """``": rotate A6 (name) or A5 (name)"``: the joints whose rotation moves gravity in {S}
    along ``missing`` most, at one of the poses held (wrist joints first)."""
    if robot is None or qs is None or frame is None:
        return ""
    q = np.asarray(qs, dtype=float).reshape(len(g), robot.nq)
    d = missing / np.linalg.norm(missing)
    gain = np.zeros(robot.nq)  # |d · dg/dq_j| / |g|, the best over the poses [g per rad]
    for qk, gk in zip(q, g, strict=True):
        omega = robot.jacobian(qk, frame, pin.LOCAL)[3:]  # each joint's axis in {S}
        # R_S turns at omega: g_S = R_Sᵀ g_base turns at -omega × g_S = g_S × omega
        gain = np.maximum(gain, np.abs(d @ np.cross(gk, omega.T).T) / np.linalg.norm(gk))
    best = float(gain.max())
    if best < 1e-6:
        return ""
    wrist = range(max(robot.nq - 3, 0), robot.nq)
    chosen = [j for j in sorted(wrist, key=lambda j: -gain[j]) if gain[j] >= 0.5 * best][:2]
    chosen = chosen or [int(np.argmax(gain))]
    names = " or ".join(f"A{j + 1} ({robot.joint_names[j]})" for j in chosen)
    return f": rotate {names} by about {min(np.pi / 2, 0.5 / gain[chosen[0]]):.1f} rad"


def _weakest(g: FloatArray, s: Spread) -> str:
    """The parameters the poses excite least (the smallest singular vector of the scaled
    regressor), when gravity did change across two directions."""
    a = static_regressor(g)
    scale = np.linalg.norm(a, axis=0)
    _, _, vt = np.linalg.svd(a / np.where(scale > 0.0, scale, 1.0))
    weights = np.abs(vt[-1])
    names = [PARAMETERS[i] for i in np.argsort(weights)[::-1][:3] if weights[i] > 0.2]
    return (f"the poses excite {' + '.join(names)} least (gravity's direction changed by "
            f"{', '.join(f'{x:.2g}' for x in s.sigma)} g rms along its principal directions): "
            "add poses with the sensor tilted further, in other directions")  # fmt: skip


@dataclasses.dataclass(frozen=True)
class PoseSet:
    """Result of :func:`calibration_poses`.

    Attributes:
        q: (n, nq) joint positions, home first, ordered for a short motion [rad].
        condition: The static fit's condition number over them.
        gravity: (n, 3) gravity in the frame at each pose [m/s²].
    """

    q: FloatArray
    condition: float
    gravity: FloatArray


def candidates(robot: RobotModel, home: ArrayLike | None = None) -> FloatArray:
    """``home`` (default the robot's) with the last three joints offset by
    :data:`WRIST_OFFSETS`, within the joint limits, the flange no more than :data:`MAX_DROP`
    below its height at home."""
    if robot.nq < 3:
        raise ConfigError("robot", robot.name, "an arm with at least three joints")
    home = robot.home if home is None else robot.check_joints(home, "home")
    floor = robot.flange_in_base(home).translation[2] - MAX_DROP
    out = []
    for offsets in itertools.product(*WRIST_OFFSETS):
        q = home.copy()
        q[-3:] += offsets
        if robot.within_limits(q) and robot.flange_in_base(q).translation[2] >= floor:
            out.append(q)
    return np.array(out)


def calibration_poses(robot: RobotModel, n: int = 12, frame: str | None = None,
                      home: ArrayLike | None = None) -> PoseSet:  # fmt: skip
    """``n`` joint configurations around ``home`` (default ``robot.home``) for a static
    calibration, chosen so gravity spans ``frame`` (default: the flange; give the sensor's
    frame if it is turned on the flange) well: home first, then greedily the
    :func:`candidates` that keep the condition number lowest. The module doc says how."""
    frame = frame or robot.flange_frame
    home = robot.home if home is None else robot.check_joints(home, "home")
    pool = candidates(robot, home)
    if not 3 <= n <= len(pool):
        raise ConfigError("n", n, f"3 to {len(pool)} poses (the candidates of {robot.name})")
    gravity = np.array([gravity_in_frame(robot, q, frame) for q in pool])
    start = int(np.argmin(np.abs(pool - home).max(axis=1)))  # home itself
    chosen = [start]
    # the second: gravity furthest from home's (any pair is singular, so no condition to rank)
    chosen.append(int(np.argmax(np.linalg.norm(gravity - gravity[start], axis=1))))
    while len(chosen) < n:
        rest = [j for j in range(len(pool)) if j not in chosen]
        scores = [condition(gravity[[*chosen, j]]) for j in rest]
        chosen.append(rest[int(np.argmin(scores))])
    ordered = _short_tour(pool[chosen])
    q = pool[chosen][ordered]
    return PoseSet(q, condition(gravity[chosen]), gravity[chosen][ordered])


def _short_tour(q: FloatArray) -> list[int]:
    """From the first pose, always the nearest unvisited one (largest joint change)."""
    order = [0]
    while len(order) < len(q):
        rest = [j for j in range(len(q)) if j not in order]
        step = np.abs(q[rest] - q[order[-1]]).max(axis=1)
        order.append(rest[int(np.argmin(step))])
    return order
