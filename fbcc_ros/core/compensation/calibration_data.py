"""Samples for the payload calibration from time series: the joint states and the sensor's
readings of an arm moving through poses, as a bag of a real cell holds them.

**Pairing.** Each reading is paired with the joint state nearest in time (by the messages'
stamps). A reading further than ``max_gap`` (:data:`MAX_PAIR_GAP`) from every joint state is
refused and counted: the arm's pose at that instant is not known.

**Static mode** (:func:`static_samples`): one sample per pose held still.

1. The joint speeds: the recorded velocities, or, when a JointState carries none, the positions
   differentiated across :data:`SPEED_WINDOW` (a central difference over ±10 ms, which keeps
   the encoder's noise from looking like motion).
2. A *dwell* is a run of joint states with every joint slower than :data:`DWELL_SPEED` that
   lasts at least :data:`MIN_DWELL`.
3. Its first :data:`SETTLE` and its last :data:`LEAD` are dropped (the transient: the arm and
   the payload ring after a stop, and accelerate before the speed shows it); the paired
   readings left are averaged, and so are the joint positions: one pose, one row.

**Dynamic mode** (:func:`dynamic_samples`): every paired reading, with the joint positions,
velocities and accelerations at its stamp, interpolated linearly between the joint states around
it. The velocities are the recorded ones or the positions differentiated as above; the
accelerations are the velocities differentiated the same way.

No ROS here: the command (``fbcc-calibrate BAG``) decodes the bag into the arrays.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import InputError

#: A reading further than this from every joint state is refused [s]: a 100 Hz joint state
#: publisher that drops one message leaves readings 10 ms from the nearest; a longer gap is a
#: stall, over which the pose is not known (at 1 rad/s a joint moves 15 mrad in 15 ms).
MAX_PAIR_GAP = 0.015
#: All joints slower than this: the arm is still [rad/s]. At 0.01 rad/s the payload's
#: centripetal force (1 kg at 0.1 m: 1e-5 N) is far below any sensor's noise, and gravity's
#: direction drifts by at most 5 mrad over a 0.5 s dwell; the dwell's averaged positions follow
#: the drift, which leaves an error of second order (1e-5 of g). A joint reversing at 1 rad/s²
#: stays under it for only 20 ms: no dwell.
DWELL_SPEED = 0.01
#: A dwell lasts at least this [s]: after dropping SETTLE and LEAD, 0.13 s of readings remain
#: (130 at 1 kHz, which cut the noise by 11); a pose held for half a second is one, a pause
#: in a trajectory is not.
MIN_DWELL = 0.3
#: Dropped at the start of each dwell [s]: the arm and the payload ring after a stop. A
#: jerk-limited stop is under DWELL_SPEED up to 2 % of its duration before it ends (70 ms of a
#: 4 s move), so at least 80 ms of ringing go: a ring of 12 Hz or more has made a period, one
#: decaying in 30 ms is down to 7 %.
SETTLE = 0.15
#: Dropped at the end of each dwell [s]: the next move accelerates before its speed reaches
#: DWELL_SPEED (at 1 rad/s², 10 ms).
LEAD = 0.02
#: Positions are differentiated across this window [s] (a central difference over ±10 ms):
#: 1e-5 rad of encoder noise gives 7e-4 rad/s rms (3e-3 at its peaks), under DWELL_SPEED,
#: where the difference of successive 1 kHz samples peaks above it; at 100 Hz the window spans
#: one state each side.
SPEED_WINDOW = 0.02


@dataclasses.dataclass(frozen=True)
class JointStates:
    """A joint state time series, in one joint order.

    Attributes:
        t: (N,) stamps [s], increasing.
        q: (N, n) positions [rad].
        dq: (N, n) velocities [rad/s], or None when the messages carried none.
    """

    t: FloatArray
    q: FloatArray
    dq: FloatArray | None = None

    def __post_init__(self) -> None:
        t, q = np.asarray(self.t, dtype=float), np.asarray(self.q, dtype=float)
        if t.ndim != 1 or q.ndim != 2 or len(q) != len(t) or len(t) < 2:
            raise InputError("joint states", (t.shape, q.shape), "(N,) stamps and (N, n) "
                             "positions, N >= 2")  # fmt: skip
        if self.dq is not None and np.shape(self.dq) != q.shape:
            raise InputError("joint states.velocity", np.shape(self.dq), f"{q.shape}")
        if not (np.isfinite(t).all() and np.isfinite(q).all()):
            raise InputError("joint states", "non-finite stamps or positions", "finite values")
        if not (np.diff(t) > 0).all():
            raise InputError("joint states.t", "not increasing",
                             "strictly increasing stamps (sort, and drop repeats)")  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Readings:
    """The sensor's readings: ``t`` (M,) stamps [s], ``wrench`` (M, 6) in {S} [N, N m]."""

    t: FloatArray
    wrench: FloatArray

    def __post_init__(self) -> None:
        if np.ndim(self.t) != 1 or np.shape(self.wrench) != (len(self.t), 6):
            raise InputError("readings", (np.shape(self.t), np.shape(self.wrench)),
                             "(M,) stamps and (M, 6) wrenches")  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Pairing:
    """Each reading's nearest joint state.

    Attributes:
        index: (M,) the nearest joint state of each reading.
        gap: (M,) how far it is [s].
        ok: (M,) ``gap <= max_gap``.
        max_gap: The bound [s].
    """

    index: NDArray[np.intp]
    gap: FloatArray
    ok: NDArray[np.bool_]
    max_gap: float

    @property
    def refused(self) -> int:
        """Readings with no joint state within ``max_gap``."""
        return int((~self.ok).sum())


def pair_nearest(t_readings: ArrayLike, t_joints: ArrayLike,
                 max_gap: float = MAX_PAIR_GAP) -> Pairing:  # fmt: skip
    """Pairs each reading (stamps ``t_readings``) with the joint state nearest in time
    (``t_joints``, increasing)."""
    tr, tj = np.asarray(t_readings, dtype=float), np.asarray(t_joints, dtype=float)
    after = np.clip(np.searchsorted(tj, tr), 1, len(tj) - 1)
    before = after - 1
    nearer_before = np.abs(tr - tj[before]) <= np.abs(tj[after] - tr)
    index = np.where(nearer_before, before, after)
    gap = np.abs(tr - tj[index])
    return Pairing(index, gap, gap <= max_gap, max_gap)


def joint_velocities(joints: JointStates, window: float = SPEED_WINDOW) -> FloatArray:
    """The recorded velocities, or the positions differentiated (:func:`differentiate`)."""
    return joints.dq if joints.dq is not None else differentiate(joints.t, joints.q, window)


def differentiate(t: FloatArray, x: FloatArray, window: float = SPEED_WINDOW) -> FloatArray:
    """d``x``/dt at each ``t``: a central difference across ``window`` (``x`` interpolated
    linearly at ``t ± window/2``, clipped to the series' ends; at least one sample each side)."""
    half = np.maximum(window / 2, 0.0)
    lo = np.interp(t - half, t, np.arange(len(t)))
    hi = np.interp(t + half, t, np.arange(len(t)))
    # at least one neighbour each side (a coarse series), within the series
    lo = np.minimum(lo, np.maximum(np.arange(len(t)) - 1, 0))
    hi = np.maximum(hi, np.minimum(np.arange(len(t)) + 1, len(t) - 1))
    t_lo, t_hi = (np.interp(i, np.arange(len(t)), t) for i in (lo, hi))
    x_lo = np.column_stack([np.interp(lo, np.arange(len(t)), col) for col in x.T])
    x_hi = np.column_stack([np.interp(hi, np.arange(len(t)), col) for col in x.T])
    return (x_hi - x_lo) / (t_hi - t_lo)[:, None]  # type: ignore[no-any-return]


def still_runs(t: FloatArray, speed: FloatArray, threshold: float = DWELL_SPEED,
               min_duration: float = MIN_DWELL) -> list[tuple[int, int]]:  # fmt: skip
    """Index ranges ``[first, last]`` of the runs where every joint is slower than ``threshold``
    (``speed``: (N, n) [rad/s]) for at least ``min_duration`` [s]."""
    still = (np.abs(speed) < threshold).all(axis=1)
    edges = np.diff(np.concatenate(([0], still.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(int(a), int(b)) for a, b in zip(starts, ends, strict=True)
            if t[b] - t[a] >= min_duration]  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Dwell:
    """One pose held still, averaged into one sample.

    Attributes:
        still: (start, end) of the still run [s].
        window: (start, end) of the part averaged [s].
        q: Mean joint positions over the window [rad].
        wrench: Mean paired reading over the window, in {S} [N, N m].
        spread: Standard deviation of those readings, per component [N, N m].
        readings: How many were averaged.
    """

    still: tuple[float, float]
    window: tuple[float, float]
    q: FloatArray
    wrench: FloatArray
    spread: FloatArray
    readings: int

    @property
    def standard_error(self) -> FloatArray:
        """Of the mean reading, per component, if the noise is white [N, N m]."""
        return self.spread / np.sqrt(max(self.readings, 1))  # type: ignore[no-any-return]


@dataclasses.dataclass(frozen=True)
class StaticSamples:
    """Result of :func:`static_samples`.

    Attributes:
        dwells: The poses held, in time order.
        pairing: Each reading's joint state.
        empty: Still runs dropped because no paired reading fell in their window.
        thresholds: The speed [rad/s], minimum duration, settle and lead [s] used.
    """

    dwells: list[Dwell]
    pairing: Pairing
    empty: int
    thresholds: tuple[float, float, float, float]

    @property
    def q(self) -> FloatArray:
        """(K, n) the poses' mean joint positions [rad] (K = 0: shape (0, 0))."""
        return np.array([d.q for d in self.dwells]) if self.dwells else np.zeros((0, 0))

    @property
    def wrench(self) -> FloatArray:
        """(K, 6) the poses' mean readings [N, N m]."""
        return np.array([d.wrench for d in self.dwells]).reshape(len(self.dwells), 6)


def static_samples(
    joints: JointStates,
    readings: Readings,
    *,
    speed: float = DWELL_SPEED,
    min_dwell: float = MIN_DWELL,
    settle: float = SETTLE,
    lead: float = LEAD,
    max_gap: float = MAX_PAIR_GAP,
) -> StaticSamples:
    """One averaged sample per dwell (the module doc says how)."""
    pairing = pair_nearest(readings.t, joints.t, max_gap)
    velocity = joint_velocities(joints)
    dwells, empty = [], 0
    for first, last in still_runs(joints.t, velocity, speed, min_dwell):
        t0, t1 = float(joints.t[first]), float(joints.t[last])
        w0, w1 = t0 + settle, t1 - lead
        take = pairing.ok & (readings.t >= w0) & (readings.t <= w1)
        if not take.any():
            empty += 1
            continue
        inside = (joints.t >= w0) & (joints.t <= w1)
        # a coarse joint state series may have none inside a short window: the run's own
        q = joints.q[inside] if inside.any() else joints.q[first : last + 1]
        w = readings.wrench[take]
        dwells.append(Dwell((t0, t1), (w0, w1), q.mean(axis=0), w.mean(axis=0), w.std(axis=0),
                            int(take.sum())))  # fmt: skip
    return StaticSamples(dwells, pairing, empty, (speed, min_dwell, settle, lead))


@dataclasses.dataclass(frozen=True)
class DynamicSamples:
    """Result of :func:`dynamic_samples`: the paired readings and the joints at their stamps.

    Attributes:
        t: (K,) stamps [s].
        q, dq, ddq: (K, n) joint positions [rad], velocities [rad/s], accelerations [rad/s²].
        wrench: (K, 6) readings in {S} [N, N m].
        pairing: Each reading's joint state (K = the ones paired).
        differentiated: Whether the velocities came from the positions.
    """

    t: FloatArray
    q: FloatArray
    dq: FloatArray
    ddq: FloatArray
    wrench: FloatArray
    pairing: Pairing
    differentiated: bool


def dynamic_samples(
    joints: JointStates,
    readings: Readings,
    *,
    max_gap: float = MAX_PAIR_GAP,
    window: float = SPEED_WINDOW,
) -> DynamicSamples:
    """Every paired reading with the joints' motion at its stamp (the module doc says how)."""
    pairing = pair_nearest(readings.t, joints.t, max_gap)
    dq = joint_velocities(joints, window)
    ddq = differentiate(joints.t, dq, window)
    t = readings.t[pairing.ok]

    def at(x: FloatArray) -> FloatArray:
        return np.column_stack([np.interp(t, joints.t, col) for col in x.T]).reshape(len(t), -1)

    return DynamicSamples(t, at(joints.q), at(dq), at(ddq), readings.wrench[pairing.ok],
                          pairing, joints.dq is None)  # fmt: skip
