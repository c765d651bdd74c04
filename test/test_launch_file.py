"""launch/fbcc_cell.launch.py: it starts the node set of fbcc_ros.harness.cell_nodes (the one
the bringup and the other tests build), and with the real Jazzy ``ros2 launch`` (when ``ros2`` is
on PATH: ``. ../shared/ros2cli.sh``, as scripts/test.sh does) the cell it starts assembles."""

from __future__ import annotations

import ast
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAUNCH = ROOT / "launch" / "fbcc_cell.launch.py"


def test_the_launch_file_builds_its_nodes_from_the_cell_description() -> None:
    tree = ast.parse(LAUNCH.read_text())
    imported = {(n.module, a.name) for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
                for a in n.names}  # fmt: skip
    assert ("fbcc_ros.harness.cell_nodes", "cell_nodes") in imported
    # no node named here: every one comes from the description
    names = {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant)}
    assert not names & {"kinematics", "dynamic_compensation", "fbcc_controller", "mock_cell"}
    assert "launch/*.launch.py" in (ROOT / "setup.py").read_text()  # installed to share


@pytest.mark.skipif(shutil.which("ros2") is None, reason="no ros2 CLI (. ../shared/ros2cli.sh)")
@pytest.mark.flaky(reruns=2)
def test_ros2_launch_rehearses_the_lbr_stack_and_assembles(tmp_path: Path) -> None:
    """The LBR rehearsal (100 Hz, in /lbr, the model from the mock's robot_description),
    started by ``ros2 launch``, started through ``/lbr/fbcc/start``: the phase reaches
    ``inserted``; then Ctrl-C ends every node cleanly. A private ROS_DOMAIN_ID keeps it off
    other runs."""
    env = dict(os.environ, ROS_DOMAIN_ID="73")
    launch = subprocess.Popen(
        ["ros2", "launch", "fbcc_ros", "fbcc_cell.launch.py", "profile:=lbr",
         "namespace:=/lbr", "scenario:=config/scenarios/lbr_rehearsal.yaml"],
        env=env, cwd=ROOT, stdout=(tmp_path / "launch.log").open("wb"),
        stderr=subprocess.STDOUT, start_new_session=True)  # fmt: skip
    try:
        phase = _run_until_inserted(env)
    finally:
        os.killpg(launch.pid, signal.SIGINT)
        try:
            launch.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(launch.pid, signal.SIGKILL)
            launch.wait()
    log = (tmp_path / "launch.log").read_text(errors="replace")
    assert phase == "inserted", log[-3000:]
    assert "robot model from /lbr/robot_description" in log
    # Ctrl-C (SIGINT to the whole group, as a terminal sends it): every node ends cleanly
    assert "process has died" not in log and "[ERROR]" not in log, log[-3000:]
    started = log.count("process started with pid")
    assert started >= 4 and log.count("process has finished cleanly") == started, log[-3000:]


def _run_until_inserted(env: dict[str, str]) -> str:
    """Starts the insertion once the cell is armed; returns the last phase seen (30 s)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import String
    from std_srvs.srv import Trigger

    from fbcc_ros.ros.topics import PHASE_QOS

    os.environ["ROS_DOMAIN_ID"] = env["ROS_DOMAIN_ID"]
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("launch_test", namespace="/lbr", context=context)
    phases: list[str] = []
    node.create_subscription(String, "fbcc/phase", lambda m: phases.append(m.data), PHASE_QOS)
    start = node.create_client(Trigger, "fbcc/start")
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    future = None
    deadline = time.monotonic() + 60.0
    try:
        while time.monotonic() < deadline and not (phases and phases[-1] == "inserted"):
            executor.spin_once(timeout_sec=0.1)
            if future is None and phases and phases[-1] == "armed" and start.service_is_ready():
                future = start.call_async(Trigger.Request())
        return phases[-1] if phases else "no phase heard"
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        context.destroy()
        del os.environ["ROS_DOMAIN_ID"]
