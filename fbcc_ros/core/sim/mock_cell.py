"""The hardware-free cell: a position-controlled arm and a force/torque sensor under the true hole.

This is the plant of :mod:`fbcc_ros.core.sim.simulation` in joint space, for the mock nodes:

* **the hole** is where the cell's configuration says (``hole_in_base``, what the controller
  believes) displaced by the scenario's unknown deviation ``x_dev``: the true hole is placed so
  that a peg at the believed features 0 has the true features ``x_dev``,
  ``T_base_Htrue = T_base_H P(0) P(x_dev)^-1`` with ``P(x)`` the peg pose of features x;
* **the arm and the contact** are the scenario's plant (``plant.type``), with the true
  geometry (it may differ from the nominal one the controller knows: Table II tolerances):

  - ``model``: the arm follows its joint command with the first-order lag of the scenario
    (``q += (1 - exp(-dt/tau)) (q_cmd - q)``), clipped to its position and velocity limits,
    and the hand where its joints put it drives eq. 5-13 with the holder
    (:mod:`fbcc_ros.core.sim.plants`);
  - ``mujoco``: the LBR in MuJoCo carries the peg in its grip over MuJoCo's hole, one model
    (:mod:`fbcc_ros.core.sim.plants.mujoco_cell`): the joints are where its servos get under
    the contact's load (the scenario's lag and the velocity clip do not apply: the servos
    follow any command within the URDF's limits, which MuJoCo enforces), and the external
    joint torques are MuJoCo's;

  a command reaches the arm the scenario's ``robot.delay`` after it was given;
* **the sensor** sits under the true hole at its acting point, axes as the hole's, and carries a
  fixture; it reads the contact wrench, the fixture's weight, the bias and white noise (the
  scenario's ``sensor`` values, given in response space).

The true features and responses of every step are returned so that a run can be scored exactly
as the simulator scores it.
"""

from __future__ import annotations

import collections
import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.payload import Motion, Payload, payload_wrench
from fbcc_ros.core.compensation.wrench import transfer_matrix, wrench_from_response
from fbcc_ros.core.contact.features import pose_from_features
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import InputError
from fbcc_ros.core.kinematics.cell import CellKinematics
from fbcc_ros.core.kinematics.ik import solve_ik
from fbcc_ros.core.kinematics.robot import RobotModel
from fbcc_ros.core.sim.arm_sensing import external_torques, wrench_at_frame
from fbcc_ros.core.sim.plants.plant import Contact
from fbcc_ros.core.sim.scenario import Scenario
from fbcc_ros.core.sim.simulation import scenario_contact

if TYPE_CHECKING:
    from fbcc_ros.core.sim.plants.mujoco_cell import MujocoCell

#: The hole fixture on the mock sensor: 1.5 kg, its centre of mass 2 cm above the sensor.
DEFAULT_FIXTURE = Payload(1.5, (0.0, 0.0, 0.02))


@dataclasses.dataclass(frozen=True)
class CellSample:
    """One step of the cell: joints, the raw sensor reading in {S}, and the truth.

    Attributes:
        q, dq: Joint positions [rad] and velocities [rad/s].
        raw: The sensor's reading ``(fx, fy, fz, tx, ty, tz)`` in {S} [N, N m].
        features: True features (depth clipped at 0 for the contact).
        response: True response (Fx, Fy, Fz, Mx, My) at the true hole's acting point.
    """

    q: FloatArray
    dq: FloatArray
    raw: FloatArray
    features: FloatArray
    response: FloatArray


def _peg_pose(features: ArrayLike, peg_radius: float) -> pin.SE3:
    rotation, position = pose_from_features(features, peg_radius)
    return pin.SE3(rotation, position)


class MockCell:
    """The plant, stepped by the mock nodes; see the module doc.

    Args:
        sc: Scenario: deviation, noise, bias, robot lag, nominal geometry.
        robot: The arm.
        hole_in_base: Where the controller believes the hole is, ``T_base_H``.
        geometry: True geometry of the pair (default: the scenario's nominal one).
        fixture: What the sensor under the hole carries.
        seed: Of the sensor noise (default: the scenario's).
        dt: The period the cell is stepped at [s] (default: the scenario's rate): MuJoCo's
            contact runs whole periods.
    """

    def __init__(
        self,
        sc: Scenario,
        robot: RobotModel,
        hole_in_base: pin.SE3,
        geometry: PegHole | None = None,
        fixture: Payload = DEFAULT_FIXTURE,
        seed: int | None = None,
        dt: float | None = None,
    ) -> None:
        self.sc = sc
        self.robot = robot
        self.geometry = geometry or sc.geometry
        r = sc.geometry.peg_radius
        self.believed = CellKinematics(robot, hole_in_base, r)
        deviation = sc.initial.copy()
        deviation[2] = 0.0
        true_hole = hole_in_base * _peg_pose(np.zeros(5), r) * _peg_pose(deviation, r).inverse()
        self.truth = CellKinematics(robot, true_hole, self.geometry.peg_radius)
        # the arm starts with the peg at the believed features 0: over the hole, tip at its top
        self.q = solve_ik(robot, self.believed.peg_target(np.zeros(5), 0.0), robot.home).q
        self.q_cmd = self.q.copy()
        #: the arm and the contact in MuJoCo (module doc), or None: the lagging arm and
        #: ``contact``
        self.mujoco: MujocoCell | None = None
        self.contact: Contact | None = None
        if sc.plant.type == "mujoco":
            from fbcc_ros.core.sim.plants.mujoco_cell import MujocoCell

            self.mujoco = MujocoCell.of(sc, robot, true_hole, self.q, self.geometry,
                                        dt or 1.0 / sc.rate_hz)  # fmt: skip
        else:
            self.contact = scenario_contact(sc, 1, [self.geometry], dt)
        #: the cell's time [s] and the commands given, not yet at the arm (robot.delay)
        self.t = 0.0
        self._late: collections.deque[tuple[float, FloatArray]] = collections.deque()
        self.fixture = fixture
        self._acting = pin.SE3(np.eye(3), self.geometry.acting_point_in_hole())
        #: the largest true contact |f| [N] and |m| about the true {H} origin [N·m] so far, as
        #: the wrench guard measures them (it sees only the samples its loop takes)
        self.peak = np.zeros(2)
        #: the largest step between two successive joint commands (the first from where the
        #: arm starts), as the time it takes at the joints' velocity limits [s]: a
        #: position-controlled arm applies each command within a cycle, however large
        self.largest_step = 0.0
        self._last_command = self.q.copy()
        self._to_origin = transfer_matrix(self._acting)
        self.sensor_in_hole = self._acting  # at the acting point, axes as the true hole's
        # the peg's wrench on the hole at the acting point, read in {S}: T_S_A = T_S_H T_H_A
        self._to_sensor = transfer_matrix(self.sensor_in_hole.actInv(self._acting))
        self._weight = payload_wrench(fixture, Motion.at_rest(true_hole.rotation))
        self._bias = wrench_from_response(sc.bias)
        self._noise = np.append(sc.noise, 0.0)  # no noise figure for mz
        self._rng = np.random.default_rng(sc.seed if seed is None else seed)
        self._alpha: dict[float, float] = {}
        self._on_hole = np.zeros(6)  # the last step's wrench on the true hole, about its origin

    def preload(self) -> None:
        """Load the compiled contact kernel and IK step now, before the nodes freeze the heap
        (loaded in the loop, the kernel left ~47k objects for the collector to walk: full
        collections of ~8 ms)."""
        self.geometry.response(np.zeros(5))
        self.truth.preload()

    def command(self, q_cmd: ArrayLike) -> None:
        """A new joint position command; refused (InputError) if malformed or beyond a limit."""
        q = self.robot.check_joints(q_cmd, "joint_command")
        if not self.robot.within_limits(q):
            raise InputError(
                "joint_command", q.tolist(), f"positions within the limits of {self.robot.name}"
            )
        step = float(np.max(np.abs(q - self._last_command) / self.robot.velocity_limit))
        self.largest_step, self._last_command = max(self.largest_step, step), q
        self._late.append((self.t, q))

    def step(self, dt: float) -> CellSample:
        """Advance the arm by dt [s] toward its command and read the sensor."""
        # the latest command given at least robot.delay ago reaches the arm
        while self._late and self._late[0][0] <= self.t - self.sc.delay + 1e-9:
            self.q_cmd = self._late.popleft()[1]
        self.t += dt
        q_prev = self.q
        if self.mujoco is not None:
            if abs(dt - self.mujoco.dt) > 1e-9 * dt:
                raise InputError("dt", dt, f"the MuJoCo cell's period, {self.mujoco.dt:g} s")
            self.mujoco.command(self.q_cmd)
            self.q, x, response = self.mujoco.step()
        else:
            assert self.contact is not None
            alpha = self._alpha.get(dt)
            if alpha is None:
                lag = self.sc.lag
                alpha = self._alpha[dt] = 1.0 - math.exp(-dt / lag) if lag > 0 else 1.0
            # q += (1 - exp(-dt/tau)) (q_cmd - q), within the velocity and position limits
            reach = self.robot.velocity_limit * dt
            step = (alpha * (self.q_cmd - q_prev)).clip(-reach, reach)
            self.q = (q_prev + step).clip(self.robot.lower, self.robot.upper)
            features, responses = self.contact.touch(self.truth.features(self.q)[None])
            x, response = features[0], responses[0]
        x[2] = max(x[2], 0.0)  # above the hole: no contact
        at_acting = wrench_from_response(response)
        at_origin = self._to_origin @ at_acting  # tau_O = tau_A + p_A x f
        self.peak = np.maximum(self.peak, (np.linalg.norm(at_origin[:3]),
                                           np.linalg.norm(at_origin[3:])))  # fmt: skip
        contact = self._to_sensor @ at_acting
        noise = self._noise * self._rng.standard_normal(6)
        raw = contact + self._weight + self._bias + noise
        self._on_hole = at_origin
        return CellSample(self.q.copy(), (self.q - q_prev) / dt, raw, x, response)

    def on_peg_at_flange(self) -> FloatArray:
        """The hole's wrench on the peg in the last step, at the flange's origin, in base axes
        (``-w`` of the wrench on the hole, moved) [N, N m]."""
        if not self._on_hole.any():
            return np.zeros(6)
        flange = self.robot.flange_in_base(self.q)
        return wrench_at_frame(-self._on_hole, self.truth.hole_in_base, flange)

    def external_torques(self) -> FloatArray:
        """The external joint torques the contact of the last step causes, ``J^T w`` (the
        arm's own sensing: :mod:`fbcc_ros.core.sim.arm_sensing`), MuJoCo's in its cell
        [N m]."""
        if self.mujoco is not None:
            return self.mujoco.external_torques()
        if not self._on_hole.any():
            return np.zeros(self.robot.nq)
        return external_torques(self.robot, self.q, self.robot.flange_frame,
                                self.on_peg_at_flange())  # fmt: skip
