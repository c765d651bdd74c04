"""A calibration motion: the arm lifted clear of the hole, through the poses of
:func:`~fbcc_ros.core.compensation.calibration_poses.calibration_poses`, holding each, and back.

``fbcc_bringup --calibration-motion`` commands it to the mock cell and records the joint states
and the wrist sensor's readings, for ``fbcc-calibrate BAG`` (static mode: one sample per pose
held). The motion is a list of :class:`Path` segments, each timed by one minimum-jerk profile:

* **the lift**: from the start, the peg straight up by ``lift`` (joint waypoints every
  :data:`LIFT_STEP` by IK, interpolated linearly between them), so the wrist turns clear of the
  fixture;
* **the poses**: the calibration poses around the lifted configuration, each held for ``hold``;
  between them a straight line in joint space;
* **the way back** down the lift, so the cell ends where it started.

A segment lasts long enough that no joint exceeds ``speed`` of its velocity limit: the
minimum-jerk profile peaks at 1.875 times its mean speed, so a straight segment along which a
joint travels ``L`` takes ``1.875 L / (speed v_max)`` (:func:`move`).
"""

from __future__ import annotations

import bisect
import dataclasses

import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.calibration_poses import calibration_poses
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.kinematics.ik import solve_ik
from fbcc_ros.core.kinematics.robot import RobotModel

#: How far the peg is lifted above its start before the wrist turns [m]: at a 52° tilt a tool
#: pointing down rises, so the peg stays this far above where it started, clear of the hole.
LIFT = 0.25
#: The lift's IK waypoints are this far apart [m] (the path between them bows by micrometres).
LIFT_STEP = 0.01
#: Peak joint speed, as a fraction of each joint's limit: a gentle motion the arm follows
#: closely, so the payload rings little at each stop.
SPEED = 0.4
#: Each pose is held this long [s]: fbcc-calibrate drops the first 0.15 s (the ring) and the
#: last 0.02 s of a dwell; 0.8 s of readings remain.
HOLD = 1.0
#: The shortest segment [s].
MIN_DURATION = 0.2


def minimum_jerk(s: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The minimum-jerk profile ``p(s) = 10 s³ - 15 s⁴ + 6 s⁵`` on s in [0, 1], and its first
    and second derivatives in s (the speed peaks at s = 1/2, at 1.875)."""
    x = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
    return (10 * x**3 - 15 * x**4 + 6 * x**5, 30 * x**2 - 60 * x**3 + 30 * x**4,
            60 * x - 180 * x**2 + 120 * x**3)  # fmt: skip


def _progress(waypoints: FloatArray) -> FloatArray:
    """Where each waypoint lies along the path, 0 to 1, by the largest joint travel."""
    steps = np.abs(np.diff(waypoints, axis=0)).max(axis=1)
    return np.concatenate(([0.0], np.cumsum(steps))) / steps.sum()


@dataclasses.dataclass(frozen=True)
class Path:
    """Joint waypoints passed through in ``duration`` [s] by one minimum-jerk profile over
    their length (the largest joint travel, summed along them); one waypoint: a hold."""

    waypoints: FloatArray
    duration: float
    hold: bool = False

    def at(self, t: float) -> FloatArray:
        """The joint positions ``t`` seconds into the segment [rad]."""
        if len(self.waypoints) == 1:
            return self.waypoints[0].copy()
        u = _progress(self.waypoints)
        p = float(minimum_jerk(t / self.duration)[0])
        i = min(int(np.searchsorted(u, p, side="right")) - 1, len(u) - 2)
        w = (p - u[i]) / (u[i + 1] - u[i]) if u[i + 1] > u[i] else 0.0
        return self.waypoints[i] + w * (self.waypoints[i + 1] - self.waypoints[i])  # type: ignore[no-any-return]


def move(waypoints: ArrayLike, velocity_limit: ArrayLike, speed: float = SPEED) -> Path:
    """A segment through ``waypoints`` whose joints stay under ``speed`` of their limits: a
    joint's rate along the path, ``dq/du``, times the profile's peak ``1.875 / T``."""
    q = np.atleast_2d(np.asarray(waypoints, dtype=float))
    if len(q) < 2 or not np.diff(q, axis=0).any():
        return Path(q[:1], MIN_DURATION)  # nowhere to go
    du = np.diff(_progress(q))
    dq = np.abs(np.diff(q, axis=0))
    rate = np.max(dq[du > 0] / du[du > 0, None], axis=0)  # the steepest stretch, per joint
    duration = float(np.max(1.875 * rate / (speed * np.asarray(velocity_limit))))
    return Path(q, max(duration, MIN_DURATION))


def lift_path(robot: RobotModel, q_start: ArrayLike, lift: float = LIFT) -> FloatArray:
    """Joint waypoints that move the peg straight up by ``lift`` [m] from ``q_start``, every
    :data:`LIFT_STEP` (IK from the previous one)."""
    q = robot.check_joints(q_start, "q_start")
    start = robot.peg_in_base(q)
    out = [q]
    for height in np.linspace(0.0, lift, max(2, round(lift / LIFT_STEP) + 1))[1:]:
        target = start.copy()
        target.translation = start.translation + np.array([0.0, 0.0, height])
        out.append(solve_ik(robot, target, out[-1]).q)
    return np.array(out)


@dataclasses.dataclass(frozen=True)
class CalibrationMotion:
    """The whole motion (module doc).

    Attributes:
        segments: The lift, moves, holds and the way back, in order.
        starts: When each segment starts [s].
        poses: The calibration poses held, in order [rad].
        condition: Their static fit's condition number.
    """

    segments: tuple[Path, ...]
    starts: tuple[float, ...]
    poses: FloatArray
    condition: float

    @property
    def duration(self) -> float:
        return self.starts[-1] + self.segments[-1].duration

    def at(self, t: float) -> FloatArray:
        """The commanded joint positions at ``t`` [s] from the motion's start (the last ones
        after its end)."""
        i = max(bisect.bisect_right(self.starts, t) - 1, 0)
        return self.segments[i].at(min(t - self.starts[i], self.segments[i].duration))

    def holds(self) -> list[tuple[float, float]]:
        """When each pose is held: (start, end) [s]."""
        return [(t, t + s.duration) for t, s in zip(self.starts, self.segments, strict=True)
                if s.hold]  # fmt: skip


def calibration_motion(robot: RobotModel, q_start: ArrayLike, n: int = 12,
                       frame: str | None = None, lift: float = LIFT, hold: float = HOLD,
                       speed: float = SPEED) -> CalibrationMotion:  # fmt: skip
    """The motion from ``q_start`` through ``n`` calibration poses for the sensor at
    ``frame`` (default the flange), each held ``hold`` [s], at ``speed`` of the limits."""
    for name, value, low, high in (("lift", lift, 0.0, 1.0), ("hold", hold, 0.3, 60.0),
                                   ("speed", speed, 0.01, 1.0)):  # fmt: skip
        if not low <= value <= high:
            raise ConfigError(name, value, f"between {low:g} and {high:g}")
    up = lift_path(robot, q_start, lift)
    poses = calibration_poses(robot, n, frame, home=up[-1])
    limit = robot.velocity_limit
    segments = [move(up, limit, speed)]
    for q_from, q_to in zip([up[-1], *poses.q], poses.q, strict=False):
        segments += [move([q_from, q_to], limit, speed), Path(q_to[None, :], hold, hold=True)]
    segments += [move([poses.q[-1], up[-1]], limit, speed), move(up[::-1], limit, speed)]
    starts = np.concatenate(([0.0], np.cumsum([s.duration for s in segments])[:-1]))
    return CalibrationMotion(tuple(segments), tuple(starts.tolist()), poses.q, poses.condition)
