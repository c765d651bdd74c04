"""The one interface every plant implements (DESIGN §7), and the robot they share.

A plant holds N trials in lockstep. Each control period the simulator asks it to
:meth:`Plant.sense`: the plant advances one period with the robot where it is and returns what
is true then, the peg's features in the true hole and the contact's response
``(Fx, Fy, Fz, Mx, My)`` about the pair's acting point (the model's convention,
:mod:`fbcc_ros.core.contact.model`). The law then sees that response through the sensor and
the robot's pose, and its command goes to :meth:`Plant.command`. The robot is the same for
every plant (:class:`LaggingRobot`); a plant differs in what happens between the hand and the
hole.
"""

from __future__ import annotations

import collections
import math
from typing import Protocol

import numpy as np

from fbcc_ros.core.arrays import FloatArray


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


class Plant(Protocol):
    """What the simulator drives (module doc)."""

    #: the robot: its ``pose`` (N, 5) is what the cell's kinematics measures
    robot: LaggingRobot
    #: per trial, the periods whose true state the plant could only approximate (the model's
    #: holder equilibrium left unconverged); zeros where it never does
    unconverged: FloatArray

    def sense(self) -> tuple[FloatArray, FloatArray]:
        """One period on, with the robot at its pose: the true features (N, 5) and the
        contact's response (N, 5)."""
        ...

    def command(self, command: FloatArray) -> None:
        """The commands (N, 5) of this period go to the robot."""
        ...
