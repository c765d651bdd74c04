"""The one interface every plant implements (DESIGN §7), and the robot they share.

A plant is the robot and a *contact*: what happens between the robot's hand and the hole. Two
contacts implement :class:`Contact`: eq. 5-13 with the holder in series
(:class:`~fbcc_ros.core.sim.plants.model.ModelContact`) and MuJoCo
(:class:`~fbcc_ros.core.sim.plants.mujoco.MujocoContact`). Every driver takes either: the
simulator through :class:`Plant` (the robot in the features of the believed hole), the mock
cell through :meth:`Contact.touch` directly (its arm in joint space).

A plant holds N trials in lockstep. Each control period the simulator asks it to
:meth:`Plant.sense`: the plant advances one period with the robot where it is and returns what
is true then, the peg's features in the true hole and the contact's response
``(Fx, Fy, Fz, Mx, My)`` about the pair's acting point (the model's convention,
:mod:`fbcc_ros.core.contact.model`). The law then sees that response through the sensor and
the robot's pose, and its command goes to :meth:`Plant.command`.
"""

from __future__ import annotations

import collections
import math
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.features import true_rows
from fbcc_ros.core.contact.model import PegHole


class LaggingRobot:
    """A position-controlled robot, in the features of the believed hole: the pose follows the
    command with a first-order lag, ``p(k+1) = p(k) + (1 - exp(-dt/tau)) (x_c(k - n) - p(k))``,
    the command reaching it ``n = round(delay / dt)`` periods late (it holds its start until
    the first one comes).

    Args:
        n: Trials.
        dt: The control period [s].
        lag: tau [s] (0: none).
        delay: [s].
    """

    def __init__(self, n: int, dt: float, lag: float, delay: float) -> None:
        self.pose = np.zeros((n, 5))
        self.alpha = 1.0 - math.exp(-dt / lag) if lag > 0 else 1.0
        self._late = collections.deque([self.pose.copy()] * round(delay / dt))

    def command(self, command: FloatArray) -> None:
        self._late.append(command)
        self.pose += self.alpha * (self._late.popleft() - self.pose)


class Contact(Protocol):
    """Between the hand and the true hole, for N trials (module doc)."""

    #: per trial, the periods whose true state the contact could only approximate (the
    #: model's holder equilibrium left unconverged); zeros where it never does
    unconverged: FloatArray

    def touch(self, hand: FloatArray) -> tuple[FloatArray, FloatArray]:
        """One control period with the hand where it holds an undeflected peg at ``hand``, the
        features (N, 5) in the true hole: the peg's true features (N, 5) and the contact's
        response (N, 5) at the period's end."""
        ...


class Plant:
    """The robot and a contact (module doc).

    Args:
        robot: The robot; its ``pose`` (N, 5) is what the cell's kinematics measures.
        deviation: The hole's deviation per trial, (N, 5).
        nominal: The pair the robot believes (its peg radius places the features).
        pairs: The true pairs, one or N.
        contact: The contact of those pairs.
    """

    def __init__(self, robot: LaggingRobot, deviation: FloatArray, nominal: PegHole,
                 pairs: Sequence[PegHole], contact: Contact) -> None:  # fmt: skip
        n = len(deviation)
        self.robot, self.contact = robot, contact
        self.r_nominal = nominal.peg_radius
        self.r_true = np.broadcast_to(np.array([g.peg_radius for g in pairs]), n).copy()
        self.deviation = np.ascontiguousarray(deviation, dtype=float)

    @property
    def unconverged(self) -> FloatArray:
        return self.contact.unconverged

    def sense(self) -> tuple[FloatArray, FloatArray]:
        """One period on, with the robot at its pose: the true features (N, 5) and the
        contact's response (N, 5)."""
        hand = np.empty(self.deviation.shape)  # the rigid peg in each true hole
        true_rows(self.robot.pose, self.deviation, self.r_nominal, self.r_true, hand)
        return self.contact.touch(hand)

    def command(self, command: FloatArray) -> None:
        """The commands (N, 5) of this period go to the robot."""
        self.robot.command(command)
