"""The model contact: eq. 5-13 between the peg and the true hole, the holder in series
(:class:`~fbcc_ros.core.sim.holder_solver.HolderSolver`). Fast: the 10 000-trial studies run on
it. It is the contact the law was designed on; MuJoCo's
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
from fbcc_ros.core.contact.model import ContactBatch, PegHole
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.holder_solver import HolderSolver


class ModelContact:
    """Args:
    n: Trials.
    pairs: The true pairs, one or N.
    holder: The holder (None: rigid).
    """

    def __init__(self, n: int, pairs: Sequence[PegHole], holder: Holder | None) -> None:
        self.contact = ContactBatch.of(list(pairs))
        self.holder = HolderSolver(holder) if holder is not None else None
        self.unconverged = np.zeros(n)

    def touch(self, hand: FloatArray) -> tuple[FloatArray, FloatArray]:
        x_touch = hand.copy()
        np.maximum(x_touch[:, 2], 0.0, out=x_touch[:, 2])  # above the hole: no contact
        if self.holder is None:
            return hand, self.contact.response(x_touch)
        settled = self.holder.step(x_touch, self.contact)  # the peg deflects in its holder
        self.unconverged += ~settled.converged
        return hand + settled.delta, settled.wrench
