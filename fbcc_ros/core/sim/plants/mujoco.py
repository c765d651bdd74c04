"""The MuJoCo contact: each trial's hand drives a MuJoCo peg-in-hole scene
(:mod:`fbcc_ros.core.sim.plants.mujoco_scene`), whose contact physics are not eq. 5-13.

Each period the hand is set where it holds an undeflected peg at the given features in the
true hole, MuJoCo runs one period of its timesteps, and the peg's features and the wrench it
exerted on the hole over the period (its mean, as a force/torque sensor reads it) are read:
the wrench about the {H} origin moved to the pair's acting point, as the model's response
(:func:`~fbcc_ros.core.compensation.wrench.response_from_wrench`).
Each trial is its own scene, stepped in turn (a trial costs what one scene costs).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.wrench import response_from_wrench
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.plants.mujoco_scene import Contact, MujocoPegHole, Part
from fbcc_ros.core.sim.plants.spec import PlantSpec

#: The credibility study's two contacts (docs/plant.md): (solref's time constant [s], solimp's
#: width [m]) of the metal-like contact the scene ships (its defaults: 0.2 ms, 10 µm), and of a
#: plastic-like one.
METAL_LIKE = (PlantSpec.timeconst, Contact.solimp[2])
PLASTIC_LIKE = (1.0e-3, 1.0e-4)


def impedance_width(timeconst: float) -> float:
    """solimp's width [m] of a contact whose time constant is ``timeconst`` [s]: on the line
    through the metal-like and the plastic-like contacts on log scales (10 µm at 0.2 ms, 0.1 mm
    at 1 ms), so that one time constant names a contact from metal-like to plastic-like."""
    (t0, w0), (t1, w1) = METAL_LIKE, PLASTIC_LIKE
    return w0 * (timeconst / t0) ** (math.log(w1 / w0) / math.log(t1 / t0))


class MujocoContact:
    """Args:
    n: Trials.
    pairs: The true pairs, one or N.
    holder: The grip (None: the scene's stiffest, :data:`~.mujoco_scene.RIGID`), or one per
        trial (N).
    dt: The control period [s], a whole number of MuJoCo timesteps.
    part: The bore's facets and face width; the peg's length, grip and mass (the chamfer is
        each pair's, :attr:`PegHole.chamfer`).
    contact: MuJoCo's contact parameters.
    """

    def __init__(self, n: int, pairs: Sequence[PegHole],
                 holder: Holder | Sequence[Holder] | None, dt: float, part: Part | None = None,
                 contact: Contact | None = None) -> None:  # fmt: skip
        true = list(pairs) if len(pairs) == n else [pairs[0]] * n
        grips = [holder] * n if holder is None or isinstance(holder, Holder) else list(holder)
        if len(grips) != n:
            raise ConfigError("holder", f"{len(grips)} holders", f"1 or {n}, one per trial")
        self.scenes = [MujocoPegHole(pair, grip, part, contact)
                       for pair, grip in zip(true, grips, strict=True)]
        self.substeps = round(dt / self.scenes[0].dt)
        if abs(self.substeps * self.scenes[0].dt - dt) > 1e-9 * dt:
            raise ConfigError("rate_hz", 1.0 / dt, f"a period that is a whole number of "
                              f"MuJoCo timesteps ({self.scenes[0].dt:g} s)")  # fmt: skip
        self.acting = [p.acting_point_in_hole() for p in true]
        self.unconverged = np.zeros(n)
        self._placed = False

    def touch(self, hand: FloatArray) -> tuple[FloatArray, FloatArray]:
        """(:meth:`~fbcc_ros.core.sim.plants.plant.Contact.touch`) The first touch places each
        peg at rest where the hand holds it."""
        features, response = np.empty_like(hand), np.empty_like(hand)
        for i, scene in enumerate(self.scenes):
            if not self._placed:
                scene.place(hand[i])
            scene.set_hand(hand[i])
            scene.step(self.substeps)
            features[i] = scene.features()
            response[i] = response_from_wrench(scene.mean_wrench_on_hole(), self.acting[i])
        self._placed = True
        return features, response


def scene_of(sc: Any) -> tuple[Part, Contact]:
    """The bore and MuJoCo's contact of a scenario (:class:`~fbcc_ros.core.sim.scenario.
    Scenario`): its ``plant`` section's facets, face width, timestep and contact time constant,
    the impedance's width following it (:func:`impedance_width`); the chamfer is each true
    pair's, ``geometry.chamfer`` or a trial's draw."""
    spec: PlantSpec = sc.plant
    d0, d1, _, middle, power = Contact.solimp
    solimp = (d0, d1, impedance_width(spec.timeconst), middle, power)
    return (Part(facets=spec.facets, face_width=spec.face_width),
            Contact(timeconst=spec.timeconst, timestep=spec.timestep, solimp=solimp))
