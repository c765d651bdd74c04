"""The peg on the hole's rim on both plants: the model with its rim (:mod:`fbcc_ros.core.contact.
rim`) against MuJoCo's faceted top face and chamfer, the same hand on each.

The hand holds the peg ``offset`` off the hole and tilted, starts ``approach`` above the top
face and descends at ``speed`` until the plant's axial force passes ``push``, then holds
``hold``: the peg stands on the face, slides down the chamfer into the bore, or leans on the
edge. What is compared is where it settled (its depth, offset and tilt) and the wrench there
(Fz, Fx, and the support's lever My/Fz about the pair's acting point).

Command: ``python -m fbcc_ros.studies.rim_wrench`` prints the table of docs/plant.md.
"""

from __future__ import annotations

import dataclasses
import math
import sys

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.plants.model import ModelContact
from fbcc_ros.core.sim.plants.mujoco import MujocoContact
from fbcc_ros.core.sim.plants.plant import Contact

DEG = math.pi / 180
#: The pair of the MuJoCo Monte Carlo (10 µm radial clearance), steel-like for the model.
PAIR = PegHole(5.05e-3, 5.04e-3, 0.01, 0.005, 0.3, 1e11)
#: Its grip (``config/scenarios/mujoco_clearance.yaml``).
GRIP = Holder(5e4, 30.0)


@dataclasses.dataclass(frozen=True)
class Case:
    """Attributes: name; chamfer [m]; offset along x [m]; tilt theta_y [rad]."""

    name: str
    chamfer: float
    offset: float
    tilt: float


CASES = (
    Case("face, 0.1 mm off", 0.0, 1e-4, 0.0),
    Case("face, 0.3 mm off", 0.0, 3e-4, 0.0),
    Case("face, 1 mm off", 0.0, 1e-3, 0.0),
    Case("chamfer, 0.1 mm off", 3e-4, 1e-4, 0.0),
    Case("chamfer, 0.2 mm off", 3e-4, 2e-4, 0.0),
    Case("tilted 2° away, 0.3 mm off", 0.0, 3e-4, 2 * DEG),
    Case("tilted 2° toward, 0.3 mm off", 0.0, 3e-4, -2 * DEG),
    Case("tilted 2° away, chamfer, 0.3 mm off", 3e-4, 3e-4, 2 * DEG),
)
PLANT_NAMES = ("model", "mujoco")
#: The least Fz [N] whose lever My/Fz the table gives.
SUPPORT = 1.0


@dataclasses.dataclass(frozen=True)
class Descent:
    """Attributes: approach [m]; speed [m/s]; push [N]; hold [s]; rate_hz; give_up, the depth
    past which the hand stops descending [m]."""

    approach: float = 3e-4
    speed: float = 5e-3
    push: float = 20.0
    hold: float = 0.15
    rate_hz: float = 1000.0
    give_up: float = 2e-3


@dataclasses.dataclass(frozen=True)
class Settled:
    """Where the peg settled on one plant: its features and the response there."""

    case: str
    plant: str
    features: FloatArray
    response: FloatArray


def contact(plant: str, case: Case, pair: PegHole, grip: Holder, dt: float) -> Contact:
    """The plant's contact of one trial: the model with the rim and the case's chamfer, or
    MuJoCo's scene with it."""
    part = pair.replace(rim=True, chamfer=case.chamfer)
    if plant == "model":
        return ModelContact(1, [part], grip, dt)
    return MujocoContact(1, [part], grip, dt)


def settle(plant: str, case: Case, pair: PegHole = PAIR, grip: Holder = GRIP,
           descent: Descent = Descent()) -> Settled:  # fmt: skip
    """The case on one plant (module doc)."""
    dt = 1.0 / descent.rate_hz
    c = contact(plant, case, pair, grip, dt)
    depth, held = -descent.approach, 0
    while held < round(descent.hold * descent.rate_hz):
        features, response = c.touch(np.array([[case.offset, 0.0, depth, 0.0, case.tilt]]))
        if held or response[0, 2] > descent.push or depth >= descent.give_up:
            held += 1
        else:
            depth += descent.speed * dt
    return Settled(case.name, plant, features[0], response[0])


def markdown(rows: list[Settled]) -> str:
    """The table of docs/plant.md: per case and plant, where the peg settled and its wrench."""
    lines = ["| case | plant | depth [µm] | dx [µm] | θy [°] | Fz [N] | Fx [N] | My/Fz [mm] |",
             "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in rows:
        f, w = r.features, r.response
        # a support's lever needs a support: a peg at rest in the bore carries next to no Fz
        lever = f"{w[4] / w[2] * 1e3:.2f}" if w[2] > SUPPORT else "-"
        lines.append(f"| {r.case} | {r.plant} | {f[2] * 1e6:.1f} | {f[0] * 1e6:.1f} | "
                     f"{f[4] / DEG:.3f} | {w[2]:.1f} | {w[0]:.2f} | {lever} |")  # fmt: skip
    return "\n".join(lines)


def main() -> int:
    rows = [settle(plant, case) for case in CASES for plant in PLANT_NAMES]
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
