"""Every key of ``config/*.yaml`` is declared by its node and reaches the node's core.

"Reaches the core" is tested by mutation: a node is built with the YAML's values and again with
one value changed; the fingerprint of what the node built from them (its core objects, numbers,
strings and arrays, and the topics it publishes and subscribes) must change. A parameter that
is declared but never read leaves the fingerprint as it was and fails here.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
import rclpy
import yaml
from rclpy.parameter import Parameter

from fbcc_ros.core.kinematics.cell import aligned_hole_at
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel
from fbcc_ros.core.param_files import node_section
from fbcc_ros.nodes.dynamic_compensation import TABLE as COMPENSATION
from fbcc_ros.nodes.dynamic_compensation import DynamicCompensationNode
from fbcc_ros.nodes.fbcc_controller import TABLE as CONTROLLER
from fbcc_ros.nodes.fbcc_controller import FbccControllerNode
from fbcc_ros.nodes.kinematics import TABLE as KINEMATICS
from fbcc_ros.nodes.kinematics import KinematicsNode
from fbcc_ros.nodes.mock_cell import TABLE as MOCK
from fbcc_ros.nodes.mock_cell import MockCellNode
from fbcc_ros.pipeline.parameters import Param, flatten

ROOT = Path(__file__).resolve().parents[2]
NODES = {
    "mock_cell": (MockCellNode, MOCK),
    "dynamic_compensation": (DynamicCompensationNode, COMPENSATION),
    "kinematics": (KinematicsNode, KINEMATICS),
    "fbcc_controller": (FbccControllerNode, CONTROLLER),
}
#: Changed values where a generic change would be invalid or meaningless.
CHANGED: dict[str, Any] = {
    "scenario": "config/scenarios/fig9_clearance.yaml",
    "plant": "mujoco",  # the scenario's is the model
    "payload.inertia": [1e-3, 0.0, 0.0, 0.0, 1e-3, 0.0, 0.0, 0.0, 1e-3],
    "deadband": [0.1, 0.01],
    "robot": "panda",
    "rate_hz": 500.0,  # 0 is the scenario's rate, and 0.1 Hz too slow for the gains
    "seed": 7,  # -1 is the scenario's seed
    "law": "admittance",  # the default scenario's law is fbcc
    "urdf_file": str(ROBOTS["iiwa7"]().urdf),
    "flange_frame": "iiwa_link_7",
    "tool_frame": "iiwa_link_7",
    "locked_joints": ["panda_finger_joint1", "panda_finger_joint2"],
    "state_stiffness": [1e8, 1e11],  # [0, 0] is the scenario's k; [0.01, 0] no range
}
#: Where the iiwa's home puts {H} (hole_from_home), nudged so that an explicit hole differs.
HOLE = {"hole_xyz": [0.575, 0.0, 0.336], "hole_rpy": [0.0, 0.0, math.pi]}
#: Parameters that matter only together with others (an explicit hole must be reachable).
#: (``node.name`` before ``name``)
URDF = {"robot": "urdf_file", "urdf_file": str(ROBOTS["iiwa14"]().urdf), "hole_from_home": False,
        **HOLE}  # fmt: skip
#: The Panda's URDF, fingers and all, over a hole it reaches from the middle of its ranges.
_PANDA_HOLE = aligned_hole_at(RobotModel.from_name("panda").peg_in_base(ROBOTS["panda"]().home))
PANDA = {**URDF, "urdf_file": str(ROBOTS["panda"]().urdf), "flange_frame": "panda_link8",
         "hole_xyz": _PANDA_HOLE.translation.tolist(),
         "hole_rpy": pin.rpy.matrixToRpy(_PANDA_HOLE.rotation).tolist()}  # fmt: skip
TOGETHER: dict[str, dict[str, Any]] = {
    "hole_from_home": HOLE,
    "hole_xyz": {"hole_from_home": False, **HOLE},
    "hole_rpy": {"hole_from_home": False, **HOLE},
    "virtual_sensor": {"placement": "wrist"},
    "joint_torques": {"placement": "wrist", "virtual_sensor": True},
    "urdf_file": URDF,
    "locked_joints": PANDA,
    "dynamic_compensation.urdf_file": {**URDF, "placement": "wrist"},
    "dynamic_compensation.locked_joints": {**PANDA, "placement": "wrist"},
    "dynamic_compensation.flange_frame": {"placement": "wrist"},
    "dynamic_compensation.tool_frame": {"placement": "wrist"},
    # the compensation reads joint states for a wrist sensor (where it is)
    **{f"dynamic_compensation.{name}": {"placement": "wrist"}
       for name in ("joint_states_topic", "joint_states_qos")},
    **{name: {"wrist_sensor": True} for name in ("wrist_payload.mass", "wrist_payload.com",
       "wrist_payload.inertia", "wrist_bias", "wrist_noise")},
}
#: Acts only while a node waits for its robot_description, shown over DDS by
#: test_robot_description.py::test_without_a_description_the_node_says_where_it_waited.
AT_START_ONLY = ("description_timeout",)


def _yaml(node: str) -> dict[str, Any]:
    text = (ROOT / "config" / f"{node}.yaml").read_text()
    doc = yaml.safe_load(text)
    assert list(doc) == [f"/**/{node}"]  # read under any namespace
    return flatten(node_section(doc, node) or {})


def _changed(p: Param, value: Any) -> Any:
    if p.name in CHANGED:
        return CHANGED[p.name]
    if isinstance(value, bool):
        return not value
    if p.choices:
        return next(c for c in p.choices if c != value)
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        low = -math.inf if p.low is None else p.low
        high = math.inf if p.high is None else p.high
        for candidate in (value * 1.5, value + 0.1, (low + high) / 2):
            if candidate != value and low <= candidate <= high:
                return candidate
    if isinstance(value, list):
        return [value[0] + 0.01, *value[1:]]
    if isinstance(value, str):
        return value + "_other"
    raise AssertionError(f"no changed value for {p.name}={value!r}")


def fingerprint(obj: Any, depth: int = 0, seen: set[int] | None = None) -> Any:
    """The numbers, strings and arrays reachable from ``obj``, and the topics of its rclpy
    entities; no identities or addresses."""
    seen = set() if seen is None else seen
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    if isinstance(obj, np.ndarray):
        return (obj.round(12) if obj.dtype.kind == "f" else obj).tolist()
    if isinstance(obj, np.random.Generator):
        return fingerprint(obj.bit_generator.state, depth + 1, seen)
    if isinstance(obj, pin.SE3):
        return obj.homogeneous.round(12).tolist()
    if id(obj) in seen or depth > 8:
        return "..."
    seen.add(id(obj))
    if isinstance(obj, (list, tuple)):
        return [fingerprint(x, depth + 1, seen) for x in obj]
    if isinstance(obj, dict):
        return {str(k): fingerprint(v, depth + 1, seen) for k, v in obj.items()}
    module = type(obj).__module__ or ""
    if module.startswith("rclpy"):
        topic = getattr(obj, "topic_name", None) or getattr(obj, "srv_name", None)
        period = getattr(obj, "timer_period_ns", None)
        return [type(obj).__name__, topic, period]
    if module.startswith(("pinocchio", "rcl_interfaces", "std_msgs", "geometry_msgs")):
        return type(obj).__name__
    state = getattr(obj, "__dict__", None)
    if state is None:
        return type(obj).__name__
    return {"type": type(obj).__name__,
            **{k: fingerprint(v, depth + 1, seen) for k, v in state.items()}}  # fmt: skip


def _built(cls: Any, values: dict[str, Any]) -> Any:
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = cls(
            context=context,
            parameter_overrides=[Parameter(k, value=v) for k, v in values.items()],
        )
        try:
            # the node's own attributes (rclpy's are private, and _parameters would hold the
            # very values under test), and the topics it uses (a subscription with its
            # reliability: the QoS it is given is the node's own)
            built = {k: v for k, v in vars(node).items() if not k.startswith("_")}
            entities = [f"{e.topic_name} {e.qos_profile.reliability.name}"
                        for e in (*node.publishers, *node.subscriptions)]
            return fingerprint({"node": built, "entities": sorted(entities)})
        finally:
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


@pytest.mark.parametrize("node", NODES)
def test_every_yaml_key_is_declared_and_every_declared_one_is_in_the_yaml(node: str) -> None:
    declared = {p.name: p.default for p in NODES[node][1]}
    keys = _yaml(node)
    assert set(keys) == set(declared), set(keys) ^ set(declared)
    assert keys == declared  # the files hold the defaults (they are generated from the tables)


CASES = [(node, p) for node, (_, table) in NODES.items() for p in table
         if p.name not in AT_START_ONLY]  # fmt: skip


@pytest.mark.parametrize(("node", "param"), CASES, ids=[f"{n}.{p.name}" for n, p in CASES])
def test_every_parameter_reaches_the_core(node: str, param: Param) -> None:
    cls, _ = NODES[node]
    together = TOGETHER.get(f"{node}.{param.name}", TOGETHER.get(param.name, {}))
    base = {**_yaml(node), **together}
    changed = {**base, param.name: _changed(param, base[param.name])}
    assert _built(cls, base) != _built(cls, changed), f"{param.name} changed nothing"


def _misspelt(name: str) -> str:
    """``name`` with two of its letters swapped (a typing slip), still not a declared name."""
    pairs = [i for i in range(len(name) - 1) if name[i] != name[i + 1]]
    i = max(i for i in pairs if "." not in name[i : i + 2])
    return name[:i] + name[i + 1] + name[i] + name[i + 2 :]


@pytest.mark.parametrize("node", NODES)
def test_a_misspelt_key_is_refused_at_start_up_with_the_closest_name(node: str) -> None:
    """Each node and the offline replay's resolution of its table: a key the node does not
    declare would otherwise leave the default in force without a word."""
    from fbcc_ros.core.errors import ConfigError
    from fbcc_ros.pipeline.parameters import resolve

    cls, table = NODES[node]
    for p in table:
        wrong = _misspelt(p.name)
        assert wrong not in {q.name for q in table}
        given = {wrong: p.default}
        for build, args in ((_built, (cls, given)), (resolve, (node, table, given))):
            with pytest.raises(ConfigError) as err:
                build(*args)
            assert err.value.value == wrong and f"did you mean {p.name!r}?" in str(err.value)


def test_the_parameter_reference_is_generated_from_the_tables() -> None:
    from fbcc_ros.cli.parameter_reference import markdown

    committed = (ROOT / "docs" / "parameters.md").read_text()
    assert committed == markdown(), "run: python -m fbcc_ros.cli.parameter_reference"
    for _, table in NODES.values():
        assert all(f"| `{p.name}` |" in committed for p in table)


def test_the_recorder_yaml_holds_exactly_its_declared_defaults() -> None:
    # not in NODES: building a recorder creates its bag folder, so it has its own tests
    from fbcc_ros.nodes.fbcc_record import TABLE as RECORD

    assert _yaml("fbcc_record") == {p.name: p.default for p in RECORD}
