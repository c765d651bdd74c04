"""The cell's safety stack in the simulator, for N trials in lockstep: what ends a trial the way
it ends an insertion in the cell (DESIGN §6).

* **The wrench guard** (:mod:`fbcc_ros.core.compensation.wrench_guard`): the compensated wrench
  (the sensor's reading, its bias and noise included) about the {H} origin, within the guard's
  force and moment limits less their stop margin, by the rule the compensation node applies
  (:func:`~fbcc_ros.core.compensation.wrench_guard.contact_excess`). A trip ends the trial.
* **The supervisor's holds** (:class:`~fbcc_ros.core.control.supervisor.Supervisor`): a trial
  the guard or the law's force limit (Algorithm 1) ended holds where the arm was last measured,
  not where the law last commanded; and every command moves at most the step limits from the
  one before.

A trial that ended is a failed trial, with its reason. What the supervisor does besides, the
simulator's lockstep has no use for: its inputs are never stale or malformed, and it starts
each trial once.
"""

from __future__ import annotations

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.wrench_guard import GuardLimits, contact_excess
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.control.supervisor import SafetyLimits
from fbcc_ros.core.sim.holder import Grip, grip_point

#: The cell's wrench guard: the compensation's limits as it ships them.
CELL_GUARD = GuardLimits()


class TrialSafety:
    """Args:
    n: Trials.
    pair: The pair whose acting point the responses' moments are taken at.
    limits: The supervisor's step limits.
    guard: The wrench guard's limits (None: no guard).
    """

    def __init__(self, n: int, pair: PegHole, limits: SafetyLimits,
                 guard: GuardLimits | None) -> None:  # fmt: skip
        self.limits, self.guard = limits, guard
        self.peg_top = pair.acting_point == "peg_top"
        # a fixed acting point (hole_bottom), or the grip point that moves with the peg
        self._acting = None if self.peg_top else pair.acting_point_in_hole()
        self._grip = Grip(pair.peg_length, None, pair.peg_radius)
        #: per trial: whether it ended, and why ("" while it runs)
        self.ended = np.zeros(n, dtype=bool)
        self.guard_tripped = np.zeros(n, dtype=bool)
        self.reason = np.full(n, "", dtype=object)
        self._hold = np.zeros((n, 5))

    def wrench_about_origin(self, response: FloatArray, features: FloatArray) -> FloatArray:
        """The wire wrench in {H} about its origin (N, 6) of responses (N, 5) about the pair's
        acting point, for a peg at ``features`` (the grip point of ``peg_top``):
        ``f = (Fx, Fy, -Fz)``, ``tau_O = tau_A + p_A x f`` (mz: the model has none about A):
        :func:`~fbcc_ros.core.compensation.wrench.wrench_from_response` for every row at once,
        each with its own point."""
        f = np.column_stack([response[:, 0], response[:, 1], -response[:, 2]])
        if self._acting is None:
            p = np.column_stack(grip_point(features, self._grip))
        else:
            p = np.broadcast_to(self._acting, (len(response), 3))
        tau = np.column_stack([response[:, 3], response[:, 4], np.zeros(len(response))])
        return np.hstack([f, tau + np.cross(p, f)])

    def command(self, command: FloatArray, target: FloatArray, pose: FloatArray,
                measured: FloatArray, features: FloatArray,
                law_stopped: FloatArray) -> FloatArray:  # fmt: skip
        """The next command of each trial: the law's ``target`` within the step limits of
        ``command``, or the hold of a trial that has ended. ``pose``: where the arm is measured
        (features of the believed hole); ``measured``: the compensated responses (N, 5);
        ``features``: the pegs' true features; ``law_stopped``: the law's force limit."""
        ending = np.zeros(len(command), dtype=bool)
        if self.guard is not None:
            for i, why in enumerate(contact_excess(self.wrench_about_origin(measured, features),
                                                   self.guard)):  # fmt: skip
                if why and not self.ended[i]:
                    ending[i] = self.guard_tripped[i] = True
                    self.reason[i] = f"wrench guard: {why}"
        limited = np.asarray(law_stopped, dtype=bool) & ~self.ended & ~ending
        self.reason[limited] = "force limit"
        ending |= limited
        self._hold[ending] = pose[ending]  # where the arm was last measured
        self.ended |= ending
        out = self.limits.clip(command, target)
        out[self.ended] = self._hold[self.ended]
        return out
