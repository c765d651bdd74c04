"""Faults of the cell around our nodes, for the fault drills (:mod:`fbcc_ros.harness.fault_drill`):
a node's process frozen, a stray node publishing onto an input or commanding the arm, a replay
started beside the live cell. Each is done the way it happens on a real cell, beside the running
:class:`~fbcc_ros.harness.cell_run.CellRun`; none touches our nodes' code paths.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String

from fbcc_ros.ros import topics
from fbcc_ros.ros.convert import seconds_to_stamp

#: How far ahead of now a stray stamps its samples [s]: inside the compensation's allowance for
#: two machines' clocks (compensator.MAX_STAMP_AHEAD), so they are taken and the real ones,
#: stamped earlier, look out of order.
STRAY_AHEAD = 0.03
#: A stray publishes at this rate [Hz] (at 100 Hz or 1 kHz alike, a guard that took its samples
#: saw only them).
STRAY_HZ = 100.0
#: Seconds a frozen node stays frozen (the cases met: 0.3-2 s).
FROZEN_FOR = 1.0
#: Seconds a stray node publishes before it leaves.
STRAY_FOR = 0.5
#: A drill's injection: ``inject(run, watch, bag)`` (:class:`fault_drill.Drill`).
Injection = Callable[[Any, Any, Path | None], None]


def freeze(run: Any, name: str, seconds: float, spin: Callable[[float], None]) -> str:
    """The node ``name`` does not run for ``seconds`` (a process stopped, SIGSTOP; in one
    process, its callbacks and the chained calls into it withheld), then goes on where it was;
    ``spin(seconds)`` runs the rest of the cell meanwhile. Returns what was done."""
    if name in run.procs:
        pid = run.procs[name].pid
        os.kill(pid, signal.SIGSTOP)
        try:
            spin(seconds)
        finally:
            os.kill(pid, signal.SIGCONT)
        return f"{name}'s process stopped (SIGSTOP) for {seconds:g} s, then continued"
    run.freeze(name)
    try:
        spin(seconds)
    finally:
        run.thaw(name)
    return f"{name} frozen for {seconds:g} s in this process, then going on"


class Stray(Node):
    """A node of nobody's, publishing onto one of the cell's topics from a timer until
    :meth:`stop`.

    Args:
        run: The running cell (its context, executor and namespace).
        topic: The cell's topic (relative, as our nodes name it).
        kind: ``wrench`` (zeros, stamped :data:`STRAY_AHEAD` ahead, in ``frame``), ``joints``
            (the arm's home, as last heard on joint_states, stamped ahead) or ``command`` (the
            arm's joint positions as last heard: a node that "holds" the arm, left running).
    """

    def __init__(self, run: Any, topic: str, kind: str, frame: str) -> None:
        super().__init__("stray_publisher", context=run.context, namespace=run.namespace)
        self.kind, self.frame = kind, frame
        self.heard: tuple[list[str], np.ndarray] | None = None
        message = {"wrench": WrenchStamped, "joints": JointState,
                   "command": Float64MultiArray}[kind]  # fmt: skip
        self.pub = self.create_publisher(message, topic, 10)
        if kind != "wrench":
            self.create_subscription(JointState, topics.JOINT_STATES, self._hear, 10)
        self.sent = 0
        self.timer = self.create_timer(1.0 / STRAY_HZ, self._publish)
        self.run = run
        run.executor.add_node(self)

    def _hear(self, msg: JointState) -> None:
        self.heard = (list(msg.name), np.asarray(msg.position, dtype=float))

    def _stamp(self) -> Time:
        sec, nanosec = seconds_to_stamp(self.get_clock().now().nanoseconds * 1e-9 + STRAY_AHEAD)
        return Time(sec=sec, nanosec=nanosec)

    def _publish(self) -> None:
        if self.kind == "wrench":
            msg = WrenchStamped()
            msg.header.stamp, msg.header.frame_id = self._stamp(), self.frame
        elif self.heard is None:
            return
        elif self.kind == "joints":
            msg = JointState(name=self.heard[0], position=self.heard[1].tolist())
            msg.header.stamp = self._stamp()
        else:
            msg = Float64MultiArray(data=self.heard[1].tolist())
        self.pub.publish(msg)
        self.sent += 1

    def stop(self) -> None:
        """Stops publishing; the node leaves the graph."""
        self.timer.cancel()
        self.run.executor.remove_node(self)
        self.destroy_node()


def other_session_bag(folder: Path, joint_names: list[str], q: np.ndarray) -> Path:
    """A bag of another session (joint states, joint commands, a phase ``inserted``), as an
    operator would replay beside the cell."""
    from rclpy.qos import QoSProfile
    from rclpy.serialization import serialize_message

    from fbcc_ros.bag.writer import BagWriter

    with BagWriter(folder) as bag:
        bag.add_topic("/joint_states", "sensor_msgs/msg/JointState", [QoSProfile(depth=10)])
        bag.add_topic("/joint_command", "std_msgs/msg/Float64MultiArray", [QoSProfile(depth=10)])
        bag.add_topic("/fbcc/phase", "std_msgs/msg/String", [QoSProfile(depth=1)])
        for k in range(200):  # 0.2 s at 1 kHz, the arm 4 mm off along its first joint
            t = 1_000_000 * (k + 1)
            pose = q + np.r_[4e-3 * k / 200, np.zeros(len(q) - 1)]
            state = JointState(name=joint_names, position=pose.tolist())
            bag.write("/joint_states", serialize_message(state), t)
            bag.write("/joint_command", serialize_message(Float64MultiArray(data=pose.tolist())),
                      t)  # fmt: skip
        bag.write("/fbcc/phase", serialize_message(String(data="inserted")), 200_000_001)
    return folder


def replay_beside(run: Any, joint_names: list[str], q: np.ndarray, args: list[str],
                  timeout: float = 20.0) -> tuple[int, str]:  # fmt: skip
    """``fbcc_replay`` of another session's bag, with ``args``, started beside the running cell
    as its own process; the cell runs on meanwhile. Returns its exit status and its last line."""
    folder = Path(tempfile.mkdtemp(prefix="fbcc_other_session_")) / "bag"
    other_session_bag(folder, joint_names, q)
    cmd = [sys.executable, "-m", "fbcc_ros.nodes.fbcc_replay", str(folder), *args]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    deadline = time.monotonic() + timeout
    while proc.poll() is None and time.monotonic() < deadline:
        run.executor.spin_once(timeout_sec=0.01)
    if proc.poll() is None:
        proc.kill()
    out = proc.communicate()[0]
    lines = out.strip().splitlines()
    return proc.wait(), lines[-1] if lines else ""


def frozen(name: str) -> Injection:
    def inject(run: Any, watch: Any, bag: Path | None) -> None:
        watch.said.append(freeze(run, name, FROZEN_FOR, lambda t: run.spin_for(t, _quiet)))

    return inject


def bias(run: Any) -> tuple[list[float], str]:
    """The compensation's bias and the sensor's frame, from its latched ``ft_sensor/bias``."""
    msg = run.heard(WrenchStamped, topics.BIAS, topics.PHASE_QOS)
    f, m = msg.wrench.force, msg.wrench.torque
    return [f.x, f.y, f.z, m.x, m.y, m.z], msg.header.frame_id


def stray(topic: str, kind: str) -> Injection:
    def inject(run: Any, watch: Any, bag: Path | None) -> None:
        stray = Stray(run, topic, kind, bias(run)[1] if kind == "wrench" else "")
        run.spin_for(STRAY_FOR, _quiet)
        stray.stop()
        watch.said.append(f"a stray node published {stray.sent} messages on {topic} "
                          f"({kind}) for {STRAY_FOR:g} s, then left")  # fmt: skip

    return inject


def replay_beside_drill(run: Any, watch: Any, bag: Path | None) -> None:
    """Another session's bag replayed onto the recorded names beside the running cell."""
    arm = run.heard(JointState, topics.JOINT_STATES)
    status, last = replay_beside(run, list(arm.name), np.asarray(arm.position),
                                 ["--prefix", "/", "--rate", "1"])  # fmt: skip
    watch.said.append(f"fbcc_replay OTHER_BAG --prefix / beside the cell: exit {status}: {last}")
    if status != 0:
        watch.refused.append(f"fbcc_replay refused: {last}")


def _quiet(_: float) -> None:
    """No progress lines while a fault is being injected."""
