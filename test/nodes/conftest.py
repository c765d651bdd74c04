"""ROS isolation for the node tests: discovery on this machine only, and a ROS domain of its own
for each test (PLATFORM.md), so that no test ever hears another's nodes. A latched phase from an
earlier test's cell did reach a later one when they shared a domain.

Domains: a cycle of 60 per test run (one of two blocks, chosen from the pid), test by test;
rclpy reads ``ROS_DOMAIN_ID`` when a context is initialised, and node subprocesses inherit it.
A cycle of 10 came back to a domain within DDS's lease time on a slow machine (a few seconds a
test, reruns included): a killed process of an earlier test was still in its graph, and the
replay's "nobody hears" test found a subscriber there.
"""

from __future__ import annotations

import itertools
import os
import subprocess
import sys
from pathlib import Path
from typing import IO

import pytest

ROOT = Path(__file__).resolve().parents[2]

_BLOCK = 100 + (os.getpid() % 2) * 60
_NEXT = itertools.cycle(range(_BLOCK, _BLOCK + 60))


@pytest.fixture(autouse=True)
def ros_isolation() -> None:
    os.environ["ROS_DOMAIN_ID"] = str(next(_NEXT))
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"


def recorder_and_cell(folder: Path, log: IO[str], *cell_args: str
                      ) -> tuple[subprocess.Popen[bytes], subprocess.Popen[bytes]]:  # fmt: skip
    """An fbcc_record recording the cell's topics into ``folder``, and the bringup (``cell_args``
    after it), not recording itself but waiting for that recorder: two processes, both
    logging into ``log``, as on a real cell."""
    run = [sys.executable, "-m"]
    recorder = subprocess.Popen(
        [*run, "fbcc_ros.nodes.fbcc_record", "--ros-args", "-p", f"out:={folder}"],
        cwd=ROOT, stdout=log, stderr=subprocess.STDOUT,
    )  # fmt: skip
    cell = subprocess.Popen([*run, "fbcc_ros.nodes.bringup", *cell_args, "--no-record",
                             "--wait-for-recorder"], cwd=ROOT, stdout=log,
                            stderr=subprocess.STDOUT)  # fmt: skip
    return recorder, cell


def kill_left(*procs: subprocess.Popen[bytes]) -> None:
    """Kill and reap each process that still runs (a test's cleanup, however it ended)."""
    for proc in procs:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
