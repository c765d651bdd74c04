"""The model plant: eq. 5-13 between the peg and the true hole, the holder in series
(:class:`~fbcc_ros.core.sim.holder_solver.HolderSolver`), the lagging robot. Fast: the
10 000-trial studies run on it. It is the plant the law was designed on; the MuJoCo plant
(:mod:`fbcc_ros.core.sim.plants.mujoco`) is the one it did not see.

* The hole sits at an unknown deviation ``x_dev = (dx, dy, 0, theta_x, theta_y)`` from where
  the robot believes it is: the true features of the robot's pose ``p`` follow exactly,
  ``T_{H_true P} = P(x_dev) P(0)^-1 P(p)`` (:func:`~fbcc_ros.core.contact.features.true_rows`).
* The peg touches nothing while its depth is <= 0 (this model has no top face).
* With a compliant holder the peg settles each period where the holder balances the contact,
  and the true features are that position.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.features import true_rows
from fbcc_ros.core.contact.model import ContactBatch, PegHole
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.holder_solver import HolderSolver
from fbcc_ros.core.sim.plants.plant import LaggingRobot


class ModelPlant:
    """Args:
    robot: The robot the trials share the behaviour of.
    deviation: The hole's deviation per trial, (N, 5).
    nominal: The pair the robot believes (its peg radius places the features).
    pairs: The true pairs, one or N.
    holder: The holder (None: rigid).
    """

    def __init__(self, robot: LaggingRobot, deviation: FloatArray, nominal: PegHole,
                 pairs: Sequence[PegHole], holder: Holder | None) -> None:  # fmt: skip
        n = len(deviation)
        self.robot = robot
        self.contact = ContactBatch.of(list(pairs))
        self.r_nominal = nominal.peg_radius
        self.r_true = np.broadcast_to(np.array([g.peg_radius for g in pairs]), n).copy()
        self.deviation = np.ascontiguousarray(deviation, dtype=float)
        self.holder = HolderSolver(holder) if holder is not None else None
        self.unconverged = np.zeros(n)

    def sense(self) -> tuple[FloatArray, FloatArray]:
        x = np.empty(self.deviation.shape)
        true_rows(self.robot.pose, self.deviation, self.r_nominal, self.r_true, x)  # rigid
        x_touch = x.copy()
        np.maximum(x_touch[:, 2], 0.0, out=x_touch[:, 2])  # above the hole: no contact
        if self.holder is None:
            return x, self.contact.response(x_touch)
        settled = self.holder.step(x_touch, self.contact)  # the peg deflects in its holder
        self.unconverged += ~settled.converged
        return x + settled.delta, settled.wrench

    def command(self, command: FloatArray) -> None:
        self.robot.command(command)
