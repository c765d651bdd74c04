"""The cell's nodes beside a robot stack, or beside the hardware-free mock playing one.

    ros2 launch fbcc_ros fbcc_cell.launch.py [profile:=fbcc|lbr|ros2_control] [mock:=true|false]
        [scenario:=FILE] [law:=fbcc|admittance|none] [namespace:=/lbr] [params_file:=FILE]
        [model:=iiwa14] [plant:=model|mujoco] [record:=false]

The node set and every node's parameter files come from fbcc_ros.harness.cell_nodes, the
description fbcc_bringup and the tests build too; this file only turns it into launch actions.
docs/integration.md goes through it step by step.
"""

from __future__ import annotations

from typing import Any

from launch.actions import DeclareLaunchArgument, LogInfo, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.harness.cell_nodes import PROFILES, CellSetup, cell_nodes, deadband_warnings
from launch import LaunchContext, LaunchDescription

ARGUMENTS = (
    ("profile", "fbcc", f"the robot stack our nodes run beside: {' | '.join(PROFILES)}"),
    ("mock", "true", "the hardware-free mock plays the robot and its sensors (true | false)"),
    ("scenario", "config/scenarios/bringup_interference.yaml",
     "the mock's scenario (its robot and sensor sections: the stack it plays)"),
    ("law", "", "fbcc | admittance | none (empty: the scenario's)"),
    ("namespace", "", "where the nodes run, e.g. /lbr (the stack's)"),
    ("params_file", "", "your cell's parameter file (hole, tool, sensor): needed beside a robot"),
    ("model", "", "a built-in model for the mock and, with profile fbcc, for our nodes "
     "(empty: the scenario's robot.model)"),
    ("plant", "", "the mock's contact: model | mujoco (empty: the scenario's); on mujoco the "
     "mock is the cell's clock (/clock) and every node runs with use_sim_time"),
    ("record", "false", "also record the session (fbcc_record) into ./bags"),
)  # fmt: skip


def _true(name: str, value: str) -> bool:
    if value.lower() not in ("true", "false"):
        raise ConfigError(name, value, "true or false")
    return value.lower() == "true"


def _nodes(context: LaunchContext) -> list[Any]:
    arg = {name: LaunchConfiguration(name).perform(context) for name, _, _ in ARGUMENTS}
    setup = CellSetup(profile=arg["profile"], scenario=arg["scenario"],
                      mock=_true("mock", arg["mock"]), law=arg["law"],
                      namespace=arg["namespace"], params_file=arg["params_file"],
                      model=arg["model"], plant=arg["plant"])  # fmt: skip
    nodes = cell_nodes(setup)
    actions: list[Any] = [LogInfo(msg=f"WARNING: {said}") for said in deadband_warnings(nodes)]
    for node in nodes:
        actions.append(Node(package="fbcc_ros", executable=node.name, name=node.name,
                            namespace=arg["namespace"], output="screen",
                            parameters=[*map(str, node.files), node.parameters]))  # fmt: skip
    if _true("record", arg["record"]):
        actions.append(Node(package="fbcc_ros", executable="fbcc_record", name="fbcc_record",
                            namespace=arg["namespace"], output="screen"))  # fmt: skip
    return actions


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        *(DeclareLaunchArgument(name, default_value=default, description=description)
          for name, default, description in ARGUMENTS),
        OpaqueFunction(function=_nodes),
    ])  # fmt: skip
