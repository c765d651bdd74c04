"""The static wrench of the same pose on both plants, in each of the nine contact states of
both planes (Fig. 4): where eq. 5-13 and MuJoCo's contact agree, and where they do not.

For each state the hand takes the peg, aligned at ``approach`` above ``depth``, to an offset
of ``offset`` past the clearance toward the state's side (or none) and a tilt of ``tilt`` with
the state's sign (or none) in one plane, over ``ramp``; then it descends the ``approach`` at
``speed``, so that friction acts as it does on an insertion. (A peg placed at its pose would
start inside the wall: MuJoCo would throw it out.) Both plants run the same poses through one
interface (:mod:`fbcc_ros.core.sim.plants.plant`): the same pair, grip, rate and robot. What
is compared is the last period's response ``(Fx, Fy, Fz, Mx, My)`` at the pair's acting
point, and the state the boundary mapping reads from it (:func:`~fbcc_ros.core.contact.
segmentation.response_state`) beside the state of the true features.

Command: ``python -m fbcc_ros.studies.static_wrench`` prints the tables of docs/plant.md.
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import SIGNS, STATES, feature_state, response_state
from fbcc_ros.core.paper import paper_pair
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.plants.model import ModelContact
from fbcc_ros.core.sim.plants.mujoco import MujocoContact
from fbcc_ros.core.sim.plants.mujoco_scene import RIGID
from fbcc_ros.core.sim.plants.plant import Contact, LaggingRobot, Plant

PLANES = ("XOZ", "YOZ")
PLANT_NAMES = ("model", "mujoco")


@dataclasses.dataclass(frozen=True)
class Poses:
    """Where the hand holds the peg (module doc).

    Attributes:
        depth: [m].
        offset: Past the radial clearance [m].
        tilt: [rad].
        approach: The descent before ``depth`` [m].
        ramp: The time to take the offset and the tilt [s].
        speed: [m/s].
        rate_hz: The control rate.
    """

    depth: float = 0.003
    offset: float = 2.0e-6
    tilt: float = 0.01
    approach: float = 5.0e-4
    ramp: float = 0.1
    speed: float = 0.005
    rate_hz: float = 1000.0

    def hands(self, pair: PegHole) -> tuple[list[tuple[str, str]], FloatArray]:
        """The (plane, state) of each pose and the hand's features at ``depth``, (18, 5)."""
        clearance = max(0.0, pair.hole_radius - pair.peg_radius)
        names, rows = [], []
        for plane in PLANES:
            for state, (d, t) in zip(STATES, SIGNS, strict=True):
                lateral = d * (clearance + self.offset)
                tilt = t * self.tilt
                if plane == "XOZ":
                    row = (lateral, 0.0, self.depth, 0.0, tilt)
                else:  # the state's letter is the sign of theta_x in YOZ
                    row = (0.0, lateral, self.depth, tilt, 0.0)
                names.append((plane, state))
                rows.append(row)
        return names, np.array(rows)


@dataclasses.dataclass(frozen=True)
class Row:
    """One pose on one plant: the response and the two states of its plane."""

    plane: str
    state: str
    plant: str
    response: FloatArray
    feature_state: str
    response_state: str


def _plant(name: str, robot: LaggingRobot, n: int, pair: PegHole, holder: Holder | None,
           dt: float) -> Plant:  # fmt: skip
    contact: Contact = (ModelContact(n, [pair], holder, dt) if name == "model"
                        else MujocoContact(n, [pair], holder, dt))  # fmt: skip
    return Plant(robot, np.zeros((n, 5)), pair, [pair], contact)


def wrench_table(pair: PegHole, holder: Holder | None, poses: Poses = Poses()) -> list[Row]:
    """Each pose of :meth:`Poses.hands` on each plant (module doc)."""
    names, hands = poses.hands(pair)
    dt = 1.0 / poses.rate_hz
    above = hands.copy()
    above[:, 2] -= poses.approach
    aligned = np.zeros_like(hands)
    aligned[:, 2] = above[:, 2]
    path = [(aligned, above, poses.ramp), (above, hands, poses.approach / poses.speed)]
    rows = []
    for plant_name in PLANT_NAMES:
        robot = LaggingRobot(len(hands), dt, 0.0, 0.0)
        robot.pose[:] = aligned
        plant = _plant(plant_name, robot, len(hands), pair, holder, dt)
        for start, end, seconds in path:
            steps = max(1, round(seconds * poses.rate_hz))
            for k in range(1, steps + 1):
                plant.sense()
                plant.command(start + (end - start) * k / steps)
        features, response = plant.sense()
        by_features = feature_state(features, pair)
        by_response = response_state(response, features[:, 2], pair)
        for i, (plane, state) in enumerate(names):
            j = PLANES.index(plane)
            rows.append(Row(plane, state, plant_name, response[i], str(by_features[j][i]),
                            str(by_response[j][i])))  # fmt: skip
    return rows


def markdown(rows: list[Row]) -> str:
    """A table of docs/plant.md: per pose, each plant's lateral force, axial force, moment
    and the state read from its response."""
    by = {(r.plane, r.state, r.plant): r for r in rows}
    lines = ["| plane | state | model F, Fz, M [N, N, N·m] | model reads | "
             "MuJoCo F, Fz, M | MuJoCo reads |", "|---|---|---|---|---|---|"]  # fmt: skip
    for plane in PLANES:
        force, moment = (0, 4) if plane == "XOZ" else (1, 3)
        for state in STATES:
            cells = []
            for plant in PLANT_NAMES:
                r = by[(plane, state, plant)].response
                cells += [f"{r[force]:.2f}, {r[2]:.2f}, {r[moment]:.3f}",
                          by[(plane, state, plant)].response_state]  # fmt: skip
            lines.append(f"| {plane} | {state} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


#: The tilts of the study [rad]: one that alone leaves the clearance at 3 mm (a one-point
#: contact where the pose also has an offset), one past two-point contact (2 c / l = 7 mrad).
TILTS = (0.002, 0.01)


def main() -> int:
    """The tables of docs/plant.md: the peg held rigidly, each tilt of :data:`TILTS`; then the
    two-point tilt with the model's rim (its wall's friction against the peg's own sliding),
    both plants in MuJoCo's stiffest grip (:data:`~fbcc_ros.core.sim.plants.mujoco_scene.
    RIGID`), the one a rigidly held peg has there."""
    pair = paper_pair("clearance")
    cases: list[tuple[str, PegHole, Holder | None, float]] = [
        (f"tilt {tilt * 1e3:g} mrad", pair, None, tilt) for tilt in TILTS]
    cases.append((f"tilt {TILTS[-1] * 1e3:g} mrad, the model with its rim in the grip "
                  f"{RIGID.lateral:g} N/m, {RIGID.angular:g} N·m/rad", pair.replace(rim=True),
                  RIGID, TILTS[-1]))  # fmt: skip
    for name, part, grip, tilt in cases:
        rows = wrench_table(part, grip, Poses(tilt=tilt))
        same = sum(a.response_state == b.response_state
                   for a, b in zip(rows[:18], rows[18:], strict=True))  # fmt: skip
        print(f"{name}: the same state read on both plants in {same} of 18")
        print(markdown(rows) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
