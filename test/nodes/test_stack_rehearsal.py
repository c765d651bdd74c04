"""The hardware-free cell rehearsing a real robot stack (a scenario's ``robot`` and ``sensor``
sections): beside lbr_fri_ros2_stack — each LBR under the stack's names in ``/lbr`` at its
100 Hz, the model from the ``robot_description`` the mock latches, the command on its forward
position controller, our virtual sensor from its joint torques — in one process and with each
node its own process; and a best-effort F/T sensor at 1 kHz. Each assembles, over real DDS."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from fbcc_ros.nodes.bringup import run_cell

ROOT = Path(__file__).resolve().parents[2]
LBR = ROOT / "config" / "scenarios" / "lbr_rehearsal.yaml"
#: A live loop over DDS on a shared two-core machine (test_cell_ros.py: REALTIME).
REALTIME = pytest.mark.flaky(reruns=2)


def _scenario(tmp_path: Path, base: Path, robot: dict[str, Any], sensor: dict[str, Any]) -> str:
    data = yaml.safe_load(base.read_text())
    data.setdefault("robot", {}).update(robot)
    data.setdefault("sensor", {}).update(sensor)
    path = tmp_path / "rehearsal.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def _assembled(summary: dict[str, Any]) -> None:
    why = f"{summary['phase']} {summary['reason']} {summary['cycles']}"
    assert summary["success"] and summary["phase"] == "inserted", why
    assert summary["cycles"]["ik_failures"] == 0, why


@REALTIME
@pytest.mark.parametrize("processes", [False, True], ids=["one_process", "processes"])
@pytest.mark.parametrize("model", ["iiwa7", "iiwa14", "med7", "med14"])
def test_beside_the_lbr_stack_each_model_assembles(model: str, processes: bool,
                                                   tmp_path: Path) -> None:  # fmt: skip
    path = _scenario(tmp_path, LBR, {"model": model}, {"source": "measured_torques"})
    summary = run_cell(path, "fbcc", processes=processes, log_dir=tmp_path / "logs")
    _assembled(summary)
    # the commands the stack's controller heard, at its 100 Hz
    assert summary["cycles"]["commands"] >= 0.9 * summary["cycles"]["expected"]


@REALTIME
def test_the_virtual_sensor_from_the_stacks_external_torques_assembles(tmp_path: Path) -> None:
    """The recorded session holds the stack's topics under /lbr, the URDF among them."""
    from fbcc_ros.bag.reader import read_bag

    path = _scenario(tmp_path, LBR, {}, {"source": "external_torques"})
    bag = tmp_path / "bag"
    _assembled(run_cell(path, "fbcc", bag=bag))
    recorded = read_bag(bag)
    for topic in ("/lbr/joint_states", "/lbr/forward_position_controller/commands",
                  "/lbr/fbcc/features", "/lbr/ft_sensor/compensated"):
        assert recorded.counts[topic] > 300, (topic, recorded.counts)
    assert recorded.counts["/lbr/robot_description"] == 1
    assert recorded.counts["/lbr/force_torque_broadcaster/wrench"] > 300  # the stack's too
    _replayed_offline(recorded, bag)


def _replayed_offline(recorded: Any, bag: Path) -> None:
    """The session under /lbr through the stages without ROS, the virtual sensor's torques
    from the bag: the recorded commands, to the replay's tolerance."""
    from fbcc_ros.bag.offline import node_parameters, replay_offline
    from fbcc_ros.nodes.fbcc_replay import TOLERANCE

    result = replay_offline(recorded, node_parameters(bag))
    compared = np.isfinite(result.recorded).all(axis=1).sum()
    assert compared > 300, result.counts
    assert (result.max_error() <= TOLERANCE).all(), (result.max_error(), result.counts)


@REALTIME
def test_the_virtual_sensor_from_the_measured_torques_replays_offline(tmp_path: Path) -> None:
    """The LBR profile's own source (the effort of the joint states): recorded in /lbr, and
    replayed offline to the recorded commands."""
    from fbcc_ros.bag.reader import read_bag

    path = _scenario(tmp_path, LBR, {}, {"source": "measured_torques"})
    bag = tmp_path / "bag"
    _assembled(run_cell(path, "fbcc", bag=bag))
    _replayed_offline(read_bag(bag), bag)


@REALTIME
def test_a_best_effort_ft_sensor_at_1khz_assembles(tmp_path: Path) -> None:
    """The F/T sensor publishes sensor-data QoS (best-effort), which a reliable subscription
    never hears: the compensation subscribes best-effort, and the cell assembles."""
    base = ROOT / "config" / "scenarios" / "bringup_interference.yaml"
    path = _scenario(tmp_path, base, {}, {"qos": "best_effort"})
    _assembled(run_cell(path, "fbcc"))
