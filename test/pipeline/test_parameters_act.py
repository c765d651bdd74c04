"""Every parameter of every stage changes what the stage puts out.

Generated from the stages' tables: each stage is driven by the committed bag's inputs (the
cell's raw wrenches and joint states, the features, compensated wrenches and commands the live
nodes exchanged) with its defaults, and again with one parameter changed; what it puts out
(outputs, refusals, counters, phases) must differ. A parameter that is read and ignored fails
here. Some parameters act only in a mode (a wrist sensor's tool, the robust law's estimate
rate): ``CONTEXT`` sets that mode for both runs; some act only past a bound the recorded
session stays within (the step clip): ``CHANGED`` picks a value past it.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from fbcc_ros.bag.reader import read_bag
from fbcc_ros.core.errors import FbccError
from fbcc_ros.core.kinematics.cell import aligned_hole_at
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel
from fbcc_ros.pipeline import compensation, controller, kinematics, mock_cell
from fbcc_ros.pipeline.parameters import Param, resolve
from fbcc_ros.ros.convert import (
    joints_from_cdr,
    pose_from_cdr,
    positions_from_cdr,
    wrench_from_cdr,
)

ROOT = Path(__file__).resolve().parents[2]
BAG = read_bag(ROOT / "test" / "data" / "bags" / "short_interference")
JOINTS = ("iiwa_joint_1", "iiwa_joint_2", "iiwa_joint_3", "iiwa_joint_4", "iiwa_joint_5",
          "iiwa_joint_6", "iiwa_joint_7")  # fmt: skip
ROBUST = str(ROOT / "config" / "scenarios" / "robust_interference.yaml")
#: A wrist sensor reading the recorded under-hole wrenches (no tare: it would take the hole's
#: load on a sensor that never carried it, and be refused).
WRIST = {"placement": "wrist", "tare_samples": 0, "sensor_xyz": [0.0, 0.0, 0.03],
         "payload.mass": 0.8,
         "payload.com": [0.0, 0.01, 0.05],
         "payload.inertia": [2e-3, 0, 0, 0, 2e-3, 0, 0, 0, 1e-3]}  # fmt: skip
HOLE = {"hole_xyz": [0.575, 0.0, 0.336], "hole_rpy": [0.0, 0.0, math.pi]}
#: A model from a URDF file: the iiwa14's, with the hole placed explicitly (no home of ours).
URDF = {"robot": "urdf_file", "urdf_file": str(ROBOTS["iiwa14"]().urdf), "hole_from_home": False,
        **HOLE}  # fmt: skip
#: The same arm, its flange 2 mm further out: another URDF the recorded commands still fit.
LONGER = Path(tempfile.mkdtemp(prefix="fbcc_urdf_")) / "iiwa14_longer.urdf"
_FLANGE = '<child link="iiwa_flange"/>\n    <origin xyz="0 0 0.04'
assert _FLANGE in Path(URDF["urdf_file"]).read_text()
LONGER.write_text(Path(URDF["urdf_file"]).read_text().replace(f"{_FLANGE}5", f"{_FLANGE}7"))
#: The Panda's URDF names its fingers' joints too.
_PANDA_HOLE = aligned_hole_at(RobotModel.from_name("panda").peg_in_base(ROBOTS["panda"]().home))
PANDA = {**URDF, "urdf_file": str(ROBOTS["panda"]().urdf), "flange_frame": "panda_link8",
         "locked_joints": ["panda_finger_joint1", "panda_finger_joint2"],
         "hole_xyz": _PANDA_HOLE.translation.tolist(),
         "hole_rpy": pin.rpy.matrixToRpy(_PANDA_HOLE.rotation).tolist()}  # fmt: skip
#: The mode in which a parameter acts, set for both runs (``node.name`` before ``name``).
CONTEXT: dict[str, dict[str, Any]] = {
    "urdf_file": URDF,
    "locked_joints": PANDA,
    "dynamic_compensation.urdf_file": {**WRIST, **URDF},
    "dynamic_compensation.locked_joints": {**WRIST, **PANDA},
    "dynamic_compensation.flange_frame": WRIST,
    "payload.com": {"payload.mass": 0.8},
    "payload.inertia": WRIST,
    "virtual_sensor": {**WRIST, "payload.mass": 0.0},
    "virtual_damping": {**WRIST, "virtual_sensor": True},
    "joint_torques": {**WRIST, "payload.mass": 0.0, "virtual_sensor": True},
    "acceleration_lowpass_hz": WRIST,
    **{f"dynamic_compensation.{name}": WRIST for name in ("robot", "tool_frame", "tool_xyz",
                                                          "tool_rpy")},
    "hole_from_home": HOLE,
    "hole_xyz": {"hole_from_home": False, "hole_rpy": HOLE["hole_rpy"]},
    "hole_rpy": {"hole_from_home": False, "hole_xyz": HOLE["hole_xyz"]},
    "estimate_rate_hz": {"scenario": ROBUST},
    "guard.max_tare": {"tare_samples": 50},
    "bias": {"tare_samples": 0},  # a tare measures the bias in its place
    "guard.stop_margin": {"guard.force_limit": 20.0},
    "fault_retract": {"timeout": 0.01},  # the features' 30 ms gap faults
    **{name: {"wrist_sensor": True} for name in ("wrist_payload.mass", "wrist_payload.com",
       "wrist_payload.inertia", "wrist_bias", "wrist_noise")},
}
for _name in ("hole_from_home", "hole_xyz", "hole_rpy"):  # the compensation: a wrist sensor's
    CONTEXT[f"dynamic_compensation.{_name}"] = {**WRIST, **CONTEXT[_name]}
    # the mock places the arm over the hole at start: a reachable one, changed from there
    CONTEXT[f"mock_cell.{_name}"] = {**HOLE, "hole_from_home": _name == "hole_from_home"}
#: Changed values where the generic change would not reach where the parameter acts.
CHANGED: dict[str, Any] = {
    "scenario": ROBUST,
    "max_step": 1e-6,  # the depth ramp moves 5 µm a period
    "max_step_angle": 1e-9,  # the tilt commands move less than 1e-6 rad a period here
    "timeout": 0.01,  # the features stop for 30 ms (_controller)
    "fbcc_controller.rate_hz": 250.0,
    "law": "admittance",  # the default scenario's law is fbcc
    "kinematics.rate_hz": 10000.0,  # a 0.5 mm command is then beyond a period's reach
    "estimate_rate_hz": 500.0,
    "state_stiffness": [1e8, 1e11],
    "payload.inertia": [1e-3, 0, 0, 0, 1e-3, 0, 0, 0, 1e-3],
    "deadband": [0.5, 0.05],
    "lowpass_hz": 20.0,
    "tare_samples": 50,
    "virtual_damping": 1.0,
    "robot": "panda",
    "urdf_file": str(LONGER),
    "flange_frame": "iiwa_link_7",
    "tool_frame": "iiwa_link_7",  # 45 mm behind the flange: the peg moves back
    "locked_joints": [],
    "hole_from_home": False,
    "seed": 7,
    "plant": "mujoco",  # the scenario's is the model
    # the guard: limits the recorded session stays within, tightened past it
    "guard.force_limit": 1.0,
    "guard.moment_limit": 0.01,
    "guard.sensor_range": [10.0, 60.0],  # the fixture's weight alone reads 14.7 N
    "guard.max_rate": [1.0, 1.0e5],
    "guard.max_tare": [1.0, 2.0],  # the tare measures the fixture's 14.7 N (no payload given)
    "guard.stop_margin": 0.9,  # of 20 N (CONTEXT): trips at 2 N, under the fixture's weight
    "fault_retract": 1e-3,
}


def _of(table: dict[str, Any], node: str, name: str) -> Any:
    return table.get(f"{node}.{name}", table.get(name))


def _changed(node: str, p: Param, value: Any) -> Any:
    if _of(CHANGED, node, p.name) is not None:
        return _of(CHANGED, node, p.name)
    if isinstance(value, bool):
        return not value
    if p.choices:
        return next(c for c in p.choices if c != value)
    if isinstance(value, float):
        high = math.inf if p.high is None else p.high
        return next(c for c in (value * 1.5, value / 1.5, 0.5) if c != value and c <= high)
    if isinstance(value, list):
        return [value[0] + 0.01, *value[1:]]
    if isinstance(value, str):
        return value + "_other"
    raise AssertionError(f"no changed value for {p.name}={value!r}")


def _attempt(out: list[Any], call: Any, *args: Any) -> Any:
    """``call(*args)``, or its refusal put into ``out``."""
    try:
        return call(*args)
    except FbccError as exc:
        out.append(f"refused: {exc}")
        return None


def _compensation(values: dict[str, Any]) -> list[Any]:
    stage = compensation.CompensationStage(values)
    out: list[Any] = []
    q = None
    for m in BAG.messages:
        if m.topic == "/joint_states" and stage.robot is not None:
            stamp, q, dq = joints_from_cdr(m.data, JOINTS)  # for any 7-joint model
            if not stage.measured:
                _attempt(out, stage.joints, stamp, q, dq)
        elif m.topic == "/ft_sensor/raw":
            stamp, frame, wrench = wrench_from_cdr(m.data)
            torques = np.r_[wrench, wrench[0]]  # such a wrench's joint torques: any 7 do
            if stage.measured:  # with the last joint state's positions
                result = _attempt(out, stage.measured_torques, stamp, q, None, torques)
            elif stage.virtual:
                result = _attempt(out, stage.torques, stamp, torques)
            else:
                result = _attempt(out, stage.reading, stamp, frame, wrench)
            if result is not None:
                out.append(np.r_[result.stamp, result.wrench])
    return [*out, stage.comp.counts, stage.comp.bias, stage.comp.guard.reason]


def _kinematics(values: dict[str, Any]) -> list[Any]:
    stage = kinematics.KinematicsStage(values)
    out: list[Any] = []
    peg = None
    for m in BAG.messages:
        if m.topic == "/joint_states":  # for any 7-joint model
            peg = _attempt(out, stage.joints, joints_from_cdr(m.data, JOINTS)[1])
            if peg is not None:
                out.append(peg.homogeneous)
        elif m.topic == "/fbcc/command":
            solution = _attempt(out, stage.command, pose_from_cdr(m.data)[1])
            if solution is not None:
                out.append(solution.q)
    if peg is not None:  # a command 0.5 mm to the side: within a period's reach at 1 kHz only
        solution = _attempt(out, stage.command, peg * pin.SE3(np.eye(3), np.array([5e-4, 0, 0])))
        out.append(None if solution is None else solution.q)
    return out


def _controller(values: dict[str, Any]) -> list[Any]:
    stage = controller.ControllerStage(values)
    out: list[Any] = []
    start = min(pose_from_cdr(m.data)[0] for m in BAG.of("/fbcc/command"))
    silent = (start + 0.5, start + 0.53)  # the features stop for 30 ms
    for m in BAG.messages:
        if m.topic == "/fbcc/features":
            stamp, peg = pose_from_cdr(m.data)
            if not silent[0] <= stamp < silent[1]:
                retract = stage.features(stamp, peg)
                out.append(None if retract is None else retract.homogeneous)
        elif m.topic == "/ft_sensor/compensated":
            stamp, _, wrench = wrench_from_cdr(m.data)
            if stage.ready_to_start or (stage.sup.phase in ("idle", "armed") and stamp >= start):
                out.append(stage.sup.start(stamp))
            command = stage.wrench(stamp, stamp, wrench)
            if command is not None:
                out.append(command.homogeneous)
            out += [stage.estimate(stamp), stage.contact_state(), stage.said]
    feed = stage.state_feed  # the samples the contact-state filter would be handed
    # and the k it would take (test_state_worker: a range changes its answers)
    return [*out, stage.input_rate.measured_hz, None if feed is None else feed.sent,
            stage.state_stiffness]


def _mock(values: dict[str, Any]) -> list[Any]:
    """The mock's plant following the recorded joint commands, one period each."""
    stage = mock_cell.MockStage(values)
    out: list[Any] = [stage.dt, stage.frame]
    for i, m in enumerate(BAG.of("/joint_command")):
        _attempt(out, stage.cell.command, positions_from_cdr(m.data))
        sample = stage.cell.step(stage.dt)
        arm = stage.arm_sensing(sample, estimate=True)
        out += [sample.q, sample.response, arm.external, arm.measured, arm.estimated,
                stage.wrist_reading(sample)]
        for stamp, raw in stage.readings(i * stage.dt, sample.raw):
            out += [stamp, raw]
    return out


STAGES = {
    "mock_cell": (mock_cell.TABLE, _mock),
    "dynamic_compensation": (compensation.TABLE, _compensation),
    "kinematics": (kinematics.TABLE, _kinematics),
    "fbcc_controller": (controller.TABLE, _controller),
}
#: Transport settings a stage has no use for, each shown acting over DDS by the named test.
_DESCRIBED = ("test/nodes/test_robot_description.py::"
              "test_features_from_a_published_robot_description_match_the_truth")
_UNDESCRIBED = ("test/nodes/test_robot_description.py::"
                "test_without_a_description_the_node_says_where_it_waited")
_COMMANDED = "test/nodes/test_command_types.py::"
TRANSPORT = {
    "dynamic_compensation.wrench_qos":
        "test/nodes/test_wrench_qos.py::test_a_best_effort_sensor_is_heard_only_when_told",
    **{f"{node}.description_timeout": _UNDESCRIBED
       for node in ("mock_cell", "dynamic_compensation", "kinematics")},
    "mock_cell.arm_sensing": ("test/nodes/test_stack_rehearsal.py::"
                              "test_the_virtual_sensor_from_the_stacks_external_torques_assembles"),
    "mock_cell.sensor_qos": ("test/nodes/test_stack_rehearsal.py::"
                             "test_a_best_effort_ft_sensor_at_1khz_assembles"),
    "dynamic_compensation.wrench_topic":
        "test/nodes/test_wrench_qos.py::test_the_wrench_is_read_where_wrench_topic_says",
    "mock_cell.publish_description": _DESCRIBED,
    "mock_cell.publish_clock": ("test/nodes/test_mujoco_cell.py::"
                                "test_the_cell_on_mujoco_records_a_bag_rosbags_reads_and_the_"
                                "report_draws"),
    "kinematics.command_type":
        f"{_COMMANDED}test_a_one_period_trajectory_for_a_joint_trajectory_controller",
    "kinematics.command_topic":
        f"{_COMMANDED}test_joint_positions_for_a_forward_position_controller",
    "kinematics.base_frame": f"{_COMMANDED}test_the_flange_pose_for_a_cartesian_controller",
    **{f"{node}.{name}": ("test/nodes/test_joint_states_input.py::"
                          "test_the_joint_states_are_read_where_and_as_told")
       for node in ("dynamic_compensation", "kinematics")
       for name in ("joint_states_topic", "joint_states_qos")},
    **{f"{node}.hole_frame": ("test/nodes/test_frame_names.py::test_topics_in_the_hole_frame_"
                              "carry_its_name_and_a_tool_frame_places_the_tool")
       for node in ("dynamic_compensation", "kinematics", "fbcc_controller")},
}  # fmt: skip
CASES = [(node, p) for node, (table, _) in STAGES.items() for p in table
         if f"{node}.{p.name}" not in TRANSPORT]  # fmt: skip


def test_each_transport_setting_has_its_dds_test() -> None:
    for where in TRANSPORT.values():
        path, name = where.split("::")
        assert f"def {name}(" in (ROOT / path).read_text(), where


def _same(a: list[Any], b: list[Any]) -> bool:
    if len(a) != len(b):
        return False
    for x, y in zip(a, b, strict=True):
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            if np.shape(x) != np.shape(y) or not np.allclose(x, y, rtol=0.0, atol=1e-12):
                return False
        elif x != y:
            return False
    return True


_RUNS: dict[str, list[Any]] = {}


def _run(node: str, values: dict[str, Any]) -> list[Any]:
    """What the stage puts out with these values (each set driven once)."""
    key = f"{node}: {sorted(values.items())!r}"
    if key not in _RUNS:
        _RUNS[key] = STAGES[node][1](values)
    return _RUNS[key]


@pytest.mark.parametrize(("node", "param"), CASES, ids=[f"{n}.{p.name}" for n, p in CASES])
def test_every_parameter_changes_what_its_stage_puts_out(node: str, param: Param) -> None:
    base = resolve(node, STAGES[node][0], _of(CONTEXT, node, param.name) or {})
    changed = {**base, param.name: _changed(node, param, base[param.name])}
    assert changed[param.name] != base[param.name]
    assert not _same(_run(node, base), _run(node, changed)), f"{param.name} changed nothing"
