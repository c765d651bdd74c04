"""The nodes of a cell and their parameters, for the robot stack they run beside: one
description for ``launch/fbcc_cell.launch.py``, ``fbcc_bringup`` (the hardware-free rehearsal)
and the tests, which build the same node set from it without launch.

A node's parameters are, in the order rcl applies them: its ``config/<node>.yaml`` (every
default), the profile's file (``config/profiles/<profile>.yaml``: what the stack's interfaces
need), the user's own file, then the values computed here (the mock's scenario, the hole under a
built-in model's home for a rehearsal, the rate, the wrench source).

Profiles:

* ``fbcc``: our own topics, the mock's names (the defaults);
* ``lbr``: beside lbr_fri_ros2_stack in ``/lbr``: the model from ``robot_description``, its
  forward position controller, its estimated wrench at ``lbr_link_ee``, 100 Hz;
* ``ros2_control``: beside any ros2_control arm with a forward position controller and a
  best-effort wrist F/T sensor.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pinocchio as pin

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.kinematics.cell import aligned_hole_at
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel
from fbcc_ros.core.param_files import file_parameters
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.plants.spec import PLANTS
from fbcc_ros.core.sim.scenario import CONVENTIONS, SOURCES

PROFILES = ("fbcc", "lbr", "ros2_control")
#: The nodes of a cell, in the order they start (the mock first: it latches the model).
NODES = ("mock_cell", "dynamic_compensation", "kinematics", "fbcc_controller")
#: The plants slower than real time in contact (docs/plant.md, Speed): a mock on one is the
#: cell's clock (mock_cell's ``publish_clock``), so that the loop closes at every period.
PLANT_CLOCKS = ("mujoco",)
#: The compensation averages this long of readings into its bias at start (a rehearsal; the
#: profiles for a real cell take a second).
TARE_SECONDS = 0.2


#: The compensation's parameters for each wrench source (scenario ``sensor.source``).
SOURCE_PARAMETERS: dict[str, dict[str, Any]] = {
    "ft_sensor": {"placement": "under_hole", "sensor_frame": "ft_sensor",
                  "wrench_topic": "ft_sensor/raw"},
    # the LBR stack's estimate at its flange, from KUKA's external torques
    "estimated": {"placement": "wrist", "sensor_xyz": [0.0, 0.0, 0.0],
                  "wrench_topic": "force_torque_broadcaster/wrench"},
    # our virtual sensor at the flange
    "external_torques": {"placement": "wrist", "sensor_xyz": [0.0, 0.0, 0.0],
                         "virtual_sensor": True, "joint_torques": "external"},
    "measured_torques": {"placement": "wrist", "sensor_xyz": [0.0, 0.0, 0.0],
                         "virtual_sensor": True, "joint_torques": "measured"},
}  # fmt: skip


@dataclasses.dataclass(frozen=True)
class CellSetup:
    """What a cell is started with (the launch file's arguments).

    Attributes:
        profile: One of :data:`PROFILES`.
        scenario: The mock's scenario file (with ``mock``); its ``robot`` and ``sensor``
            sections say what the mock plays (model, rate, wrench source, F/T sensor QoS).
        mock: Whether the hardware-free mock plays the robot and its sensors.
        law: fbcc | admittance | none (empty: the scenario's).
        namespace: Where the cell's nodes run ('' or /name).
        params_file: The user's own parameter file (their hole, tool, sensor, payload).
        model: A built-in model for the mock and, where they use a built-in one, for our nodes
            (not beside a stack's robot_description); empty: the scenario's ``robot.model``.
        plant: The mock's contact, model or mujoco (empty: the scenario's ``plant.type``).
    """

    profile: str = "fbcc"
    scenario: str = "config/scenarios/bringup_interference.yaml"
    mock: bool = True
    law: str = ""
    namespace: str = ""
    params_file: str = ""
    model: str = ""
    plant: str = ""


@dataclasses.dataclass(frozen=True)
class NodeConfig:
    """One node: its executable (``fbcc_ros.nodes.<name>``, also its node name), the parameter
    files it reads in order, and the values set after them."""

    name: str
    files: tuple[Path, ...]
    parameters: dict[str, Any]

    def merged(self) -> dict[str, Any]:
        """All its parameters, as rcl would apply the files and then the values."""
        return {**file_parameters(self.files, self.name), **self.parameters}


def config_dir() -> Path:
    """``config/`` of the source checkout, or of the installed package's share."""
    here = Path(__file__).resolve().parents[2] / "config"
    if here.is_dir():
        return here
    from ament_index_python.packages import get_package_share_directory

    return Path(get_package_share_directory("fbcc_ros")) / "config"


def profile_of(conventions: str) -> str:
    """The profile our nodes use beside the stack a scenario's mock plays."""
    return "lbr" if conventions == "lbr" else "fbcc"


def cell_nodes(setup: CellSetup) -> list[NodeConfig]:
    """The cell's nodes and their parameters (module doc)."""
    if setup.profile not in PROFILES:
        raise ConfigError("profile", setup.profile, f"one of {list(PROFILES)}")
    if setup.plant and setup.plant not in PLANTS:
        raise ConfigError("plant", setup.plant, f"one of {list(PLANTS)} (empty: the scenario's "
                          "plant.type)")  # fmt: skip
    if setup.model and setup.model not in ROBOTS:
        raise ConfigError("model", setup.model, f"one of {sorted(ROBOTS)} (empty: the "
                          "scenario's robot.model)")  # fmt: skip
    path = str(scenario_io.find(setup.scenario))
    sc = scenario_io.load(path)
    cell = sc.cell
    if setup.mock and profile_of(cell.conventions) != setup.profile:
        raise ConfigError("profile", setup.profile, f"'{profile_of(cell.conventions)}' with "
                          f"the scenario's robot.conventions '{cell.conventions}' (the stack "
                          "the mock plays)")  # fmt: skip
    if not setup.mock and not setup.params_file and setup.profile != "fbcc":
        raise ConfigError("params_file", "", "your cell's parameter file (the hole's measured "
                          "pose, the tool, the sensor) beside a real robot")  # fmt: skip
    config = config_dir()
    profile = () if setup.profile == "fbcc" else (config / "profiles" / f"{setup.profile}.yaml",)
    user = (Path(setup.params_file),) if setup.params_file else ()
    computed = _rehearsal(sc, path, setup) if setup.mock else {}
    law = {"law": setup.law} if setup.law else {}
    names = NODES if setup.mock else NODES[1:]
    nodes = [NodeConfig(name, (config / f"{name}.yaml", *profile, *user),
                        {**computed.get(name, {}), **(law if name == "fbcc_controller" else {})})
             for name in names]  # fmt: skip
    if setup.model and not setup.mock:  # the rehearsal's values hold it already
        for node in nodes:  # where a built-in model is used (not a stack's description)
            if node.merged().get("robot") in ROBOTS:
                node.parameters["robot"] = setup.model
    return nodes


def on_plant_clock(sc: scenario_io.Scenario, plant: str = "") -> bool:
    """Whether a mock of ``sc`` on ``plant`` (empty: the scenario's) is the cell's clock
    (:data:`PLANT_CLOCKS`)."""
    return (plant or sc.plant.type) in PLANT_CLOCKS


def deadband_warnings(nodes: list[NodeConfig]) -> list[str]:
    """What the dead bands in the wrench's path hide, before a run
    (:func:`~fbcc_ros.pipeline.lateral_watch.deadband_warning`): ours (``deadband``), and the
    LBR stack's estimate's when the compensation reads it (its default band: the stack's
    ``lbr_system_config.yaml``)."""
    from fbcc_ros.core.sim.arm_sensing import LBR_DEADBAND
    from fbcc_ros.pipeline.lateral_watch import deadband_warning
    from fbcc_ros.ros.topics import LBR_WRENCH

    merged = {node.name: node.merged() for node in nodes}
    comp = merged["dynamic_compensation"]
    scenario = merged["fbcc_controller"].get("scenario", "")
    radius = scenario_io.load(scenario_io.find(scenario)).geometry.peg_radius
    said = [deadband_warning(tuple(comp["deadband"]), radius, "dynamic_compensation "
                             "(deadband)")]  # fmt: skip
    if not comp["virtual_sensor"] and comp["wrench_topic"].strip("/").endswith(LBR_WRENCH):
        said.append(deadband_warning((LBR_DEADBAND[0], LBR_DEADBAND[3]), radius,
                                     f"the LBR stack's estimated wrench ({LBR_WRENCH}, its "
                                     "default force_x_th and torque_x_th)"))  # fmt: skip
    return [s for s in said if s]


def _rehearsal(sc: scenario_io.Scenario, path: str, setup: CellSetup
               ) -> dict[str, dict[str, Any]]:  # fmt: skip
    """The values a hardware-free run sets: the mock's scenario and the stack it plays, the
    hole under the model's home (a real cell measures it), the rate, the wrench source, and
    the clock: on a plant slower than real time (:data:`PLANT_CLOCKS`) the mock is the cell's
    clock and every other node reads it (``use_sim_time``)."""
    from fbcc_ros.pipeline.mock_cell import FIXTURE_COM, FIXTURE_MASS, LBR_NAME

    cell = sc.cell
    lbr = cell.conventions == "lbr"
    model_name = setup.model or cell.model
    model = RobotModel.from_name(model_name, lbr_name=LBR_NAME if lbr else "")
    hole = aligned_hole_at(model.peg_in_base(model.home))
    where = {"hole_from_home": False, "hole_xyz": hole.translation.tolist(),
             "hole_rpy": pin.rpy.matrixToRpy(hole.rotation).tolist()}  # fmt: skip
    robot = {"robot": "robot_description"} if lbr else {"robot": model_name}
    rate = {"rate_hz": sc.rate_hz}
    tare = {"tare_samples": max(1, round(TARE_SECONDS * sc.rate_hz))}
    compensation: dict[str, Any] = {**robot, **where, **tare, "wrench_qos": cell.qos,
                                    "virtual_sensor": False, **SOURCE_PARAMETERS[cell.source]}
    if cell.source == "ft_sensor":  # under the hole, carrying the mock's fixture
        compensation.update(sensor_xyz=sc.geometry.acting_point_in_hole().tolist(),
                            **{"payload.mass": FIXTURE_MASS, "payload.com": list(FIXTURE_COM)})
    if cell.source == "estimated":
        compensation["sensor_frame"] = model.flange_frame  # lbr_link_ee
    sim_time = {"use_sim_time": True} if on_plant_clock(sc, setup.plant) else {}
    return {
        "mock_cell": {"scenario": path, "robot": model_name, "conventions": cell.conventions,
                      "sensor_qos": cell.qos, "arm_sensing": cell.source != "ft_sensor",
                      **rate, **({"plant": setup.plant} if setup.plant else {}),
                      **({"publish_clock": True} if sim_time else {})},
        "dynamic_compensation": {**compensation, **sim_time},
        "kinematics": {**robot, **where, **rate, **sim_time},
        "fbcc_controller": {"scenario": path, **rate, **sim_time},
    }


__all__ = ["CONVENTIONS", "PROFILES", "SOURCES", "CellSetup", "NodeConfig", "cell_nodes",
           "deadband_warnings", "on_plant_clock"]
