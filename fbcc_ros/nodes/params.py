"""Parameter tables: each node declares its parameters from one table (name, default, unit,
description, range, read_only) with rclpy's descriptors, which rclpy enforces on declare and on
set; values are then validated once more by the core's dataclasses (cross-field checks)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.node import Node

from fbcc_ros.core.errors import ConfigError, FbccError


@dataclasses.dataclass(frozen=True)
class Param:
    """One parameter: ``name`` as in the YAML (dots for nesting), its default, unit and meaning.

    ``low``/``high`` bound a number (rclpy refuses values outside); ``choices`` a string.
    """

    name: str
    default: Any
    description: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    read_only: bool = True
    choices: tuple[str, ...] = ()

    def descriptor(self) -> ParameterDescriptor:
        unit = f" [{self.unit}]" if self.unit else ""
        choices = f" (one of {', '.join(self.choices)})" if self.choices else ""
        desc = ParameterDescriptor(
            description=f"{self.description}{unit}{choices}", read_only=self.read_only
        )
        if self.low is not None and self.high is not None:
            if isinstance(self.default, int) and not isinstance(self.default, bool):
                desc.integer_range = [
                    IntegerRange(from_value=int(self.low), to_value=int(self.high), step=1)
                ]
            elif isinstance(self.default, float):
                desc.floating_point_range = [
                    FloatingPointRange(from_value=self.low, to_value=self.high, step=0.0)
                ]
        return desc


def declare(
    node: Node,
    table: Sequence[Param],
    apply: Callable[[dict[str, Any]], None] | None = None,
) -> dict[str, Any]:
    """Declares the table's parameters and returns their values by name.

    Start-up values outside a range or a choice raise (rclpy's exception or
    :class:`~fbcc_ros.core.errors.ConfigError`). With ``apply``, a runtime change of a
    writable parameter is passed to it with all current values; if it raises an FbccError the
    change is refused with the reason.
    """
    values: dict[str, Any] = {}
    for p in table:
        values[p.name] = node.declare_parameter(p.name, p.default, p.descriptor()).value
        check_choice(p, values[p.name])
    by_name = {p.name: p for p in table}

    def on_set(changes: list[Any]) -> SetParametersResult:
        merged = dict(values)
        for change in changes:
            if change.name in by_name:
                try:
                    check_choice(by_name[change.name], change.value)
                except FbccError as exc:
                    return SetParametersResult(successful=False, reason=str(exc))
                merged[change.name] = change.value
        if apply is not None:
            try:
                apply(merged)
            except FbccError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
        values.update(merged)
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(on_set)
    return values


def check_choice(p: Param, value: Any) -> None:
    if p.choices and value not in p.choices:
        raise ConfigError(p.name, value, f"one of {list(p.choices)}")


#: The arm, its tool and where the hole is: shared by the nodes that need kinematics.
CELL = (
    Param("robot", "iiwa14", "robot model", choices=("iiwa14", "panda", "ur5")),
    Param("tool_xyz", [0.0, 0.0, 0.10], "peg tip centre in the flange frame", "m"),
    Param("tool_rpy", [0.0, 0.0, 0.0], "peg frame orientation in the flange frame", "rad"),
    Param("hole_from_home", True,
          "place {H} aligned under the peg at the robot's home (hole_xyz/rpy ignored)"),
    Param("hole_xyz", [0.0, 0.0, 0.0], "origin of {H} in the base frame", "m"),
    Param("hole_rpy", [0.0, 0.0, 0.0], "orientation of {H} in the base frame", "rad"),
)  # fmt: skip


def cell_from(values: dict[str, Any]) -> tuple[Any, Any]:
    """The robot model and ``T_base_H`` from the CELL parameters."""
    from fbcc_ros.core.kinematics import RobotModel, Tool, aligned_hole_at, pose

    tool = Tool(tuple(values["tool_xyz"]), tuple(values["tool_rpy"]))  # type: ignore[arg-type]
    robot = RobotModel.from_name(values["robot"], tool)
    if values["hole_from_home"]:
        return robot, aligned_hole_at(robot.peg_in_base(robot.home))
    return robot, pose(values["hole_xyz"], values["hole_rpy"])


def run(node_factory: Callable[[], Node]) -> None:
    """The ``main()`` of every node (ros2/demos shape), on the EventsExecutor.

    A parameter that is refused at start-up (out of range, not a choice, a failed core check)
    ends the process with exit status 2 and one line naming the value and what is allowed.
    SIGINT and SIGTERM end the spin between callbacks (rclpy's own handlers would raise inside
    a callback), then the node is destroyed and the process exits 0.
    """
    import signal
    import sys

    import rclpy
    from rclpy.exceptions import ParameterException
    from rclpy.experimental import EventsExecutor
    from rclpy.signals import SignalHandlerOptions

    stop: list[int] = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda number, _: stop.append(number))
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = None
    try:
        try:
            node = node_factory()
        except (FbccError, ParameterException) as exc:
            print(f"{getattr(node_factory, '__name__', 'node')}: {exc}", file=sys.stderr)
            raise SystemExit(2) from None
        executor = EventsExecutor()
        executor.add_node(node)
        freeze_heap()
        while not stop and rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


def freeze_heap() -> None:
    """Once the nodes are built: everything alive now leaves the garbage collector's view.

    A full collection otherwise walks every object of pinocchio, numpy and rclpy: one took
    32 ms in the 1 kHz loop (32 periods lost), the middle generation up to 1.7 ms. Objects
    made afterwards are collected as usual.
    """
    import gc

    gc.collect()
    gc.freeze()


def find_scenario(value: str) -> Path:
    path = Path(value)
    if path.is_file():
        return path
    try:
        from ament_index_python.packages import get_package_share_directory

        shared = Path(get_package_share_directory("fbcc_ros")) / value
        if shared.is_file():
            return shared
    except (ImportError, LookupError, KeyError, ValueError, OSError):
        pass
    package = Path(__file__).resolve().parents[2] / value  # a source checkout
    if package.is_file():
        return package
    raise ConfigError("scenario", value, "the path of a scenario YAML (DESIGN §4)")
