"""The controller's phases and safety: what the fbcc_controller node runs, without ROS.

Phases (:class:`~fbcc_ros.core.control.phase.Phase`): ``idle`` (nothing commanded) ⇄ ``armed``
(a ``start()`` would be accepted, :meth:`Supervisor.not_armed`) → ``start()`` → ``inserting`` →
``inserted`` (the depth ramp reached L; the law keeps adjusting);
``force_limit`` (Algorithm 1's stop), ``aborted`` (``abort()``) and ``fault`` end an insertion
and hold; ``reset()`` acknowledges the end (``idle``), and a ``start()`` after a
fault or a force limit is refused until it has. A ``start()`` also needs recent features and a
recent compensated wrench (a compensation still taring, or whose wrench guard has tripped,
publishes none).

A fault or a force limit holds where the arm was last measured (the last features, however
old: a command is never ahead of the arm's measured pose when a hold is sent; an abort holds the
last command) and records why; with ``retract`` > 0 it then withdraws that far along the hole
axis (the depth l), one ``max_step`` per measured features, while they keep coming (the wrench
may not: a tripped guard withholds it):

* non-finite features or response;
* stale input: no features or no compensated wrench for longer than ``timeout`` (checked on
  every wrench and by :meth:`Supervisor.watchdog`);
* the kinematics could not reach a command (:meth:`Supervisor.fault`, from the node).

No blind commands: the law steps only on a compensated wrench that finds the features fresh:
sampled at most :func:`fresh_within` before it (their stamps, when given, else the times
``now`` they came at; from the data, so the offline replay of a bag takes the same steps). A
wrench without fresh features holds the command (counted in ``blind``); the law's next step
counts one period, not the blind time. So a stalled kinematics leaves the command at most a few
periods ahead of the arm, and the stale-input fault follows (judged on ``now``: the nodes give a
steady clock, which no parameter can stop).

Every command moves at most ``max_step`` (offsets and depth, [m]) and ``max_step_angle``
(tilts, [rad]) from the previous one, whatever the law asks.

Time comes from the samples: given the stamp of each response, the law steps by the time since
the previous one, counted in whole control periods (so its coefficients are computed once, at
construction, for each count) and bounded by the longest period the law resolves; a period of
more than one counts as ``late``. Without stamps every response is one period.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.control.laws import Law
from fbcc_ros.core.control.phase import ACTIVE, NEEDS_RESET, WAITING, Phase
from fbcc_ros.core.errors import ConfigError

#: The most control periods one sample may stand for (a longer gap is stepped as this many).
MAX_PERIODS = 10
#: The features may be this many control periods old when the law steps (a cell's jitter at its
#: rate) ...
FRESH_PERIODS = 3
#: ... and at least this old [s]: this machine's loop stalls 3-15 ms a few times per 10 s
#: (docs/nodes.md); a pause longer than it holds the command instead of stepping blind.
FRESH_FLOOR = 0.01


def fresh_within(dt: float) -> float:
    """The oldest the features may be for the law to step at the period ``dt`` [s]."""
    return max(FRESH_PERIODS * dt, FRESH_FLOOR)


@dataclasses.dataclass(frozen=True)
class SafetyLimits:
    """Attributes:
    timeout: Longest gap between features or wrenches before a fault [s]. Commands stop
        with the inputs anyway (one per compensated wrench), so the gap bounds how long a
        dead input goes unnamed, not how far the arm moves blind; 0.25 s rides over the
        stalls of nodes as processes on a shared machine (51 ms faulted a run at 0.05 s,
        docs/nodes.md) while a dead driver is named within a quarter second.
    max_step: Largest change of dx, dy or l per command [m].
    max_step_angle: Largest change of theta_x or theta_y per command [rad].
    """

    timeout: float = 0.25
    max_step: float = 5e-5
    max_step_angle: float = 1e-3

    def __post_init__(self) -> None:
        for name in ("timeout", "max_step", "max_step_angle"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(name, value, "a finite number > 0 (s, m, rad)")

    def clip(self, command: FloatArray, target: FloatArray) -> FloatArray:
        """The next command: ``target`` features, (5,) or (N, 5), reached from ``command`` by
        at most ``max_step`` (dx, dy, l) and ``max_step_angle`` (tilts)."""
        bound = np.array([self.max_step] * 3 + [self.max_step_angle] * 2)
        return command + (target - command).clip(-bound, bound)  # type: ignore[no-any-return]


class Supervisor:
    """Runs one law with phases and safety checks.

    Args:
        law: The compliance law (FBCC, admittance or none).
        dt: The control period the law is discretised for [s].
        limits: Timeouts and step limits.
        retract: How far to withdraw along the hole axis after a fault or a force limit [m]
            (0: hold where the arm is).
    """

    def __init__(self, law: Law, dt: float, limits: SafetyLimits, retract: float = 0.0) -> None:
        # a rate too low for the gains is refused here, at start-up, not at the first command;
        # and the coefficients (matrix exponentials, ~1.5 ms) are not computed in the loop
        law.prepare(dt)
        #: the most periods one sample may stand for: the longest period the law resolves
        self.max_periods = max(1, min(MAX_PERIODS, int(law.max_period() / dt * (1 + 1e-9))))
        for k in range(2, self.max_periods + 1):
            law.prepare(k * dt)
        self.late = 0
        if not (math.isfinite(retract) and retract >= 0.0):
            raise ConfigError("fault_retract", retract, "a finite distance >= 0 (m)")
        self.retract = retract
        self._retract_to: FloatArray | None = None
        self._t_sample: float | None = None
        self.law = law
        self.dt = dt
        self.limits = limits
        self.phase = Phase.IDLE
        self.reason = ""
        self.command: FloatArray | None = None
        self.features: FloatArray | None = None
        self._t_features = -math.inf
        self._s_features = -math.inf  # the features' sample time (their stamp, else arrival)
        self._t_wrench = -math.inf
        self._t_ran = -math.inf  # the last call of watchdog or on_response
        #: the watchdog's own stalls (its process did not run for longer than the timeout)
        self.stalls = 0
        #: wrenches on which the law did not step: the features were not fresh
        self.blind = 0
        self.fresh = fresh_within(dt)

    @property
    def active(self) -> bool:
        return self.phase in ACTIVE

    def fault(self, reason: str, now: float) -> None:
        """Stop, saying why, and hold where the arm is (:meth:`_hold`). A fault while already
        holding stops a retract where the arm is; the first such is added to the reason (a
        repeating one, an IK failure each period, would grow it without end)."""
        if self.active or self.phase in WAITING:
            self.phase, self.reason = Phase.FAULT, reason
            self._hold(now)
        elif self.phase in NEEDS_RESET:
            if "; then " not in self.reason:
                self.reason = f"{self.reason}; then {reason}"
            if self._retract_to is not None:
                self._retract_to = None
                self._hold(now, retract=False)

    def _hold(self, now: float, retract: bool = True) -> None:
        """The command becomes the last measured features: the arm stops where it was measured
        instead of going on to a command it has not reached (a step and its lag further into the
        hole, or, with an input stalled, as far as the law ran before the timeout). Stale
        features are still the arm's last known pose; a command is only ever the law's guess."""
        if self.command is not None and self.features is not None:
            self.command = self.features.copy()
        if retract and self.retract > 0.0 and self.command is not None:
            self._retract_to = self.command - np.array([0.0, 0.0, self.retract, 0.0, 0.0])

    def on_features(self, now: float, features: ArrayLike, stamp: float | None = None
                    ) -> FloatArray | None:  # fmt: skip
        """The measured features (sampled at ``stamp``, if given); returns a new command if
        they move one (the retract after a fault, a step each), else None."""
        x = np.asarray(features, dtype=float)
        if x.shape != (5,) or not np.isfinite(x).all():
            self.fault(f"non-finite or malformed features {x.tolist()}", now)
            return None
        self.features, self._t_features = x, now
        self._s_features = now if stamp is None else stamp
        self._arm(now)
        if self._retract_to is None or self.phase not in NEEDS_RESET or self.command is None:
            return None
        if np.abs(self._retract_to - self.command).max() < 1e-12:
            return None  # withdrawn (to rounding)
        self.command = self.limits.clip(self.command, self._retract_to)
        return self.command

    def not_armed(self, now: float) -> str:
        """Why a ``start`` at ``now`` would be refused; ``""`` when it would be accepted (the
        controller is *armed*: idle or ended without a fault, with recent inputs)."""
        if self.active:
            return f"already {self.phase}"
        if self.phase in NEEDS_RESET:
            return f"{self.phase} ({self.reason}): acknowledge it with reset first"
        if self.features is None or now - self._t_features > self.limits.timeout:
            return "no recent features: is the kinematics node running?"
        if now - self._t_wrench > self.limits.timeout:
            return ("no recent compensated wrench: is the compensation running, tared and its "
                    "wrench guard armed?")
        return ""

    def _arm(self, now: float) -> None:
        """``idle`` ⇄ ``armed`` as the inputs come and go."""
        if self.phase in WAITING:
            self.phase = Phase.IDLE if self.not_armed(now) else Phase.ARMED

    def start(self, now: float) -> tuple[bool, str]:
        """Begin an insertion from the current features, if armed (:meth:`not_armed`)."""
        why = self.not_armed(now)
        if why:
            return False, why
        assert self.features is not None
        self.law.reset(self.features)
        self.command = self.features.copy()
        self._t_sample = None
        self.phase, self.reason = Phase.INSERTING, ""
        self._t_ran = now
        return True, "insertion started"

    def reset(self) -> tuple[bool, str]:
        """Acknowledge how the last insertion ended (a fault, a force limit, an abort): back to
        ``idle``, the last command still held. Refused while an insertion runs."""
        if self.active:
            return False, f"{self.phase}: abort it first"
        ended, why = self.phase, self.reason
        self.phase, self.reason = Phase.IDLE, ""
        self._retract_to = None
        self._arm(max(self._t_ran, self._t_wrench, self._t_features))  # the latest time seen
        return True, f"{ended} acknowledged{f' ({why})' if why else ''}; {self.phase}"

    def abort(self, reason: str = "abort requested") -> tuple[bool, str]:
        if not self.active:
            return False, f"nothing to abort: {self.phase}"
        self.phase, self.reason = Phase.ABORTED, reason
        return True, "aborted; the last command is held"

    def watchdog(self, now: float) -> None:
        """Faults on stale input while an insertion runs (the timer's check).

        If this supervisor itself did not run for longer than the timeout (a stalled process,
        seen here as 0.17 s VM stalls), the inputs may be queued behind this call: they get one
        timeout from now before they are judged, and the stall is counted.
        """
        ran, self._t_ran = self._t_ran, now
        self._arm(now)
        if self.active and now - ran > self.limits.timeout:
            self.stalls += 1
            self._t_wrench = max(self._t_wrench, now)
            self._t_features = max(self._t_features, now)
            return
        self._check(now)

    def _check(self, now: float) -> None:
        if not self.active:
            return
        for name, t in (("compensated wrench", self._t_wrench), ("features", self._t_features)):
            if now - t > self.limits.timeout:
                self.fault(
                    f"stale {name}: none for {now - t:.3f} s (timeout {self.limits.timeout} s)",
                    now,
                )

    def period(self, stamp: float | None) -> float:
        """The time the law steps for a sample stamped ``stamp`` [s] (module doc)."""
        last, self._t_sample = self._t_sample, stamp
        if stamp is None or last is None:
            return self.dt
        periods = min(max(round((stamp - last) / self.dt), 1), self.max_periods)
        self.late += periods > 1
        return periods * self.dt

    def on_response(
        self, now: float, response: ArrayLike, stamp: float | None = None
    ) -> FloatArray | None:
        """One control period on a compensated response (sampled at ``stamp`` [s], if given);
        returns the command to publish (the held one outside an insertion, None before the
        first)."""
        w = np.asarray(response, dtype=float)
        valid = w.shape == (5,) and bool(np.isfinite(w).all())
        if not self.active:
            if valid:  # a start needs a recent one
                self._t_wrench = now
                self._arm(now)
            return self.command
        if not valid:
            self.fault(f"non-finite or malformed response {w.tolist()}", now)
            return self.command
        self._t_wrench = self._t_ran = now
        self._check(now)
        if not self.active or self.features is None or self.command is None:
            return self.command
        if (now if stamp is None else stamp) - self._s_features > self.fresh:  # no blind steps
            self.blind += 1
            self._t_sample = None  # the next step is one period, not the blind time
            return self.command
        x_c = self.law.step(w, self.features, self.period(stamp))
        law_phase = self.law.phase_of(0)
        if law_phase == Phase.FORCE_LIMIT:
            self.phase = Phase.FORCE_LIMIT
            self.reason = (
                f"|F| = {np.linalg.norm(w[:3]):.1f} N over the limit "
                f"{self.law.params.F_ext_limit} N"
            )
            self._hold(now)
            return self.command
        elif law_phase == Phase.INSERTED:
            self.phase = Phase.INSERTED
        self.command = self.limits.clip(self.command, x_c)  # whatever the law asks
        return self.command
