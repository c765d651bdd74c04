"""An interference fit on MuJoCo, against eq. 5-13: where MuJoCo is not credible, in numbers.

The model's push-in force of an aligned, centred peg is the hoop stress of the interference
δ = r - R, eq. 8's pressure ``p = k δ / R`` over the band ``2 π R l``, through eq. 11:

.. math::
    F_z = \\mu\\,2\\pi\\,\\delta\\,l\\,k,

in proportion to the material's k and to the depth l (:meth:`~fbcc_ros.core.contact.model.
PegHole.push_in_force`). A rigid-body engine has no hoop stress: MuJoCo's contact is a soft
constraint whose force at a penetration is set by its ``solref`` (the plant's ``timeconst``),
its ``solimp`` and the bodies' masses, one contact per pair of geoms (one per facet, whatever
the depth). MuJoCo's scene (:mod:`~fbcc_ros.core.sim.plants.mujoco_scene`) takes a peg larger
than its hole: the facets then all overlap the peg by δ.

On the interference pair of :data:`SCENARIO` (R 5.03 mm, r 5.04 mm, μ 0.3), two measurements:

* **pushed** (:func:`push`): the hand takes the aligned peg down at :data:`SPEED`, from above
  the hole or from a depth in the bore; MuJoCo's axial force Fz and the peg's depth, against
  eq. 5-13's Fz at the hand's depth (the model's peg is where the hand holds it).
* **held in the bore** (:func:`held`): the peg placed centred at a depth, each facet δ into it,
  at rest for :data:`HOLD` periods; the sum of MuJoCo's normal forces Σ N and the axial force
  Coulomb friction then holds, μ Σ N, against the model's push-in force at that depth, for each
  change of :data:`CHANGES`: the material's k (the model's parameter) and MuJoCo's contact
  parameters and peg mass (the engine's).

Command: ``python -m fbcc_ros.studies.interference_on_mujoco`` prints the tables of
docs/plant.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys

import mujoco
import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.holder import AXIAL
from fbcc_ros.core.sim.plants.mujoco import MujocoContact
from fbcc_ros.core.sim.plants.mujoco_scene import Contact, Part

SCENARIO = "config/scenarios/robust_interference.yaml"
#: The hand's speed [m/s] and the control period [s].
SPEED, DT = 0.01, 1.0e-3
#: The periods a placed peg is held before its forces are read.
HOLD = 20
#: The depths [m] of the held peg.
DEPTHS = (0.001, 0.003)
#: The reference: eq. 8's k [Pa] of a stiff plastic, MuJoCo's scene as shipped.
REFERENCE_K = 1.0e9
#: What each row changes from the reference: (name, eq. 8's k [Pa], MuJoCo's contact, part).
CHANGES: tuple[tuple[str, float, Contact, Part], ...] = (
    ("none (k 1 GPa; solref 0.2 ms, solimp (0.99, 0.999, 10 µm))", REFERENCE_K, Contact(),
     Part()),
    ("eq. 8's k 100 GPa", 1.0e11, Contact(), Part()),
    ("eq. 8's k 0.184 GPa (the scenario's)", 1.84e8, Contact(), Part()),
    ("solref 1 ms (timeconst)", REFERENCE_K, Contact(timeconst=1.0e-3), Part()),
    ("solimp (0.9, 0.95, 10 µm)", REFERENCE_K, Contact(solimp=(0.9, 0.95, 1.0e-5, 0.5, 2.0)),
     Part()),
    ("solimp width 100 µm", REFERENCE_K, Contact(solimp=(0.99, 0.999, 1.0e-4, 0.5, 2.0)),
     Part()),
    ("peg mass 0.5 kg (0.05)", REFERENCE_K, Contact(), Part(peg_mass=0.5)),
)  # fmt: skip
#: A contact soft enough for the grip to push the peg through: solref 1 ms, solimp (0.9, 0.95).
SOFT = Contact(timeconst=1.0e-3, solimp=(0.9, 0.95, 1.0e-5, 0.5, 2.0))


def interference_pair(stiffness: float | None = None) -> PegHole:
    """:data:`SCENARIO`'s pair, with eq. 8's k = ``stiffness`` [Pa] if given."""
    pair = scenario_io.load(scenario_io.find(SCENARIO)).geometry
    if pair.fit != "interference":
        raise ConfigError("geometry.peg_radius", pair.peg_radius, f"more than the hole's "
                          f"radius {pair.hole_radius:g} m (an interference fit)")  # fmt: skip
    return pair if stiffness is None else pair.replace(stiffness=stiffness)


def model_fz(pair: PegHole, depth: float) -> float:
    """Eq. 5-13's Fz [N] of the aligned, centred peg at ``depth`` [m] (0 above the hole)."""
    return float(pair.response(np.array([0.0, 0.0, max(depth, 0.0), 0.0, 0.0]))[2])


def push(pair: PegHole, start: float, end: float, contact: Contact | None = None,
         part: Part | None = None) -> FloatArray:  # fmt: skip
    """The aligned peg placed at depth ``start`` [m] (< 0: above the hole) and the hand taken
    to ``end`` at :data:`SPEED`: per period the hand's depth, the peg's and MuJoCo's Fz, (T, 3)
    [m, m, N]."""
    if not start < end <= pair.hole_depth:
        raise ConfigError("end", end, f"in ({start:g}, {pair.hole_depth:g}] m")
    plant = MujocoContact(1, [pair], None, DT, part, contact)
    periods = int(np.ceil((end - start) / (SPEED * DT)))
    hand, rows = np.zeros((1, 5)), np.zeros((periods + 1, 3))
    for k in range(periods + 1):
        hand[0, 2] = min(start + SPEED * DT * k, end)
        features, response = plant.touch(hand)
        rows[k] = hand[0, 2], features[0, 2], response[0, 2]
    return rows


def held(pair: PegHole, depth: float, contact: Contact | None = None,
         part: Part | None = None) -> tuple[float, float]:  # fmt: skip
    """The peg placed centred at ``depth`` [m] in the bore and held there for :data:`HOLD`
    periods: MuJoCo's normal forces summed over its contacts, Σ N, and μ Σ N [N]."""
    if not 0.0 < depth < pair.hole_depth:
        raise ConfigError("depth", depth, f"in (0, {pair.hole_depth:g}) m: in the bore")
    plant = MujocoContact(1, [pair], None, DT, part, contact)
    hand = np.array([[0.0, 0.0, depth, 0.0, 0.0]])
    for _ in range(HOLD):
        plant.touch(hand)
    scene, force, normal = plant.scenes[0], np.zeros(6), 0.0
    for i in range(scene.data.ncon):
        mujoco.mj_contactForce(scene.model, scene.data, i, force)
        normal += force[0]  # the contact frame's first axis is its normal
    return normal, pair.friction * normal


@dataclasses.dataclass(frozen=True)
class Change:
    """One row of :func:`changes_table`: the model's Fz and MuJoCo's μ Σ N per depth [N]."""

    change: str
    model: tuple[float, ...]
    mujoco: tuple[float, ...]


def changes_table(depths: tuple[float, ...] = DEPTHS,
                  changes: tuple[tuple[str, float, Contact, Part], ...] = CHANGES,
                  ) -> list[Change]:  # fmt: skip
    """Per change: the model's push-in force and MuJoCo's μ Σ N at each depth [N]."""
    rows = []
    for name, k, contact, part in changes:
        pair = interference_pair(k)
        rows.append(Change(name, tuple(model_fz(pair, d) for d in depths),
                           tuple(held(pair, d, contact, part)[1] for d in depths)))  # fmt: skip
    return rows


@dataclasses.dataclass(frozen=True)
class Push:
    """One row of :func:`pushes_table`: the final depths of the hand and the peg [m], MuJoCo's
    Fz, what the axial grip holds (:data:`AXIAL` times the hand's lead over the peg) and eq.
    5-13's Fz at the hand's depth [N]."""

    case: str
    hand: float
    peg: float
    fz: float
    grip: float
    model: float


def pushes_table(travel: float = 0.002) -> list[Push]:
    """The pushes of the module doc, each over ``travel`` [m] of the hand: from 0.3 mm above
    the hole, without and with a 0.3 mm chamfer; from 1 mm in the bore, MuJoCo's contact as
    shipped and :data:`SOFT`."""
    pair = interference_pair(REFERENCE_K)
    chamfered = pair.replace(rim=True, chamfer=3.0e-4)
    cases = (("above, no chamfer", -3.0e-4, Contact(), pair),
             ("above, 0.3 mm chamfer", -3.0e-4, Contact(), chamfered),
             ("in the bore from 1 mm", 1.0e-3, Contact(), pair),
             ("in the bore from 1 mm, solref 1 ms, solimp (0.9, 0.95)", 1.0e-3, SOFT,
              pair))  # fmt: skip
    out = []
    for name, start, contact, part in cases:
        hand, peg, fz = push(part, start, start + travel, contact)[-1]
        out.append(Push(name, float(hand), float(peg), float(fz), AXIAL * float(hand - peg),
                        model_fz(pair, float(hand))))  # fmt: skip
    return out


def markdown(pushes: list[Push], changes: list[Change],
             depths: tuple[float, ...] = DEPTHS) -> str:  # fmt: skip
    """The two tables of docs/plant.md."""
    lines = ["| pushed | hand's depth [mm] | peg's depth [mm] | MuJoCo Fz [N] | "
             "axial grip × (hand − peg) [N] | model Fz at the hand's depth [N] |",
             "|---|---|---|---|---|---|"]  # fmt: skip
    for r in pushes:
        lines.append(f"| {r.case} | {r.hand * 1e3:.2f} | {r.peg * 1e3:.4f} | {r.fz:.1f} | "
                     f"{r.grip:.1f} | {r.model:.1f} |")  # fmt: skip
    at = " / ".join(f"{d * 1e3:g}" for d in depths)
    lines += ["", f"| changed from the reference | model Fz at {at} mm [N] | × the reference's | "
              f"MuJoCo μ Σ N at {at} mm [N] | × the reference's |",
              "|---|---|---|---|---|"]  # fmt: skip
    ref = changes[0]
    for c in changes:
        model = " / ".join(f"{v:,.1f}" for v in c.model)
        engine = " / ".join(f"{v:,.0f}" for v in c.mujoco)
        lines.append(f"| {c.change} | {model} | {c.model[0] / ref.model[0]:.4g} | {engine} | "
                     f"{c.mujoco[0] / ref.mujoco[0]:.4g} |")  # fmt: skip
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m fbcc_ros.studies.interference_on_mujoco",
                                     description=__doc__.splitlines()[0])  # fmt: skip
    parser.add_argument("--travel-mm", type=float, default=2.0,
                        help="how far the hand pushes in each push [mm] (2)")  # fmt: skip
    args = parser.parse_args(argv)
    if not 0.0 < args.travel_mm <= 5.0:
        parser.error(f"--travel-mm {args.travel_mm}: expected a length in (0, 5] mm")
    print(markdown(pushes_table(args.travel_mm * 1e-3), changes_table()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
