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
