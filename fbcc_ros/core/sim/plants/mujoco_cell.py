"""The cell in one MuJoCo model: the LBR (:mod:`.mujoco_arm`) carrying the peg in its grip at
its tool frame, over the faceted hole (:mod:`.mujoco_scene`) where the hole truly is.

* **The world is the true hole's frame {H}**, so that the peg's features and the wrench on the
  hole are read as the scene alone reads them; the arm's base sits at ``T_H_base`` and gravity
  points along the base's -z.
* **The arm** is our URDF's (the file Pinocchio reads): its joints are position servos of the
  LBR's stiffness, gravity-compensated, and its links touch nothing. The peg's weight is
  compensated too, as the LBR's controller does with the tool's load data (left on the arm,
  it bent the joints by 3e-5 rad: 11 µm at the peg).
* **The peg** hangs from the flange at the tool frame {P} of the cell's :class:`~fbcc_ros.
  core.kinematics.robot.RobotModel`, in the grip of :func:`~.mujoco_scene.peg_xml`: six joints
  at its grip point, each a servo holding it undeflected (their targets stay 0); the grip's
  slides and hinges are along the tool's axes.
* **Each timestep** the contact and the grip act on the arm and the arm on them: the compliance
  of the joints and of the grip are both in the loop, as on a real LBR, and the arm's joint
  positions are what its servos reach under the load, not a lag of the command.

What is read each control period: the joints, the peg's true features, the wrench on the hole
(its mean over the period, :meth:`~.mujoco_scene.MujocoPegHole.mean_wrench_on_hole`) and the
external joint torques (the mean constraint force at the arm's joints: what the contact does
to the arm). Test: ``test/core/sim/test_mujoco_cell.py``.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import pinocchio as pin

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.wrench import response_from_wrench
from fbcc_ros.core.contact.features import R_ALIGNED
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.kinematics.robot import RobotModel
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.plants.mujoco import scene_of
from fbcc_ros.core.sim.plants.mujoco_arm import arm_spec
from fbcc_ros.core.sim.plants.mujoco_scene import (
    Contact,
    MujocoPegHole,
    Part,
    contact_defaults,
    peg_xml,
    quaternion,
    scene_xml,
)

GRAVITY = 9.81  # [m/s^2], along the base's -z
#: The prefix of the arm's names in the model (our URDFs have a link named ``peg``: the tool).
ARM = "arm/"


def cell_model(robot: RobotModel, hole_in_base: pin.SE3, pair: PegHole, holder: Holder | None,
               part: Part, contact: Contact) -> mujoco.MjModel:  # fmt: skip
    """The model of the module doc, for the hole truly at ``hole_in_base`` (``T_base_H``)."""
    scene = mujoco.MjSpec.from_string(scene_xml(pair, holder, part, contact, peg=False))
    scene.option.gravity = hole_in_base.rotation.T @ np.array([0.0, 0.0, -GRAVITY])
    base = hole_in_base.inverse()  # T_H_base
    arm = arm_spec(robot.urdf_text)
    mount = scene.worldbody.add_frame(pos=base.translation, quat=quaternion(base.rotation))
    mount.attach_body(arm.worldbody.first_body(), ARM, "")
    flange = scene.body(ARM + robot.flange_frame)
    if flange is None:
        raise ConfigError("flange_frame", robot.flange_frame, "a link of the URDF MuJoCo reads")
    # the peg body's frame in {P}: its origin the grip point, its z from the tip up the peg
    body, servos = peg_xml(pair, holder, part)
    peg = mujoco.MjSpec.from_string(
        f'<mujoco><compiler angle="radian"/>{contact_defaults(pair, contact)}'
        f"<worldbody>{body}</worldbody><actuator>{servos}</actuator></mujoco>")
    in_flange = robot.peg_in_flange() * pin.SE3(R_ALIGNED, R_ALIGNED @ [0.0, 0.0, part.grip])
    tool = flange.add_frame(pos=in_flange.translation, quat=quaternion(in_flange.rotation))
    tool.attach_body(peg.body("peg"), "", "")
    # the peg's weight compensated too, as the LBR's controller does with its load data
    scene.body("peg").gravcomp = 1.0
    return scene.compile()


class MujocoCell:
    """The cell of the module doc, stepped a control period at a time.

    Args:
        robot: The arm (its URDF, flange and tool frame).
        hole_in_base: Where the hole truly is, ``T_base_H``.
        q: The joints at the start [rad]: the arm at rest there, commanded there, the peg
            undeflected in its grip.
        pair: The true peg and hole.
        holder: The grip (None: the scene's stiffest).
        part, contact: The bore and MuJoCo's contact (:mod:`.mujoco_scene`).
        dt: The control period [s], a whole number of timesteps.
    """

    def __init__(self, robot: RobotModel, hole_in_base: pin.SE3, q: FloatArray, pair: PegHole,
                 holder: Holder | None, part: Part, contact: Contact,
                 dt: float) -> None:  # fmt: skip
        model = cell_model(robot, hole_in_base, pair, holder, part, contact)
        self.scene = MujocoPegHole(pair, holder, part, contact, model=model)
        self.dt = dt
        self.substeps = round(dt / self.scene.dt)
        if self.substeps < 1 or abs(self.substeps * self.scene.dt - dt) > 1e-9 * dt:
            raise ConfigError("rate_hz", 1.0 / dt, f"a period that is a whole number of "
                              f"MuJoCo timesteps ({self.scene.dt:g} s)")  # fmt: skip
        joints = [model.joint(ARM + name) for name in robot.joint_names]
        self._qpos = np.array([j.qposadr[0] for j in joints])
        self._dofs = np.array([j.dofadr[0] for j in joints])
        self._servos = np.array([model.actuator(ARM + name).id for name in robot.joint_names])
        self.acting = pair.acting_point_in_hole()
        d = self.scene.data
        d.qpos[self._qpos] = q
        d.ctrl[self._servos] = q
        mujoco.mj_forward(model, d)

    @classmethod
    def of(cls, sc: Any, robot: RobotModel, hole_in_base: pin.SE3, q: FloatArray,
           pair: PegHole, dt: float) -> MujocoCell:  # fmt: skip
        """The cell of a scenario (:class:`~fbcc_ros.core.sim.scenario.Scenario`): its holder,
        its ``plant`` section's scene (:func:`~.mujoco.scene_of`)."""
        return cls(robot, hole_in_base, q, pair, sc.holder, *scene_of(sc), dt)

    def command(self, q: FloatArray) -> None:
        """The joint positions the servos hold [rad]."""
        self.scene.data.ctrl[self._servos] = q

    def step(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """One control period: the joints [rad] at its end, the peg's true features and the
        contact's response (Fx, Fy, Fz, Mx, My) about the pair's acting point, its mean."""
        self.scene.step(self.substeps)
        response = response_from_wrench(self.scene.mean_wrench_on_hole(), self.acting)
        return self.scene.data.qpos[self._qpos].copy(), self.scene.features(), response

    def external_torques(self) -> FloatArray:
        """What the contact did to the arm's joints over the last period, its mean [N·m]: the
        constraint forces at the arm's joints (``J^T`` of the hole's wrench on the peg)."""
        return self.scene.period_constraint_force()[self._dofs]
