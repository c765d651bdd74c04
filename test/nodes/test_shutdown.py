"""Every node of the cell, each in its own process, ends cleanly on SIGINT or SIGTERM in every
state: while its modules load, armed and idle, inserting, aborted. Exit status 0, nothing
logged as an error, no traceback, the recorder's bag closed (the independent reader opens it);
stopped while inserting, the kinematics holds the arm at its measured joints and the controller
aborts with a hold."""

from __future__ import annotations

import signal
import subprocess
import time
from pathlib import Path

import pytest
from rosbags.rosbag2 import Reader

from fbcc_ros.core.sim import scenario
from fbcc_ros.harness.cell_run import CellRun
from fbcc_ros.nodes.bringup import (
    cell_nodes,
    recorded_topics,
    recorder,
    start_insertion,
    wait_recording,
)
from fbcc_ros.ros.process import LEASE_PROFILE, PROFILE_VARIABLE, short_lease
from test.nodes.test_cell_ros import REALTIME, SCENARIO

#: The states a cell is stopped in, and the signal: as Ctrl-C in a terminal (or ros2 launch)
#: sends SIGINT to every process at once; as a process manager (systemd, docker stop) SIGTERM.
STATES = [("loading", signal.SIGTERM), ("loading", signal.SIGINT), ("armed", signal.SIGTERM),
          ("inserting", signal.SIGINT), ("inserting", signal.SIGTERM),
          ("aborted", signal.SIGINT)]  # fmt: skip


@REALTIME
@pytest.mark.parametrize(("state", "sig"), STATES, ids=[f"{s}-{g.name}" for s, g in STATES])
def test_every_node_ends_cleanly_on_a_signal(state: str, sig: signal.Signals,
                                             tmp_path: Path) -> None:  # fmt: skip
    sc = scenario.load(SCENARIO)
    recorded = recorded_topics(sc.cell.conventions)
    bag = tmp_path / "bag"
    specs = [*cell_nodes(str(SCENARIO), sc, "fbcc", processes=True), recorder(bag, recorded)]
    logs = tmp_path / "logs"
    with CellRun(specs, processes=True, log_dir=logs) as run:
        if state == "loading":
            time.sleep(0.3)  # importing rclpy, Pinocchio, numba
        else:
            wait_recording(run, 30.0, recorded)
            if state == "armed":
                run.spin_until(lambda: run.observer.phase == "armed", 30.0, "not armed")
            else:
                start_insertion(run, timeout=30.0)
                run.spin_for(0.5, lambda _: None)
            if state == "aborted":
                run.call(run.observer.abort_client)
                run.spin_until(lambda: run.observer.phase == "aborted", 5.0, "not aborted")
            assert run.observer.phase == state, run.observer.phase
        for proc in run.procs.values():  # all at once, as a terminal's Ctrl-C does
            proc.send_signal(sig)
        status = {}
        for name, proc in run.procs.items():
            try:
                status[name] = proc.wait(timeout=10)
            except subprocess.TimeoutExpired:  # reported below, with the logs
                status[name] = None
    said = {p.stem: p.read_text(errors="replace") for p in logs.glob("*.log")}
    assert status == dict.fromkeys(status, 0), (status, said)
    for name, text in said.items():
        assert "Traceback" not in text and "[ERROR]" not in text, (name, text)
    if state != "loading":  # the recorder ran: its bag is closed, whole
        with Reader(bag) as r:
            assert sum(c.msgcount for c in r.connections) > 0
    if state == "inserting":
        assert "held at its measured joints" in said["kinematics"], said["kinematics"]
        assert "aborted, held at the measured pose" in said["fbcc_controller"]


def test_a_killed_node_leaves_the_graph_within_its_short_lease(tmp_path: Path) -> None:
    """SIGKILL leaves no goodbye: the node's publishers stay in the graph for its DDS lease,
    3 s for our nodes (ros/fastdds.xml) where Fast DDS's default keeps them 20 s."""
    import sys

    import rclpy

    cmd = [sys.executable, "-m", "fbcc_ros.nodes", "fbcc_controller", "--ros-args", "-r",
           "__ns:=/lease_test"]  # fmt: skip
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("lease_watcher", context=context)
    with (tmp_path / "log.txt").open("w") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 30.0
        while node.count_publishers("/lease_test/fbcc/phase") == 0:
            assert time.monotonic() < deadline, (tmp_path / "log.txt").read_text()
            time.sleep(0.05)
        proc.kill()
        proc.wait()
        killed = time.monotonic()
        while node.count_publishers("/lease_test/fbcc/phase") and time.monotonic() < killed + 10:
            time.sleep(0.05)
        gone = time.monotonic() - killed
    finally:
        if proc.poll() is None:
            proc.kill()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    assert gone < 4.5, f"the dead node stayed {gone:.1f} s in the graph"


def test_a_profile_of_the_users_own_is_left_alone() -> None:
    env = {PROFILE_VARIABLE: "/etc/my_dds.xml"}
    short_lease(env)
    assert env == {PROFILE_VARIABLE: "/etc/my_dds.xml"}
    env = {}
    short_lease(env)
    assert env == {PROFILE_VARIABLE: str(LEASE_PROFILE)} and LEASE_PROFILE.is_file()
