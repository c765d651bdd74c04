"""Every fault drill of ``fbcc_bringup --fault`` on the hardware-free cell over real DDS, recorded,
in one process and with the nodes as processes: the cell ends safe — the true contact force and
moment within the wrench guard's limits, no joint-command step beyond what the velocity limits
allow, the arm at its hold, the bag complete (for a full disk: holding exactly what its
metadata counts) — with the outcome each fault calls for, and the reason naming what caught
it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from rosbags.rosbag2 import Reader

from fbcc_ros.bag.reader import read_bag
from fbcc_ros.bag.recover import recover
from fbcc_ros.harness.fault_drill import DRILLS
from fbcc_ros.nodes.bringup import main as bringup_main
from test.nodes.test_cell_ros import REALTIME, SCENARIO

GHOST = "the same node twice (a second instance, or a dead one DDS has not forgotten yet)"
#: What each drill's reason (or one of its faults) must say: what caught it, or, where the
#: fault passes, any of the ways it may pass (a restart within the timeout faults nothing).
REASONS = {
    "moment-spike": ("wrench guard: raw ty",),
    "force-spike": ("wrench guard: |f|",),
    "nan-wrench": ("of the last 100 samples rejected", "stale compensated wrench"),
    "stale-wrench": ("stale compensated wrench",),
    "future-stamp": ("of the last 100 samples rejected", "stale compensated wrench"),
    "slow-sensor": ("arrives at 100.0 Hz, configured for 1000 Hz",),
    "sensor-burst": ("no fault; phase inserted",),
    # as processes, a killed node's endpoints stay in the graph until its DDS lease ends: the
    # node started anew publishes beside them, a second source until then
    "compensation-restart": ("no fault; phase inserted", "stale compensated wrench", GHOST),
    "controller-restart": ("no fault; phase inserted", GHOST),
    "kinematics-restart": ("no fault; phase inserted", "stale features", GHOST),
    "tare-under-load": ("fbcc/start refused: no recent compensated wrench", "tare refused"),
    "deadband-param": ("a force band of at most 0.5 N",),
    "lowpass-param": ("0 (off) or at least its start-up value",),
    "max-step-param": ("at most its start-up value",),
    "start-after-fault": ("acknowledge it with reset first",),
    "disk-full": ("recording stopped",),
    "frozen-kinematics": ("stale features",),
    "frozen-compensation": ("stale compensated wrench",),
    "stray-wrench": ("2 publishers on /ft_sensor/raw (/mock_cell, /stray_publisher)",),
    "stray-joint-states": ("2 publishers on /joint_states (/mock_cell, /stray_publisher)",),
    "stray-commander": ("another commander on /joint_command: /stray_publisher",),
    "clock-change": ("use_sim_time is set at start-up only",),
    "replay-beside": ("/joint_states (/mock_cell) publish there now (a cell is running)",),
}


def test_every_drill_has_an_expectation() -> None:
    assert sorted(REASONS) == sorted(DRILLS)


@REALTIME
@pytest.mark.parametrize("mode", ["one-process", "processes"])
@pytest.mark.parametrize("name", list(DRILLS))
def test_a_fault_drill_ends_safe(name: str, mode: str, tmp_path: Path, capfd) -> None:
    """In one process, or each node in its own (a kill is then SIGKILL, a freeze SIGSTOP)."""
    processes = ["--processes"] if mode == "processes" else []
    status = bringup_main([str(SCENARIO), "--fault", name, "--out", str(tmp_path), *processes])
    out = capfd.readouterr()
    said = (status, out.out[-2000:], out.err[-2000:])  # a run that ended early says why
    assert (tmp_path / "summary.json").exists(), said
    summary = json.loads((tmp_path / "summary.json").read_text())
    drill = summary["fault_drill"]
    assert status == 0 and drill["safe"] and drill["as_expected"], (drill, out.out[-2000:])
    assert f"fault drill {name}: {drill['outcome']}" in out.out and " — SAFE" in out.out
    outcome = DRILLS[name].expected
    assert (drill["outcome"], drill["name"]) == (outcome, name), drill
    said = [drill["reason"], *drill["faults"]]
    assert any(r in s for r in REASONS[name] for s in said), (said, drill["outcome"])
    # the safety figures themselves, from the mock's ground truth and the joint commands
    assert 0.0 < drill["peak_force"] <= drill["force_limit"] == 300.0, drill
    assert 0.0 < drill["peak_moment"] <= drill["moment_limit"] == 30.0, drill
    assert 0.0 < drill["joint_step"] <= 1.0, drill
    if drill["final_phase"] in ("fault", "force_limit", "aborted"):  # the arm at its hold
        assert drill["hold_error"] is not None and drill["hold_error"] <= 5e-5, drill
    assert "Traceback" not in out.err
    bag = read_bag(Path(summary["bag"]["path"]))
    counted = _metadata_counts(bag.path.parent)
    assert counted == {t: bag.counts[t] for t in bag.topics}, (counted, bag.counts)
    assert drill["bag"] == {"complete": not bag.truncated, "consistent": True}
    if name == "disk-full":  # cut at its last flushed chunk: what was flushed is all there
        assert bag.truncated and "recording stopped" in " ".join(drill["reports"]), drill
        last = max(m.log_time_ns for m in bag.messages) * 1e-9
        assert drill["injected_at"] - 1.0 < last, (drill["injected_at"], last)
        # fbcc-recover makes it whole: the independent reader opens it, every message there
        recovered = recover(bag.path.parent)
        assert recovered is not None
        with Reader(recovered.bag) as whole:
            held = {c.topic: c.msgcount for c in whole.connections if c.msgcount}
            assert held == dict(bag.counts), (held, bag.counts)
    else:  # complete: the independent reader opens it and counts what ours read
        assert not bag.truncated
        with Reader(bag.path.parent) as whole:
            held = {c.topic: c.msgcount for c in whole.connections if c.msgcount}
        assert held == dict(bag.counts), (held, bag.counts)
    if outcome == "recovered":  # the insertion went on to the end
        assert summary["phase"] == "inserted" and summary["success"], summary["phase"]


def _metadata_counts(folder: Path) -> dict[str, int]:
    info = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    return {t["topic_metadata"]["name"]: t["message_count"]
            for t in info["topics_with_message_count"]}  # fmt: skip
