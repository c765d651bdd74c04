"""The closed loop at 1 kHz over DDS, against a bare rclpy chain of the same shape.

Both runs use the same mock cell as the source (joint states and raw wrenches each tick, joint
commands back) and the same observer. The *bare* chain has three nodes with our nodes' topics,
message types and subscriptions, doing no work: compensation copies the wrench, the controller
answers each wrench with a fixed pose stamped with the sample's stamp, the kinematics answers
with the last joint positions. So the difference between the two is what our computation and
our message handling cost. Either chain runs in one process or with each node in its own
(``processes``: the bare nodes through :func:`main`), and each is compared with the other in the
same shape. Figures per run:

While it measures, the observer listens only to what the figures need (joint commands, TCP
commands, the phase), not to the truth, compensated wrenches and features the bringup watches:
the instrument should load the loop it measures as little as it can.

The ``fbcc`` chain runs the scenario's law (the stiffness-robust default: identification,
guard, axis insertion; ``loop_delay`` 0.05 s, as the hardware-free cell states it) or, with
``table_i``, the same scenario on Table I label 3, so that the two laws' cost to the loop
compare.

- cycles delivered: joint commands received / periods of the run (rate × seconds);
- latency: sensor stamp → TCP command received, p50 and p99 (both on the system clock);
- CPU per node, as a share of one core (:mod:`fbcc_ros.harness.cell_run`).
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.harness.cell_run import CellRun, NodeSpec
from fbcc_ros.ros import topics

SCENARIO = "config/scenarios/bringup_interference.yaml"
#: ``controller.params`` of the ``table_i`` run: the paper's law at its label 3.
TABLE_I_PARAMS = {"label": 3}


class BareCompensation(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("dynamic_compensation", **kwargs)
        pub = self.create_publisher(WrenchStamped, topics.COMPENSATED_WRENCH, 10)
        self.create_subscription(WrenchStamped, topics.RAW_WRENCH, pub.publish, 10)


class BareController(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("fbcc_controller", **kwargs)
        self.pub = self.create_publisher(PoseStamped, topics.COMMAND, 10)
        self.command = PoseStamped()
        self.features: PoseStamped | None = None
        self.create_subscription(WrenchStamped, topics.COMPENSATED_WRENCH, self.on_wrench, 10)
        self.create_subscription(PoseStamped, topics.FEATURES, self.on_features, 10)

    def on_wrench(self, msg: WrenchStamped) -> None:
        self.command.header = msg.header
        self.pub.publish(self.command)

    def on_features(self, msg: PoseStamped) -> None:
        self.features = msg


class BareKinematics(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("kinematics", **kwargs)
        self.q: list[float] | None = None
        self.pub_features = self.create_publisher(PoseStamped, topics.FEATURES, 10)
        self.pub_joints = self.create_publisher(Float64MultiArray, topics.JOINT_COMMAND, 10)
        self.pub_tcp = self.create_publisher(PoseStamped, topics.TCP_COMMAND, 10)
        self.features = PoseStamped()
        self.create_subscription(JointState, topics.JOINT_STATES, self.on_joints, 10)
        self.create_subscription(PoseStamped, topics.COMMAND, self.on_command, 10)

    def on_joints(self, msg: JointState) -> None:
        self.q = list(msg.position)
        self.features.header = msg.header
        self.pub_features.publish(self.features)

    def on_command(self, msg: PoseStamped) -> None:
        if self.q is not None:
            self.pub_joints.publish(Float64MultiArray(data=self.q))
            self.pub_tcp.publish(msg)


#: This module, which runs a bare node in its own process (:func:`main`).
MODULE = "fbcc_ros.harness.loop_bench"
#: The bare chain's nodes by name.
BARE = {"dynamic_compensation": BareCompensation, "kinematics": BareKinematics,
        "fbcc_controller": BareController}  # fmt: skip


@dataclass
class LoopFigures:
    chain: str
    seconds: float
    delivered: float  # joint commands / periods
    latency_p50_us: float
    latency_p99_us: float
    cpu: dict[str, float]  # share of one core, per node


def measure(
    chain: str,
    seconds: float,
    processes: bool = False,
    table_i: bool = False,
    recorder: bool = False,
    rate_hz: float | None = None,
    chained: bool = True,
) -> LoopFigures:
    """Runs the ``bare`` or the ``fbcc`` chain for ``seconds`` at the scenario's rate (or
    ``rate_hz``); with ``table_i``, the ``fbcc`` chain runs Table I label 3 (module doc);
    with ``recorder``, an fbcc_record in its own process records the cell's topics, as the
    bringup does; ``chained=False`` passes every message through DDS even in one process
    (:class:`CellRun`'s ``chain``)."""
    from fbcc_ros.core.sim.scenario import find as find_scenario

    path = find_scenario(SCENARIO)
    data = yaml.safe_load(path.read_text())
    if table_i:
        data["controller"] = {"type": "fbcc", "params": TABLE_I_PARAMS}
    if rate_hz is not None:
        data["rate_hz"] = rate_hz
    with tempfile.TemporaryDirectory() as folder:
        run_path = Path(folder) / "scenario.yaml"
        run_path.write_text(yaml.safe_dump(data))
        bag = Path(folder) / "bag" if recorder else None
        return _measure(chain, seconds, processes, str(run_path), bag, chained)


def _measure(
    chain: str, seconds: float, processes: bool, path: str, bag: Path | None, chained: bool
) -> LoopFigures:
    from fbcc_ros.nodes.bringup import (
        cell_nodes,
        recorded_topics,
        recorder,
        start_insertion,
        wait_recording,
    )

    sc = scenario_io.load(path)
    specs = cell_nodes(path, sc, "fbcc", processes=processes)
    if chain == "bare":  # the mock stays; each of our nodes is replaced by its bare twin
        specs = [specs[0]] + [NodeSpec(s.name, BARE[s.name], own_process=s.own_process,
                                       module=(MODULE, s.name)) for s in specs[1:]]  # fmt: skip
    if bag is not None:
        specs.append(recorder(bag, recorded_topics("fbcc")))
    with CellRun(specs, processes=processes, probe=True, chain=chained) as run:
        if bag is not None:
            wait_recording(run, 30.0, recorded_topics("fbcc"))
        if chain == "bare":
            run.spin_until(lambda: len(run.observer.latency) > 100, 10.0, "no TCP command")
        else:
            start_insertion(run, timeout=30.0 if processes else 10.0)
        run.observer.probe_only()
        run.spin_for(0.1, lambda _: None)  # the graph learns the observer stopped listening
        run.observer.reset_counts()
        cpu0 = run.cpu()
        run.spin_for(seconds, lambda _: None)
        cpu = {k: (v - cpu0[k]) / seconds for k, v in run.cpu().items()}
        latency = np.array(run.observer.latency) * 1e6
        commands = run.observer.counts["commands"]
    if latency.size == 0:
        latency = np.array([np.nan])
    return LoopFigures(
        chain,
        seconds,
        commands / (seconds * sc.rate_hz),
        float(np.percentile(latency, 50)),
        float(np.percentile(latency, 99)),
        cpu,
    )


def main() -> None:
    """``python -m fbcc_ros.harness.loop_bench NAME --ros-args ...``: the bare node ``NAME``
    (a key of :data:`BARE`) in its own process, for the bare chain as processes."""
    import sys

    from fbcc_ros.ros.params import run

    run(BARE[sys.argv[1]])


if __name__ == "__main__":
    main()
