"""The hardware-free cell with MuJoCo's contact, over real DDS (``fbcc_bringup --plant
mujoco``): the mock cell's truth is MuJoCo's peg in its grip, not eq. 5-13; the mock is the
cell's clock, so that every period of the plant's time is answered; the recorded bag reads
back with rosbags, and fbcc-report draws it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rclpy
import yaml
from rclpy.parameter import Parameter
from rosbags.highlevel import AnyReader

from fbcc_ros.cli import report
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.nodes.bringup import run_cell
from fbcc_ros.nodes.mock_cell import MockCellNode

PAIR = {"hole_radius": 0.00505, "peg_radius": 0.00504, "hole_depth": 0.01,
        "base_thickness": 0.005, "friction": 0.3, "stiffness": 1.84e8}  # fmt: skip
#: The paper's clearance pair 0.1 mm off over a 0.3 mm chamfer, the scenario's plant the
#: model: ``--plant mujoco`` is what makes the cell MuJoCo's. A coarse bore (32 facets, 0.1 ms)
#: keeps the cell near real time on a shared two-core machine (docs/plant.md, speed): this test
#: is of the plumbing, the credibility study is of the physics.
SCENARIO = {"geometry": {**PAIR, "rim": True, "chamfer": 3e-4},
            "initial": {"dx": 1e-4, "dy": 0.0, "theta_x": 0.0, "theta_y": 0.0},
            "insertion": {"depth": 0.001, "speed": 0.005}, "duration": 1.5,
            "plant": {"facets": 32, "timestep": 1e-4, "timeconst": 4e-4}}


def test_the_cell_on_mujoco_records_a_bag_rosbags_reads_and_the_report_draws(
        tmp_path: Path) -> None:  # fmt: skip
    path = tmp_path / "mujoco.yaml"
    path.write_text(yaml.safe_dump(SCENARIO))
    bag = tmp_path / "bag"
    summary = run_cell(str(path), "fbcc", bag=bag, plant="mujoco")
    assert summary["plant"] == "mujoco"
    # on the plant's clock every period is sampled and answered, however slow the plant
    cycles = summary["cycles"]
    assert cycles["samples"] == cycles["expected"] and cycles["samples"] > 1000
    assert cycles["commands"] >= cycles["expected"] - 2, cycles
    with AnyReader([bag]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        truth = [reader.deserialize(raw, c.msgtype).data for c, _, raw in reader.messages()
                 if c.topic == "/mock_cell/truth"]  # fmt: skip
        stamps = [(m := reader.deserialize(raw, c.msgtype)).header.stamp.sec
                  + m.header.stamp.nanosec * 1e-9 for c, _, raw in reader.messages()
                  if c.topic == "/joint_states"]  # fmt: skip
    # stamped with the plant's time: one period apart, none skipped
    np.testing.assert_allclose(np.diff(stamps), 1e-3, atol=1e-8)
    np.testing.assert_allclose(np.diff(np.array(truth)[:, 0]), 1e-3, atol=1e-8)
    for topic in ("/joint_states", "/ft_sensor/raw", "/joint_command", "/fbcc/phase"):
        assert counts.get(topic, 0) > 0, counts
    rows = np.array(truth)[:, 1:]  # features, response
    touching = rows[np.abs(rows[:, 7]) > 0.2]
    assert len(touching) > 10, "the peg never met the chamfer"
    # the truth is not eq. 5-13's: the model's response at the same features differs
    model = PegHole(**PAIR).response(touching[:, :5])
    assert np.abs(model[:, 2] - touching[:, 7]).max() > 0.5
    out = tmp_path / "report"
    assert report.main([str(bag), "--out", str(out)]) == 0
    assert (out / "trajectories.png").stat().st_size > 20_000


def test_a_mock_that_is_the_clock_does_not_read_one() -> None:
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        with pytest.raises(ConfigError, match=r"use_sim_time=True.*it is the clock"):
            MockCellNode(context=context, parameter_overrides=[
                Parameter("publish_clock", value=True), Parameter("use_sim_time", value=True)])
    finally:
        rclpy.try_shutdown(context=context)
