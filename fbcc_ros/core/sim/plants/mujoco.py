"""The MuJoCo plant: the lagging robot drives the hand of a MuJoCo peg-in-hole scene per trial
(:mod:`fbcc_ros.core.sim.plants.mujoco_scene`), whose contact physics are not eq. 5-13.

Each period the hand is set where the robot's pose puts an undeflected peg in the true hole
(the same :func:`~fbcc_ros.core.contact.features.true_rows` as the model plant), MuJoCo runs
one period of its timesteps, and the peg's features and the wrench it exerts on the hole are
read: the wrench about the {H} origin moved to the pair's acting point, as the model's response
(:func:`~fbcc_ros.core.compensation.wrench.response_from_wrench`). Each trial is its own scene,
stepped in turn (a trial costs what one scene costs).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.wrench import response_from_wrench
from fbcc_ros.core.contact.features import true_rows
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.plants.mujoco_scene import Contact, MujocoPegHole, Part
from fbcc_ros.core.sim.plants.plant import LaggingRobot


class MujocoPlant:
    """Args:
    robot: The robot.
    deviation: The hole's deviation per trial, (N, 5).
    nominal: The pair the robot believes (its peg radius places the features).
    pairs: The true pairs, one or N.
    holder: The grip (None: the scene's stiffest, :data:`~.mujoco_scene.RIGID`).
    dt: The control period [s], a whole number of MuJoCo timesteps.
    part: The bore's facets, chamfer and rim; the peg's length, grip and mass.
    contact: MuJoCo's contact parameters.
    """

    def __init__(self, robot: LaggingRobot, deviation: FloatArray, nominal: PegHole,
                 pairs: Sequence[PegHole], holder: Holder | None, dt: float,
                 part: Part | None = None, contact: Contact | None = None) -> None:  # fmt: skip
        n = len(deviation)
        self.robot = robot
        true = list(pairs) if len(pairs) == n else [pairs[0]] * n
        self.scenes = [MujocoPegHole(pair, holder, part, contact) for pair in true]
        self.substeps = round(dt / self.scenes[0].dt)
        if abs(self.substeps * self.scenes[0].dt - dt) > 1e-9 * dt:
            raise ConfigError("rate_hz", 1.0 / dt, f"a period that is a whole number of "
                              f"MuJoCo timesteps ({self.scenes[0].dt:g} s)")  # fmt: skip
        self.r_nominal = nominal.peg_radius
        self.r_true = np.array([p.peg_radius for p in true])
        self.acting = [p.acting_point_in_hole() for p in true]
        self.deviation = np.ascontiguousarray(deviation, dtype=float)
        self.unconverged = np.zeros(n)
        hand = self._hand()
        for scene, x in zip(self.scenes, hand, strict=True):
            scene.place(x)

    @classmethod
    def of(cls, sc: Any, robot: LaggingRobot, deviation: FloatArray,
           pairs: Sequence[PegHole]) -> MujocoPlant:  # fmt: skip
        """The plant of a scenario (:class:`~fbcc_ros.core.sim.scenario.Scenario`): its
        holder, its ``plant`` section's bore, timestep and contact time constant."""
        spec = sc.plant
        part = Part(facets=spec.facets, chamfer=spec.chamfer, rim=spec.rim)
        contact = Contact(timeconst=spec.timeconst, timestep=spec.timestep)
        return cls(robot, deviation, sc.geometry, pairs, sc.holder, 1.0 / sc.rate_hz, part,
                   contact)  # fmt: skip

    def _hand(self) -> FloatArray:
        """Where the robot's pose puts an undeflected peg in each true hole, (N, 5)."""
        x = np.empty(self.deviation.shape)
        true_rows(self.robot.pose, self.deviation, self.r_nominal, self.r_true, x)
        return x

    def sense(self) -> tuple[FloatArray, FloatArray]:
        hand = self._hand()
        features, response = np.empty_like(hand), np.empty_like(hand)
        for i, scene in enumerate(self.scenes):
            scene.set_hand(hand[i])
            scene.step(self.substeps)
            features[i] = scene.features()
            response[i] = response_from_wrench(scene.wrench_on_hole(), self.acting[i])
        return features, response

    def command(self, command: FloatArray) -> None:
        self.robot.command(command)
