"""Offline replay: a bag's raw wrenches and joint states through the cell's stages
(:mod:`fbcc_ros.pipeline`: compensation, kinematics, controller), without ROS, and its commands
against the ones the cell recorded.

What the live nodes do per message, done here by the same stages in the bag's order:

* ``joint_states`` → the kinematics stage's peg pose → the controller stage's features; for a
  wrist sensor also the compensation stage's joints;
* ``ft_sensor/noise`` (the noise the live tare measured) → the controller stage, as live;
* the compensation's input → the compensation stage → one control period of the controller
  stage → the command. The input is the raw wrench on ``wrench_topic`` (``ft_sensor/raw`` by
  default), or for a virtual sensor the joint torques: the measured ones in ``joint_states``
  (``joint_torques: measured``) or ``external_joint_torques``. A joint state that is also the
  virtual sensor's sample goes to the compensation before the kinematics, as the one-process
  cell takes it: the controller steps on the features of the joint state before.

**The namespace.** A cell run in a namespace (``/lbr`` beside the LBR stack) records its topics
under it: the replay reads the namespace of the bag's one ``joint_states`` (or the one given).

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
import functools
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fbcc_ros.bag.reader import Bag
from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.compensator import Compensated
from fbcc_ros.core.control.phase import WAITING
from fbcc_ros.core.errors import InputError
from fbcc_ros.core.files import read_yaml
from fbcc_ros.core.param_files import node_of
from fbcc_ros.pipeline import compensation, controller, kinematics
from fbcc_ros.pipeline.parameters import flatten, resolve
from fbcc_ros.ros.cdr import decode_stamp, decode_string, decode_wrench
from fbcc_ros.ros.convert import (
    efforts_from_cdr,
    joints_from_cdr,
    pose_from_cdr,
    stamp_to_seconds,
    wrench_from_cdr,
)

#: The file ``fbcc_bringup`` writes beside the bag's .mcap: each cell node's parameters.
PARAMS_FILE = "fbcc_params.yaml"
#: The nodes whose stage the offline replay runs, and the topics it needs from a bag.
NODES = ("dynamic_compensation", "kinematics", "fbcc_controller")
JOINT_STATE, WRENCH = "sensor_msgs/msg/JointState", "geometry_msgs/msg/WrenchStamped"


def bag_namespace(bag: Bag) -> str:
    """The namespace of the cell a bag recorded: that of its one ``joint_states`` ('' at the
    root); an InputError naming them if it has none or several."""
    found = sorted(t for t, kind in bag.topics.items() if t.endswith("/joint_states")
                   and kind == JOINT_STATE and bag.counts[t])  # fmt: skip
    if len(found) != 1:
        have = {t: f"{k} ({bag.counts[t]})" for t, k in bag.topics.items()}
        raise InputError("bag topics", have, "one sensor_msgs/msg/JointState topic named "
                         f"<namespace>/joint_states with messages, not {found or 'none'} "
                         "(--namespace chooses one)")  # fmt: skip
    return found[0].removesuffix("/joint_states")


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
        doc = read_yaml(file, "--params")
        if not isinstance(doc, dict):
            raise InputError("--params", str(file), "YAML of node_name: ros__parameters: ...")
        for node, body in doc.items():
            params = (body or {}).get("ros__parameters", {}) if isinstance(body, dict) else None
            if not isinstance(params, dict):
                raise InputError(f"{file}: {node}", body, "ros__parameters: {name: value}")
            given.setdefault(node_of(node), {}).update(flatten(params))
    return given


class OfflineCell:
    """The compensation, kinematics and controller stages of one cell, configured as its nodes
    (``given``: each node's parameters by name; the rest are the defaults; ``description``:
    the URDF the session latched on robot_description, for ``robot: robot_description``)."""

    def __init__(self, given: dict[str, dict[str, Any]], description: str | None = None
                 ) -> None:  # fmt: skip
        stages = (compensation, kinematics, controller)
        comp, kin, ctrl = (resolve(node, stage.TABLE, given.get(node, {}))
                           for node, stage in zip(NODES, stages, strict=True))  # fmt: skip
        self.compensation = compensation.CompensationStage(comp, description)
        self.kinematics = kinematics.KinematicsStage(kin, description)
        self.controller = controller.ControllerStage(ctrl)
        self.wrist = self.compensation.robot is not None
        #: the compensation's input (relative), and its type
        self.input = (("joint_states", JOINT_STATE) if self.compensation.measured
                      else ("external_joint_torques", JOINT_STATE) if self.compensation.virtual
                      else (comp["wrench_topic"], WRENCH))  # fmt: skip


def replay_offline(bag: Bag, given: dict[str, dict[str, Any]], namespace: str | None = None
                   ) -> OfflineResult:  # fmt: skip
    """Runs ``bag`` through an :class:`OfflineCell` configured by ``given``; the cell's topics
    under ``namespace`` (default: :func:`bag_namespace`)."""
    ns = bag_namespace(bag) if namespace is None else "/" + namespace.strip("/")
    ns = "" if ns == "/" else ns

    def name(topic: str) -> str:
        return topic if topic.startswith("/") else f"{ns}/{topic}"

    joints_topic = name("joint_states")
    bag.require({joints_topic: JOINT_STATE})
    latched = [decode_string(m.data) for m in bag.of(name("robot_description"))]
    cell = OfflineCell(given, latched[-1] if latched else None)
    input_topic = name(cell.input[0])
    bag.require({input_topic: cell.input[1]})
    names = cell.kinematics.joint_names
    comp = cell.compensation
    flow = _recorded_flow(bag, cell, name, input_topic)
    counts = flow.counts
    counts.update(compensated=0, stepped=0, dropped_by_controller=0)
    ctrl = cell.controller
    start = min(flow.commands) if flow.commands else None
    t, commands, matched = [], [], []

    def step(stamp: float, sample: Callable[[], Compensated | None]) -> None:
        """One sample of the compensation's input, through the controller as live."""
        key = _key(stamp)
        if flow.fed is not None and key not in flow.fed:
            return
        out = sample()
        if out is None:
            return
        counts["compensated"] += 1
        if start is not None:
            if key < start:  # not started yet: the idle controller hears it, as live
                ctrl.wrench(stamp, stamp, out.wrench)
                return
            if key not in flow.commands:
                counts["dropped_by_controller"] += 1
                return
        if ctrl.sup.phase in WAITING and not ctrl.sup.start(stamp)[0]:
            # not armed (no recent features or wrench): counted, tried again on the next sample
            counts["start_refused"] = counts.get("start_refused", 0) + 1
            return
        command = ctrl.wrench(stamp, stamp, out.wrench)
        if command is None:
            return
        counts["stepped"] += 1
        t.append(stamp)
        commands.append(ctrl.features_of(command))
        matched.append(flow.commands.get(key, np.full(5, np.nan)))

    noise_topic = name("ft_sensor/noise")
    for m in bag.messages:
        if m.topic == noise_topic:  # the tare's: the robust law takes it, as live
            ctrl.noise(wrench_from_cdr(m.data)[2])
        elif m.topic == joints_topic:
            stamp, q, dq = joints_from_cdr(m.data, names)
            if comp.measured:  # the same joint state is the virtual sensor's sample
                effort = efforts_from_cdr(m.data, names)[1]
                step(stamp, functools.partial(comp.measured_torques, stamp, q, dq, effort))
            elif cell.wrist:
                comp.joints(stamp, q, dq)
            ctrl.features(stamp, cell.kinematics.joints(q), stamp)
        elif m.topic == input_topic:
            if comp.virtual:
                stamp, tau = efforts_from_cdr(m.data, names)
                step(stamp, functools.partial(comp.torques, stamp, tau))
            else:
                stamp, frame, wrench = wrench_from_cdr(m.data)
                step(stamp, functools.partial(comp.reading, stamp, frame, wrench))
    counts["bias_used"] = comp.comp.bias.tolist()  # recorded, or tared from the bag
    return OfflineResult(np.array(t), np.array(commands).reshape(-1, 5),
                         np.array(matched).reshape(-1, 5), counts, ctrl.said)  # fmt: skip


@dataclasses.dataclass
class _Flow:
    """What the live nodes processed, read from their outputs' stamps."""

    fed: set[int] | None  # raw samples the compensation took (None: all)
    commands: dict[int, FloatArray]  # sample -> the command that answered it, as features
    counts: dict[str, Any]


def _recorded_flow(bag: Bag, cell: OfflineCell, name: Callable[[str], str], input_topic: str
                   ) -> _Flow:  # fmt: skip
    """The raw samples the live compensation took, and the bias it used.

    The samples: the ones its outputs answer. The bias: the one it published on
    ``ft_sensor/bias`` (latched: the last is the one in use), so its tare is not redone. A bag
    without it gets the tare redone on the ``tare_samples`` raw samples before the first output
    (fewer if the bag begins later); a sample the live tare missed then shifts the bias a little
    (``bias: retared`` in the counts). Sets ``cell``'s compensator to match."""
    def keys(topic: str) -> list[int]:
        return [_key(stamp_to_seconds(decode_stamp(m.data))) for m in bag.of(topic)]

    raw, outputs = keys(input_topic), set(keys(name("ft_sensor/compensated")))
    commands: dict[int, FloatArray] = {}
    for m in bag.of(name("fbcc/command")):  # the peg in {H}: back to the controller's features
        stamp, peg = pose_from_cdr(m.data)
        commands[_key(stamp)] = cell.controller.features_of(peg)
    counts: dict[str, Any] = {"raw": len(raw), "dropped_by_compensation": 0}
    if not outputs:
        return _Flow(None, commands, counts)
    first = min(outputs)
    counts["dropped_by_compensation"] = sum(k >= first and k not in outputs for k in raw)
    biases = list(bag.of(name("ft_sensor/bias")))
    if biases:
        cell.compensation.retare(0, decode_wrench(biases[-1].data)[2])
        counts["bias"] = "recorded"
        return _Flow(outputs, commands, counts)
    before = [k for k in raw if k < first]
    tare = before[len(before) - min(len(before), cell.compensation.setup.tare_samples) :]
    cell.compensation.retare(len(tare))
    counts.update(bias="retared", tare_in_bag=len(tare))
    return _Flow(set(tare) | outputs, commands, counts)
