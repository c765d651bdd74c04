"""The LBR in MuJoCo: an arm whose kinematics and inertials are our URDF's (``fbcc_ros/urdf``,
the same file Pinocchio reads), each joint a position servo as the LBR is in position mode, its
links' weight compensated as the LBR's controller does.

* **The model** is compiled from the URDF text itself (MuJoCo reads URDF), its fixed frames
  kept as bodies (``fusestatic`` off), so that the flange and the tool frame are there by name.
  Nothing is downloaded: no meshes, no menagerie.
* **The servos** are a spring :data:`JOINT_STIFFNESS` and a damper :data:`JOINT_DAMPING` to the
  commanded position, per joint. KUKA publishes no position-mode stiffness: the spring is the
  package's one estimate of the LBR's joint stiffness (:data:`~fbcc_ros.core.sim.holder.
  LBR_JOINT_STIFFNESS`, 1e4 N·m/rad: harmonic drive and torque sensor in series), the damper
  MuJoCo Menagerie's ``kuka_iiwa_14`` (200 N·m·s/rad).
* **Gravity** acts on every link and is compensated on each (``gravcomp``): the LBR's
  controller adds the model's gravity torques to its command, so the servos hold a pose without
  a sag of tau_g / k (without it, 6 mrad at the shoulder of an iiwa 14 bent at the elbow).

The mock cell's MuJoCo arm carries the peg over the hole (:mod:`.mujoco_cell`). Tests:
``test/core/sim/test_mujoco_arm.py`` (the flange where Pinocchio puts it, a pose held under
gravity, a commanded step followed).
"""

from __future__ import annotations

import mujoco

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.sim.holder import LBR_JOINT_STIFFNESS

#: Each joint's servo: stiffness [N·m/rad] and damping [N·m·s/rad] (module doc).
JOINT_STIFFNESS, JOINT_DAMPING = LBR_JOINT_STIFFNESS, 200.0
#: The arm's timestep [s] alone (its damping is integrated implicitly: a step settles to 1e-12
#: at 1 ms as at 0.2 ms).
ARM_TIMESTEP = 1.0e-3
_KEEP_FRAMES = '<mujoco><compiler fusestatic="false" discardvisual="true"/></mujoco>'


def arm_model(urdf_text: str, timestep: float = ARM_TIMESTEP) -> mujoco.MjModel:
    """The arm of this URDF (module doc), compiled."""
    spec = arm_spec(urdf_text)
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    return spec.compile()


def arm_spec(urdf_text: str) -> mujoco.MjSpec:
    """The arm of this URDF (module doc): servos on every revolute joint, in the URDF's order,
    its links' weight compensated; its links touch nothing (the URDFs carry no collision
    shapes)."""
    head, sep, rest = urdf_text.partition("<robot")
    if not sep:
        raise ValueError("not a URDF: no <robot> element")
    close = rest.index(">") + 1
    spec = mujoco.MjSpec.from_string(head + sep + rest[:close] + _KEEP_FRAMES + rest[close:])
    for body in spec.bodies[1:]:
        body.gravcomp = 1.0
    for joint in spec.joints:
        servo = spec.add_actuator()
        servo.name, servo.target = joint.name, joint.name
        servo.trntype = mujoco.mjtTrn.mjTRN_JOINT
        servo.set_to_position(kp=JOINT_STIFFNESS, kv=JOINT_DAMPING)
    for geom in spec.geoms:
        geom.contype = geom.conaffinity = 0
    return spec


class MujocoArm:
    """The arm, stepped: command joint positions, step, read the joints and a frame's pose.

    Args:
        urdf_text: The URDF (a ``robot_description``).
        q: The joints at the start [rad], at rest and commanded there.
    """

    def __init__(self, urdf_text: str, q: FloatArray) -> None:
        self.model = arm_model(urdf_text)
        self.data = mujoco.MjData(self.model)
        self.joint_names = [self.model.joint(i).name for i in range(self.model.njnt)]
        self.data.qpos[:] = q
        self.data.ctrl[:] = q
        mujoco.mj_forward(self.model, self.data)

    def command(self, q: FloatArray) -> None:
        self.data.ctrl[:] = q

    def step(self, n: int = 1) -> None:
        mujoco.mj_step(self.model, self.data, nstep=n)

    @property
    def q(self) -> FloatArray:
        return self.data.qpos.copy()

    def frame(self, name: str) -> tuple[FloatArray, FloatArray]:
        """The body ``name``'s (a URDF link's) rotation (3, 3) and position (3,) in the base."""
        body = self.model.body(name).id
        return self.data.xmat[body].reshape(3, 3).copy(), self.data.xpos[body].copy()
