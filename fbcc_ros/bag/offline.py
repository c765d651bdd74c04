"""Offline replay: a bag's raw wrenches and joint states through the compensation, kinematics and
controller core, without ROS, and its commands against the ones the cell recorded.

What the live nodes did per message, done here in the bag's order:

* ``joint_states`` → the feature solution (``CellKinematics.peg_in_hole``, then
  ``features_from_pose`` with the nominal radius, as the controller reads the kinematics' pose)
  → the supervisor's features; for a wrist sensor also the compensator's joints;
* ``ft_sensor/raw`` → ``Compensator.reading`` → ``response_from_wrench`` → one control period
  of the supervisor → the command features.

**Following the recorded flow.** A loaded cell drops samples: a node's queue overflows during a
stall, and that node never sees the sample. The bag says which samples each node did process,
because every output is stamped with the sample it answers. When the bag holds the compensated
wrenches, only the raw samples they answer are compensated here (plus the ones before the first
output, the taring); when it holds commands, the controller steps only on the samples they
answer, and starts where the first command is. The drops are counted in the result. A bag with
no outputs (a real cell recorded without the controller, say) is replayed sample by sample.

The parameters are the nodes': each node's table defaults, overridden by ros__parameters YAML
files (``--params``) or, by default, the ``fbcc_params.yaml`` that ``fbcc_bringup`` writes into
the bags it records.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from fbcc_ros.bag.reader import Bag
from fbcc_ros.core.errors import ConfigError, InputError

FloatArray = NDArray[np.float64]

#: The file ``fbcc_bringup`` writes beside the bag's .mcap: each cell node's parameters.
PARAMS_FILE = "fbcc_params.yaml"
#: The nodes whose core the offline replay runs, and the topics it needs from a bag.
NODES = ("dynamic_compensation", "kinematics", "fbcc_controller")
NEEDED = {"/joint_states": "sensor_msgs/msg/JointState",
          "/ft_sensor/raw": "geometry_msgs/msg/WrenchStamped"}  # fmt: skip


def _key(seconds: float) -> int:
    """A sample's identity: its stamp to 10 µs (stamps are 1 ms apart; a float of epoch seconds
    keeps ~0.2 µs, so the nanoseconds do not survive a round trip through it)."""
    return round(seconds * 1e5)


@dataclasses.dataclass
class OfflineResult:
    """The replay's commands beside the recorded ones.

    Attributes:
        t: Stamps of the samples the controller answered [s].
        commands: Command features computed here, (N, 5).
        recorded: The recorded command for each of those samples, (N, 5); NaN where the bag
            has none.
        counts: Samples read, compensated, stepped; what the live nodes dropped; whether the
            bias was the recorded one.
        phase: The supervisor's phase at the end, and why.
    """

    t: FloatArray
    commands: FloatArray
    recorded: FloatArray
    counts: dict[str, Any]
    phase: str

    def max_error(self) -> FloatArray:
        """Largest |computed - recorded| per feature over the samples both have, (5,)."""
        both = np.isfinite(self.recorded).all(axis=1)
        if not both.any():
            return np.full(5, np.nan)
        return np.abs(self.commands[both] - self.recorded[both]).max(axis=0)  # type: ignore[no-any-return]


def node_parameters(bag_path: Path, files: Sequence[Path] = ()) -> dict[str, dict[str, Any]]:
    """Each node's given parameters: from ``files`` (ros__parameters YAML, later files win),
    else from the bag folder's ``fbcc_params.yaml``, else none (the defaults)."""
    folder = bag_path if bag_path.is_dir() else bag_path.parent
    if not files and (folder / PARAMS_FILE).is_file():
        files = [folder / PARAMS_FILE]
    given: dict[str, dict[str, Any]] = {}
    for file in files:
        try:
            doc = yaml.safe_load(Path(file).read_text())
        except (OSError, yaml.YAMLError) as exc:
            raise InputError("--params", str(file), f"a readable YAML file ({exc})") from exc
        if not isinstance(doc, dict):
            raise InputError("--params", str(file), "YAML of node_name: ros__parameters: ...")
        for node, body in doc.items():
            params = (body or {}).get("ros__parameters", {}) if isinstance(body, dict) else None
            if not isinstance(params, dict):
                raise InputError(f"{file}: {node}", body, "ros__parameters: {name: value}")
            given.setdefault(str(node).lstrip("/"), {}).update(flatten_parameters(params))
    return given


def flatten_parameters(params: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{payload: {mass: 1}}`` → ``{"payload.mass": 1}``, as ROS names nested parameters."""
    out: dict[str, Any] = {}
    for name, value in params.items():
        if isinstance(value, dict):
            out.update(flatten_parameters(value, f"{prefix}{name}."))
        else:
            out[f"{prefix}{name}"] = value
    return out


def table_values(node: str, table: Sequence[Any], given: dict[str, Any]) -> dict[str, Any]:
    """The table's defaults overridden by ``given``, checked as rclpy checks them on declare
    (a name the node does not have, a number out of range, a string not among the choices)."""
    from fbcc_ros.nodes.params import check_choice

    by_name = {p.name: p for p in table}
    unknown = sorted(set(given) - set(by_name))
    if unknown:
        raise ConfigError(f"{node} parameters", unknown, f"names of {node}: {sorted(by_name)}")
    values = {p.name: given.get(p.name, p.default) for p in table}
    for p in table:
        value = values[p.name]
        check_choice(p, value)
        if p.low is not None and p.high is not None and not p.low <= value <= p.high:
            raise ConfigError(f"{node}.{p.name}", value, f"within [{p.low}, {p.high}] {p.unit}")
    return values


class OfflineCell:
    """The compensation, kinematics and controller core of one cell, configured as its nodes."""

    def __init__(self, given: dict[str, dict[str, Any]]) -> None:
        from fbcc_ros.core import scenario as scenario_io
        from fbcc_ros.core.compensation import Compensator
        from fbcc_ros.core.control import make_law
        from fbcc_ros.core.kinematics import CellKinematics
        from fbcc_ros.core.supervisor import Supervisor
        from fbcc_ros.nodes import dynamic_compensation, fbcc_controller, kinematics
        from fbcc_ros.nodes.params import cell_from, find_scenario

        comp = table_values(NODES[0], dynamic_compensation.TABLE, given.get(NODES[0], {}))
        kin = table_values(NODES[1], kinematics.TABLE, given.get(NODES[1], {}))
        ctrl = table_values(NODES[2], fbcc_controller.TABLE, given.get(NODES[2], {}))
        if comp["virtual_sensor"]:
            raise ConfigError("virtual_sensor", True, "false: the offline replay reads the raw "
                              "wrench (ft_sensor/raw), not external joint torques")  # fmt: skip
        robot, hole = cell_from(kin)
        self.kinematics = CellKinematics(robot, hole, kin["peg_radius"])
        sensor_robot, sensor_hole = cell_from(comp)
        self._setup = dynamic_compensation.setup_from(comp, sensor_hole)
        self.wrist = self._setup.placement == "wrist"
        self._sensor_robot = sensor_robot if self.wrist else None
        self.compensator = Compensator(self._setup, self._sensor_robot)
        sc = scenario_io.load(find_scenario(ctrl["scenario"]))
        self.nominal = sc.geometry
        law = make_law(ctrl["law"], sc.geometry, sc.params, sc.insertion)
        limits = fbcc_controller.safety_limits(ctrl)
        self.supervisor = Supervisor(law, 1.0 / ctrl["rate_hz"], limits)

    def retare(self, samples: int, bias: Sequence[float] | None = None) -> None:
        """A fresh compensator that tares on ``samples`` readings (at most its setup's), or
        that uses ``bias`` as it is, with no tare."""
        from fbcc_ros.core.compensation import Compensator

        tare = 0 if bias is not None else min(samples, self._setup.tare_samples)
        setup = dataclasses.replace(self._setup, tare_samples=tare)
        if bias is not None:
            setup = dataclasses.replace(setup, bias=tuple(bias))
        self.compensator = Compensator(setup, self._sensor_robot)

    def features(self, q: FloatArray) -> FloatArray:
        """The feature solution, as the controller reads it from the kinematics' pose."""
        from fbcc_ros.core.features import features_from_pose

        peg = self.kinematics.peg_in_hole(q)
        return features_from_pose(peg.rotation, peg.translation, self.nominal.peg_radius)


def replay_offline(bag: Bag, given: dict[str, dict[str, Any]]) -> OfflineResult:
    """Runs ``bag`` through an :class:`OfflineCell` configured by ``given``."""
    from fbcc_ros.core.wrench import response_from_wrench
    from fbcc_ros.nodes.convert import joints_from_cdr, wrench_from_cdr

    bag.require(NEEDED)
    cell = OfflineCell(given)
    names = cell.kinematics.robot.joint_names
    flow = _recorded_flow(bag, cell)
    counts = flow.counts
    counts.update(compensated=0, stepped=0, dropped_by_controller=0)
    sup = cell.supervisor
    start = min(flow.commands) if flow.commands else None
    t, commands, matched = [], [], []
    for m in bag.messages:
        if m.topic == "/joint_states":
            stamp, q, dq = joints_from_cdr(m.data, names)
            sup.on_features(stamp, cell.features(q))
            if cell.wrist:
                cell.compensator.joints(stamp, q, dq)
            continue
        if m.topic != "/ft_sensor/raw":
            continue
        stamp, frame, wrench = wrench_from_cdr(m.data)
        key = _key(stamp)
        if flow.fed is not None and key not in flow.fed:
            continue
        out = cell.compensator.reading(stamp, frame, wrench)
        if out is None:
            continue
        counts["compensated"] += 1
        if start is not None:
            if key < start:
                continue  # the insertion had not started yet
            if key not in flow.commands:
                counts["dropped_by_controller"] += 1
                continue
        if sup.phase == "idle":
            sup.start(stamp)
        command = sup.on_response(stamp, response_from_wrench(out.wrench), stamp)
        if command is None:
            continue
        counts["stepped"] += 1
        t.append(stamp)
        commands.append(command.copy())
        matched.append(flow.commands.get(key, np.full(5, np.nan)))
    phase = f"{sup.phase}: {sup.reason}" if sup.reason else sup.phase
    counts["bias_used"] = cell.compensator.bias.tolist()  # recorded, or tared from the bag
    return OfflineResult(np.array(t), np.array(commands).reshape(-1, 5),
                         np.array(matched).reshape(-1, 5), counts, phase)  # fmt: skip


@dataclasses.dataclass
class _Flow:
    """What the live nodes processed, read from their outputs' stamps."""

    fed: set[int] | None  # raw samples the compensation took (None: all)
    commands: dict[int, FloatArray]  # sample -> the command that answered it, as features
    counts: dict[str, Any]


def _recorded_flow(bag: Bag, cell: OfflineCell) -> _Flow:
    """The raw samples the live compensation took, and the bias it used.

    The samples: the ones its outputs answer. The bias: the one it published on
    ``ft_sensor/bias`` (latched: the last is the one in use), so its tare is not redone. A bag
    without it gets the tare redone on the ``tare_samples`` raw samples before the first output
    (fewer if the bag begins later); a sample the live tare missed then shifts the bias a little
    (``bias: retared`` in the counts). Sets ``cell``'s compensator to match."""
    from fbcc_ros.core.features import features_from_pose
    from fbcc_ros.nodes.cdr import decode_wrench
    from fbcc_ros.nodes.convert import pose_from_cdr, stamp_to_seconds

    def keys(topic: str) -> list[int]:
        return [_key(stamp_to_seconds(decode_wrench(m.data)[0])) for m in bag.of(topic)]

    raw, outputs = keys("/ft_sensor/raw"), set(keys("/ft_sensor/compensated"))
    commands: dict[int, FloatArray] = {}
    for m in bag.of("/fbcc/command"):  # the peg's pose in {H}: back to the controller's features
        stamp, peg = pose_from_cdr(m.data)
        radius = cell.nominal.peg_radius
        commands[_key(stamp)] = features_from_pose(peg.rotation, peg.translation, radius)
    counts: dict[str, Any] = {"raw": len(raw), "dropped_by_compensation": 0}
    if not outputs:
        return _Flow(None, commands, counts)
    first = min(outputs)
    counts["dropped_by_compensation"] = sum(k >= first and k not in outputs for k in raw)
    biases = list(bag.of("/ft_sensor/bias"))
    if biases:
        cell.retare(0, decode_wrench(biases[-1].data)[2])
        counts["bias"] = "recorded"
        return _Flow(outputs, commands, counts)
    before = [k for k in raw if k < first]
    tare = before[len(before) - min(len(before), cell.compensator.setup.tare_samples) :]
    cell.retare(len(tare))
    counts.update(bias="retared", tare_in_bag=len(tare))
    return _Flow(set(tare) | outputs, commands, counts)
