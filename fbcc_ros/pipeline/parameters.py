"""The parameters of a stage, declared once, without ROS.

Each stage of the pipeline declares its parameters in one table of :class:`Param` (name as in
the YAML, dots for nesting; default; unit; meaning; range or choices; whether it may change at
runtime). The ROS nodes declare the same table with rclpy's descriptors
(:mod:`fbcc_ros.ros.params`); the offline replay resolves it here with :func:`resolve`, which
checks what rclpy checks on declare, and refuses a name the stage does not have.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from typing import Any

from fbcc_ros.core.errors import ConfigError, closest
from fbcc_ros.core.param_files import flatten

__all__ = ["HOLE_FRAME", "JOINT_STATES", "Param", "flatten", "frame_id", "resolve",
           "unknown_names"]


@dataclasses.dataclass(frozen=True)
class Param:
    """One parameter: ``name`` as in the YAML (dots for nesting), its default, unit and meaning
    (an empty list default: a list of strings).

    ``low``/``high`` bound a number; ``choices`` a string; ``read_only`` is False for the
    parameters a stage applies while it runs.
    """

    name: str
    default: Any
    description: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    read_only: bool = True
    choices: tuple[str, ...] = ()

    def check(self, value: Any, where: str = "") -> None:
        """Raises :class:`ConfigError` for a value of another type than the default's (a number
        for a floating-point default), outside the choices or outside the range."""
        name = f"{where}.{self.name}" if where else self.name
        if not _same_kind(value, self.default):
            raise ConfigError(name, value, _kind(self.default))
        if self.choices and value not in self.choices:
            raise ConfigError(name, value, f"one of {list(self.choices)}")
        if self.low is not None and self.high is not None and not self.low <= value <= self.high:
            raise ConfigError(name, value, f"within [{self.low}, {self.high}] {self.unit}".strip())


def _same_kind(value: Any, default: Any) -> bool:
    """Whether ``value`` has the type rclpy would accept for a parameter declared with
    ``default`` (a float parameter also takes an integer here, as YAML writes 20 for 20.0)."""
    if isinstance(default, list):
        if not isinstance(value, list):
            return False
        if not default:  # an empty default: a list of strings (names)
            return all(isinstance(v, str) for v in value)
        return all(_same_kind(v, default[0]) for v in value)
    if isinstance(default, bool) or isinstance(value, bool):
        return isinstance(value, bool) and isinstance(default, bool)
    if isinstance(default, float):
        return isinstance(value, (int, float))
    return isinstance(value, type(default))


def _kind(default: Any) -> str:
    if isinstance(default, list):
        return f"a list of {_kind(default[0] if default else '').removeprefix('a ')}s"
    names = {bool: "a boolean (true or false)", int: "an integer", float: "a number",
             str: "a string"}  # fmt: skip
    return names.get(type(default), f"a {type(default).__name__}")


#: Parameters rclpy itself gives every node (and its QoS overrides, ``qos_overrides.*``): no
#: stage's, whichever file or launch sets them (``use_sim_time`` on a cell on its plant's clock).
ROS_OWN = ("use_sim_time", "start_type_description_service")


def stage_names(names: Iterable[str]) -> list[str]:
    """``names`` less rclpy's own (:data:`ROS_OWN`)."""
    return [n for n in names if n not in ROS_OWN and not n.startswith("qos_overrides.")]


def unknown_names(stage: str, table: Sequence[Param], names: Sequence[str]) -> None:
    """Raises :class:`ConfigError` for the first of ``names`` the table does not declare, with
    the closest declared name (a misspelt key would otherwise leave its default in force)."""
    declared = [p.name for p in table]
    for name in names:
        if name not in declared:
            allowed = f"{closest(name, declared)}a name {stage} declares: {declared}"
            raise ConfigError(f"{stage} parameter", name, allowed)


def resolve(stage: str, table: Sequence[Param], given: dict[str, Any]) -> dict[str, Any]:
    """The table's defaults overridden by ``given``, checked as the node checks them on
    declare: a name the stage does not have, a number out of range, a string not a choice."""
    unknown_names(stage, table, stage_names(sorted(given)))
    values = {p.name: given.get(p.name, p.default) for p in table}
    for p in table:
        p.check(values[p.name], stage)
    return values


#: The frame_id of the topics in the hole's frame {H} (features, compensated wrench, command):
#: a transport setting of the three nodes that publish them.
HOLE_FRAME = Param("hole_frame", "hole", "frame_id of the topics in the hole's frame {H} "
                   "(features, compensated wrench, command)")


def frame_id(values: dict[str, Any], name: str) -> str:
    """The frame name of parameter ``name``: not empty, no spaces (a ConfigError)."""
    value = values[name]
    if not value or any(c.isspace() for c in value):
        raise ConfigError(name, value, "a frame name: not empty, no spaces")
    return str(value)


#: The choices of an input's QoS parameter (:mod:`fbcc_ros.ros.inputs`).
INPUT_QOS = ("reliable", "best_effort", "match")
#: Where a node hears the arm's joint states, and with which reliability: transport settings
#: of the nodes that read them (kinematics, dynamic_compensation).
JOINT_STATES = (
    Param("joint_states_topic", "joint_states", "where the arm's joint states come from (e.g. "
          "a joint_state_broadcaster's)"),
    Param("joint_states_qos", "reliable", "reliability of the joint states subscription: "
          "best_effort for a publisher of sensor-data QoS; match: its publishers', subscribed "
          "once one is seen", choices=INPUT_QOS),
)
