"""The model contact: eq. 5-13 between the peg and the true hole, the holder in series
(:class:`~fbcc_ros.core.sim.holder_solver.HolderSolver`). Fast: the 10 000-trial studies run on
it. It is the contact the law was designed on; MuJoCo's
(:mod:`fbcc_ros.core.sim.plants.mujoco`) is the one it did not see.

* The hole sits at an unknown deviation ``x_dev = (dx, dy, 0, theta_x, theta_y)`` from where
  the robot believes it is: the true features of the robot's pose ``p`` follow exactly,
  ``T_{H_true P} = P(x_dev) P(0)^-1 P(p)`` (:func:`~fbcc_ros.core.contact.features.true_rows`).
* Without the rim (``PegHole.rim``, the paper's model) the peg touches nothing while its depth
  is <= 0. With it, the top face, the chamfer and the bottom hold the peg up
  (:mod:`fbcc_ros.core.contact.rim`), the holder's axial spring pushing it down; the face's
  friction acts against the peg's own sliding over the period (``dt``).
* With a compliant holder the peg settles each period where the holder balances the contact,
  and the true features are that position.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import ContactBatch, PegHole
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.holder_solver import HolderSolver


class ModelContact:
    """Args:
    n: Trials.
    pairs: The true pairs, one or N.
    holder: The holder (None: rigid), or one compliant holder per trial (N).
    dt: The control period [s], for the peg's sliding velocity (the rim's friction).
    """

    def __init__(self, n: int, pairs: Sequence[PegHole], holder: Holder | Sequence[Holder] | None,
                 dt: float) -> None:  # fmt: skip
        self.contact = ContactBatch.of(list(pairs))
        if self.contact.has_rim and (holder is None or (isinstance(holder, Holder)
                                                        and holder.is_rigid)):  # fmt: skip
            raise ConfigError("holder", "rigid", "a compliant holder with the rim: a rigid "
                              "hand would press the peg into the top face by its whole "
                              "commanded depth")  # fmt: skip
        self.holder = HolderSolver(holder) if holder is not None else None
        self.unconverged = np.zeros(n)
        # depths <= 0 touch nothing, but where the pair has its rim
        self._floor = np.where(self.contact.table[8] > 0, -np.inf, 0.0)
        self._dt = dt
        self._last: FloatArray | None = None

    def touch(self, hand: FloatArray) -> tuple[FloatArray, FloatArray]:
        x_touch = hand.copy()
        np.maximum(x_touch[:, 2], self._floor, out=x_touch[:, 2])
        if self.holder is None:
            return hand, self.contact.response(x_touch)
        # the face's friction acts against the peg's own sliding since the last period
        settled = self.holder.step(x_touch, self.contact, last=self._last, dt=self._dt)
        self._last = settled.features.copy() if self.contact.has_rim else None
        self.unconverged += ~settled.converged
        return hand + settled.delta, settled.wrench
