"""Parameters of a node: its stage's table (:mod:`fbcc_ros.pipeline.parameters`) declared with
rclpy's descriptors, which rclpy enforces on declare and on set; values are then validated once
more by the core's dataclasses (cross-field checks). A key the node does not declare (a misspelt
one in its YAML) is refused at start-up, with the closest declared name."""

from __future__ import annotations

import array
from collections.abc import Callable, Iterable, Sequence
from typing import Any

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.node import Node

from fbcc_ros.core.errors import FbccError, one_line
from fbcc_ros.core.files import read_yaml
from fbcc_ros.pipeline.parameters import Param, stage_names, unknown_names
from fbcc_ros.ros.executor import make_executor
from fbcc_ros.ros.process import StopSignalError, catch_signals, short_lease

#: The clock source: set at start-up only. Switched on a running node (with no ``/clock``) its
#: clock read 0 and no stamp looked stale; the watchdogs run on a steady clock regardless.
CLOCK_SOURCE = "use_sim_time"
CLOCK_FIXED = (f"{CLOCK_SOURCE} is set at start-up only (--ros-args -p {CLOCK_SOURCE}:=true): "
               "switched while the cell runs, the stamps of its messages would jump")


def descriptor(p: Param) -> ParameterDescriptor:
    """rclpy's descriptor of ``p``: its meaning and unit, read-only, its range."""
    unit = f" [{p.unit}]" if p.unit else ""
    choices = f" (one of {', '.join(p.choices)})" if p.choices else ""
    desc = ParameterDescriptor(description=f"{p.description}{unit}{choices}",
                               read_only=p.read_only)  # fmt: skip
    # an empty list has no type for rclpy (it calls [] bytes, from YAML too): a list of names
    # then, whatever rclpy calls it, checked by Param.check
    desc.dynamic_typing = p.default == []
    if p.low is not None and p.high is not None:
        if isinstance(p.default, int) and not isinstance(p.default, bool):
            desc.integer_range = [
                IntegerRange(from_value=int(p.low), to_value=int(p.high), step=1)
            ]
        elif isinstance(p.default, float):
            desc.floating_point_range = [
                FloatingPointRange(from_value=p.low, to_value=p.high, step=0.0)
            ]
    return desc


def declare(
    node: Node,
    table: Sequence[Param],
    apply: Callable[[dict[str, Any]], None] | None = None,
) -> dict[str, Any]:
    """Declares the table's parameters and returns their values by name.

    Start-up values outside a range or a choice, and keys the table does not declare, raise
    (rclpy's exception or :class:`~fbcc_ros.core.errors.ConfigError`). With ``apply``, a
    runtime change of a writable parameter is passed to it with all current values; if it
    raises an FbccError the change is refused with the reason. ``use_sim_time`` is refused
    at runtime (:data:`CLOCK_FIXED`).
    """
    unknown_names(node.get_name(), table, stage_names(node._parameter_overrides))
    values: dict[str, Any] = {}
    for p in table:
        value = node.declare_parameter(p.name, p.default, descriptor(p)).value
        # a YAML file's [] reaches rclpy as no value at all
        values[p.name] = [] if value is None and p.default == [] else plain(value)
        p.check(values[p.name])
    by_name = {p.name: p for p in table}

    def on_set(changes: list[Any]) -> SetParametersResult:
        merged = dict(values)
        for change in changes:
            if change.name == CLOCK_SOURCE:
                return SetParametersResult(successful=False, reason=CLOCK_FIXED)
            if change.name in by_name:
                value = plain(change.value)
                try:
                    by_name[change.name].check(value)
                except FbccError as exc:
                    return SetParametersResult(successful=False, reason=str(exc))
                merged[change.name] = value
        if apply is not None:
            try:
                apply(merged)
            except FbccError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
        values.update(merged)
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(on_set)
    return values


def plain(value: Any) -> Any:
    """A parameter's value as the tables hold it: rclpy gives a number array set at runtime
    as ``array.array`` (a list when declared from YAML), an empty list as ``bytes``."""
    return list(value) if isinstance(value, (array.array, bytes)) else value


def run(node_factory: Callable[[], Node]) -> None:
    """The ``main()`` of every node (ros2/demos shape), on the executor
    :func:`~fbcc_ros.ros.executor.make_executor` chooses (the EventsExecutor by default).

    A parameter that is refused at start-up (out of range, not a choice, a failed core check),
    or a file the node cannot make (the recorder's bag folder), ends the process with exit
    status 2 and one line naming the value and what is allowed.
    SIGINT and SIGTERM end the spin between callbacks (rclpy's own handlers would raise inside
    a callback), then the node's ``on_shutdown`` runs (if it has one: the hold of a node that
    moves the arm), the node is destroyed and the process exits 0; one that comes while the
    node is built (waiting for its robot model) ends it there (:mod:`fbcc_ros.ros.process`).
    """
    import sys

    import rclpy
    from rclpy.exceptions import (
        InvalidNamespaceException,
        InvalidNodeNameException,
        ParameterException,
    )
    from rclpy.signals import SignalHandlerOptions

    name = getattr(node_factory, "__name__", "node")
    stop = catch_signals()
    short_lease()
    if stop:  # a signal while the node's modules loaded
        return
    try:
        for file in params_files(sys.argv):  # read strictly before rcl reads them
            read_yaml(file, "--params-file")
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    except FbccError as exc:
        print(f"{name}: {one_line(exc)}", file=sys.stderr)
        raise SystemExit(2) from None
    except (RuntimeError, InvalidNamespaceException, InvalidNodeNameException) as exc:
        # rcl's own refusal of the command line (RCLError is a RuntimeError): its first line
        said = str(exc).split(", at /")[0]
        print(f"{name}: the ROS arguments were refused: {said}", file=sys.stderr)
        raise SystemExit(2) from None
    node = None
    try:
        try:
            node = node_factory()
        except StopSignalError:  # a signal while it waited for its robot model
            return
        except (FbccError, ParameterException, OSError) as exc:  # OSError: the recorder's bag
            said = str(exc) if isinstance(exc, ParameterException) else one_line(exc)
            print(f"{name}: {said}", file=sys.stderr)
            raise SystemExit(2) from None
        executor = make_executor()
        executor.add_node(node)
        settle([node])
        while not stop and rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
        if hasattr(node, "on_shutdown"):  # a hold, if it was moving the arm
            node.on_shutdown()
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


def params_files(argv: Sequence[str]) -> list[str]:
    """The files of ``--params-file FILE`` in a command line's ROS arguments."""
    files, ros = [], False
    for k, arg in enumerate(argv):
        if arg == "--ros-args":
            ros = True
        elif arg == "--":
            ros = False
        elif ros and arg == "--params-file" and k + 1 < len(argv):
            files.append(argv[k + 1])
    return files


def settle(nodes: Iterable[Any]) -> None:
    """Once the nodes are built, before the loop: each node's ``preload()`` (where it has one)
    loads its compiled code, then :func:`freeze_heap`."""
    for node in nodes:
        preload = getattr(node, "preload", None)
        if preload is not None:
            preload()
    freeze_heap()


def freeze_heap() -> None:
    """Once the nodes are built: everything alive now leaves the garbage collector's view.

    A full collection otherwise walks every object of pinocchio, numpy and rclpy: one took
    32 ms in the 1 kHz loop (32 periods lost), the middle generation up to 1.7 ms. Objects
    made afterwards are collected as usual.
    """
    import gc

    gc.collect()
    gc.freeze()
