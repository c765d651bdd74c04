"""The contact state online, over DDS: the controller publishes the deviation filter's state
probabilities (``fbcc/contact_state_estimate``) once someone listens, here a recorder of the
cell's topics started on its own, as on a real cell. What it published, read back from the bag
by rosbags (an independent reader), is what the same filter gives along the recorded session."""

from __future__ import annotations

import signal
import time
from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader

from fbcc_ros.bag.reader import read_bag
from fbcc_ros.cli import report, report_states
from fbcc_ros.core.contact.segmentation import STATES
from fbcc_ros.core.sim import scenario as scenario_io
from test.nodes.conftest import kill_left, recorder_and_cell

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "config" / "scenarios" / "bringup_interference.yaml"


#: A live cell over DDS on a shared two-core machine: repeated, at most twice, as the loop's are.
@pytest.mark.flaky(reruns=2)
def test_the_controllers_contact_states_are_the_filters_along_the_recorded_session(
    tmp_path: Path,
) -> None:
    folder = tmp_path / "session"
    log_path = tmp_path / "log.txt"
    log = log_path.open("w")
    recorder, cell = recorder_and_cell(folder, log, str(SCENARIO), "--out",
                                       str(tmp_path / "cell"))  # fmt: skip
    try:
        assert cell.wait(timeout=120) == 0, log_path.read_text()
        time.sleep(0.5)  # the last answers reach the recorder
        recorder.send_signal(signal.SIGINT)  # a clean stop: the bag is closed
        recorder.wait(timeout=20)
    finally:
        kill_left(cell, recorder)
    assert "contact-state filter started" in log_path.read_text()
    with AnyReader([folder]) as reader:
        connections = [c for c in reader.connections if c.topic == report_states.RECORDED]
        assert connections and connections[0].msgtype == "std_msgs/msg/Float64MultiArray"
        messages = [reader.deserialize(raw, c.msgtype)
                    for c, _, raw in reader.messages(connections=connections)]  # fmt: skip
    fields = messages[0].layout.dim[0].label.split()
    assert fields == ["stamp", *(f"{p}:{s}" for p in ("xoz", "yoz") for s in STATES)]
    rows = np.array([m.data for m in messages])
    assert np.allclose(rows[:, 1:].reshape(-1, 2, len(STATES)).sum(axis=2), 1.0)
    bag = read_bag(folder)
    nominal = report.nominal_geometry(bag, SCENARIO)
    s = report.session(bag, nominal)
    online = report_states.recorded_states(bag, s, nominal)
    offline = report_states.estimate_states(s, nominal)
    assert online is not None and offline is not None
    # the session recorded is the whole run: it spans the scenario's duration (how many
    # filter updates fill it, one per fifth loop cycle, is the loop's: 802 on an idle machine,
    # ~390 on one that delivers a third of the cycles). The filter lags the loop on a busy
    # machine (it had answered none when a starved run ended); the stopping controller sends
    # what it still owed, so every update of the insertion is recorded
    duration = scenario_io.load(SCENARIO).duration
    n = len(online["t"])
    assert n == len(rows) == len(offline["t"]) and n >= 100, (n, len(offline["t"]))
    assert offline["t"][-1] > 0.95 * duration, (offline["t"][-1], duration)
    np.testing.assert_array_equal(np.sort(rows[:, 0]) - s.t0, online["t"])
    np.testing.assert_array_equal(online["t"], offline["t"])
    np.testing.assert_allclose(online["p"], offline["p"], rtol=0, atol=1e-12)


def test_the_filter_starts_for_a_listener_and_its_end_is_said_once(tmp_path: Path) -> None:
    """No listener, no process; a listener starts it; a filter that dies is said once and the
    node goes on."""
    import rclpy
    from std_msgs.msg import Float64MultiArray

    from fbcc_ros.nodes.fbcc_controller import FbccControllerNode
    from fbcc_ros.ros import topics

    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = FbccControllerNode(context=context)
        node.on_watchdog()
        assert node.stage.state_worker is None  # nobody listens
        node.create_subscription(Float64MultiArray, topics.CONTACT_STATE_ESTIMATE,
                                 lambda _: None, 10)  # fmt: skip
        end = time.monotonic() + 10.0
        while node.stage.state_worker is None and time.monotonic() < end:
            node.on_watchdog()
            time.sleep(0.01)
        worker = node.stage.state_worker
        assert worker is not None and worker.alive
        worker._process.kill()
        worker._process.wait()
        for _ in range(3):
            node.on_watchdog()
        assert node._state_filter_gone and worker.exit_code is not None
        assert node.sup.phase == "idle"  # the controller is not disturbed
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
        context.destroy()
