"""The mock cell's stage: its parameters, and the plant they configure (ROS-free).

:class:`fbcc_ros.core.sim.mock_cell.MockCell` is the plant; this stage builds it from the
mock_cell node's parameters (the scenario, the rate, a drawn geometry, the seed, the fixture,
the cell's robot and hole) so that the node stays an adapter and a test can drive the same
configuration without ROS. Its one runtime parameter injects a sensor fault
(:mod:`fbcc_ros.core.sim.sensor_faults`).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.payload import Payload
from fbcc_ros.core.contact.mapping_study import perturbed
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.filters import LowPass
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.arm_sensing import (
    LBR_TORQUE_CUTOFF_HZ,
    estimated_wrench,
    measured_torques,
)
from fbcc_ros.core.sim.mock_cell import CellSample, MockCell
from fbcc_ros.core.sim.plants.spec import PLANTS
from fbcc_ros.core.sim.sensor_faults import SENSOR_FAULTS, Reading, SensorFault
from fbcc_ros.core.sim.wrist_sensor import WristSensor
from fbcc_ros.pipeline.compensation import payload_of, payload_params
from fbcc_ros.pipeline.kinematics import CELL, cell_from
from fbcc_ros.pipeline.parameters import Param

#: The hole fixture on the sensor: its mass [kg] (the default of ``fixture_mass``) and its centre
#: of mass in the sensor frame [m].
FIXTURE_MASS = 1.5
FIXTURE_COM = (0.0, 0.0, 0.02)

#: The wrist sensor's defaults: a parallel gripper holding the peg (0.8 kg, its centre of mass
#: 6 cm out along the flange's axis), a bias of the order a strain-gauge sensor drifts to, and
#: the noise of a 6-axis sensor of the ATI Gamma class at 1 kHz.
WRIST_PAYLOAD = (0.8, [0.004, -0.002, 0.06], [4e-3, 2e-4, 0.0, 2e-4, 3e-3, 0.0, 0.0, 0.0, 1.5e-3])
WRIST_BIAS = [1.5, -0.7, 3.0, 0.05, -0.02, 0.01]
WRIST_NOISE = [0.05, 0.05, 0.05, 0.002, 0.002, 0.002]

#: The robot stacks the mock can play (:mod:`fbcc_ros.core.kinematics.lbr_names`).
CONVENTIONS = ("fbcc", "lbr")
#: lbr_fri_ros2_stack's default robot_name: its joints are lbr_A1..A7.
LBR_NAME = "lbr"

TABLE = (
    Param("scenario", "config/scenarios/bringup_interference.yaml", "scenario YAML: the true "
          "deviation of the hole (initial), the sensor noise and bias, the robot lag"),
    Param("rate_hz", 0.0, "joint state and sensor rate; 0: the scenario's rate_hz", "Hz", 0.0,
          10000.0),
    Param("plant", "", "the contact between the hand and the hole: model (eq. 5-13) or mujoco "
          "(docs/plant.md); empty: the scenario's plant.type", choices=("", *PLANTS)),
    Param("publish_clock", False, "be the cell's clock: step the plant one period a tick, as "
          "fast as it can up to real time, stamp with the plant's time and publish it on "
          "/clock (the other nodes then run with use_sim_time); for a plant slower than real "
          "time (mujoco), which would otherwise skip periods"),
    Param("draw_geometry", False, "draw the true radii from Table II's tolerances"),
    Param("seed", -1, "seed of the noise and of the drawn geometry; -1: the scenario's seed", "",
          -1, 2**31 - 1),
    Param("sensor_frame", "ft_sensor", "frame_id of the raw readings"),
    Param("fixture_mass", FIXTURE_MASS, "mass of the hole fixture on the sensor", "kg", 0.0,
          100.0),
    Param("arm_sensing", False, "publish the arm's joint torques (effort of joint_states, "
          "external_joint_torques) and, with conventions lbr, its estimated wrench: what a "
          "virtual sensor or the LBR stack's estimate reads (a 1 kHz cell's spare time "
          "without)"),
    Param("torque_noise", 0.05, "white noise (1 sigma) on each external joint torque, as the "
          "arm's torque sensing adds it", "N m", 0.0, 100.0),
    Param("wrist_sensor", False, "also publish a 6-axis F/T sensor at the flange carrying the "
          "tool (wrist_sensor/raw, frame wrist_sensor): what fbcc-calibrate fits, and a wrist "
          "sensor's input to the compensation"),
    *payload_params("wrist_payload", *WRIST_PAYLOAD),
    Param("wrist_bias", WRIST_BIAS, "the wrist sensor's bias (fx, fy, fz, tx, ty, tz)",
          "N, N m"),
    Param("wrist_noise", WRIST_NOISE, "white noise (1 sigma) per component of the wrist sensor",
          "N, N m"),
    Param("conventions", "fbcc", "the robot stack the mock plays: fbcc (our names) or lbr "
          "(lbr_fri_ros2_stack's joint and link names, its forward position controller's "
          "command topic)", choices=CONVENTIONS),
    # transport settings (the node's)
    Param("sensor_qos", "reliable", "reliability of the F/T sensor's readings: best_effort as "
          "a driver publishing sensor-data QoS", choices=("reliable", "best_effort")),
    Param("publish_description", True, "latch the model's URDF on robot_description, as the "
          "robot stack's robot_state_publisher does"),
    Param("sensor_fault", "", "a sensor fault to rehearse, from the next reading on (empty: "
          "none; set it again to repeat it)", choices=("", *SENSOR_FAULTS), read_only=False),
    *CELL,
)  # fmt: skip



@dataclasses.dataclass(frozen=True)
class ArmReading:
    """The arm's own sensing at one tick: ``external`` and ``measured`` joint torques [N m],
    and the stack's ``estimated`` wrench at the flange (force, moment; flange axes) or None."""

    external: FloatArray
    measured: FloatArray
    estimated: FloatArray | None


class MockStage:
    """The plant of the mock_cell node, configured by its parameters (``TABLE``, resolved).

    Attributes:
        cell: The plant (``command`` a joint position, ``step`` one period).
        dt: Its period [s]: ``rate_hz``, or the scenario's rate when 0.
        frame: The frame_id of the raw readings.
    """

    def __init__(self, values: dict[str, Any], description: str | None = None) -> None:
        sc = scenario_io.load(scenario_io.find(values["scenario"]))
        if values["plant"]:
            sc = sc.on_plant(values["plant"])
        lbr = LBR_NAME if values["conventions"] == "lbr" else ""
        robot, hole = cell_from(values, description, lbr_name=lbr)
        seed = sc.seed if values["seed"] < 0 else values["seed"]
        geometry = None
        if values["draw_geometry"]:
            geometry = perturbed(sc.geometry, np.random.default_rng(seed),
                                 friction_spread=0.0, stiffness_octaves=0.0)  # fmt: skip
        fixture = Payload(values["fixture_mass"], FIXTURE_COM)
        self.dt = 1.0 / (values["rate_hz"] or sc.rate_hz)
        self.cell = MockCell(sc, robot, hole, geometry, fixture, seed, self.dt)
        self.frame: str = values["sensor_frame"]
        self.fault: SensorFault | None = None
        self.torque_noise = values["torque_noise"]
        # the LBR stack low-passes the torques it publishes (arm_sensing)
        self._torque_lowpass = LowPass(LBR_TORQUE_CUTOFF_HZ if lbr else 0.0)
        self._rng = np.random.default_rng(seed + 1)  # its own stream: the sensor's stays as is
        self.wrist = (WristSensor(robot, payload_of(values, "wrist_payload"),
                                  _six(values, "wrist_bias"), _six(values, "wrist_noise", 0.0),
                                  np.random.default_rng(seed + 2))
                      if values["wrist_sensor"] else None)  # fmt: skip
        self.apply(values)

    def apply(self, values: dict[str, Any]) -> None:
        """The runtime parameter: ``sensor_fault`` (``core.sim.sensor_faults``)."""
        name = values["sensor_fault"]
        self.fault = SensorFault(name, self.dt) if name else None

    def arm_sensing(self, sample: CellSample, estimate: bool) -> ArmReading:
        """The arm's own sensing of ``sample``, the last step (:mod:`fbcc_ros.core.sim.
        arm_sensing`): its external joint torques with their noise, the measured joint
        torques, and with ``estimate`` the stack's estimated wrench at the flange."""
        robot = self.cell.robot
        noise = self.torque_noise * self._rng.standard_normal(robot.nq)
        tau_ext = self._torque_lowpass(self.cell.external_torques() + noise, self.dt)
        measured = measured_torques(robot, sample.q, tau_ext)
        if not estimate:
            return ArmReading(tau_ext, measured, None)
        return ArmReading(tau_ext, measured,
                          estimated_wrench(robot, sample.q, tau_ext, robot.flange_frame))

    def wrist_reading(self, sample: CellSample) -> FloatArray | None:
        """The wrist sensor's reading of ``sample``, the last step, in {S} (the flange's axes),
        or None without one."""
        if self.wrist is None:
            return None
        base = self.cell.on_peg_at_flange()
        rotation = self.cell.robot.flange_in_base(sample.q).rotation
        on_peg = np.concatenate([rotation.T @ base[:3], rotation.T @ base[3:]])
        return self.wrist.reading(sample.q, sample.dq, self.dt, on_peg)

    def readings(self, stamp: float, raw: FloatArray) -> list[Reading]:
        """What the sensor delivers for the reading ``raw`` taken at ``stamp`` [s]: itself, or
        what the fault makes of it."""
        return self.fault.apply(stamp, raw) if self.fault else [(stamp, raw)]


def _six(values: dict[str, Any], name: str, low: float = -np.inf) -> FloatArray:
    """A (fx, fy, fz, tx, ty, tz) parameter: six finite numbers from ``low``, else a
    ConfigError."""
    out = np.asarray(values[name], dtype=float)
    if out.shape != (6,) or not np.isfinite(out).all() or (out < low).any():
        more = f" >= {low:g}" if low > -np.inf else ""
        raise ConfigError(name, values[name], f"six finite numbers{more} (fx, fy, fz, tx, ty, "
                          "tz)")  # fmt: skip
    return out
