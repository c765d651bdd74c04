"""fbcc-kinematics as a user runs it: an arm follows a simulated assembly, or says why not."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from fbcc_ros.cli import kinematics

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "config" / "scenarios" / "fig10_interference_1.yaml"


@pytest.mark.parametrize("robot", ["iiwa14", "ur5"])
def test_an_arm_follows_the_simulated_assembly(
    tmp_path: Path, robot: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert kinematics.main([str(SCENARIO), "--robot", robot, "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["robot"] == robot
    assert max(summary["max_feature_error"].values()) < 1e-6
    assert all(j["peak_speed"] <= j["speed_limit"] for j in summary["joints"].values())
    with (tmp_path / "joints.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == summary["steps"] > 1000
    # the command is in the believed frame; aligned with the hole tilted by theta0 = 2°, the peg
    # at the true depth L reads L + 2 r sin(theta0) there (r = 10.04 mm)
    assert float(rows[-1]["l_cmd"]) == pytest.approx(0.01 + 2 * 0.01004 * math.sin(0.0349066),
                                                     abs=1e-5)  # fmt: skip
    assert (tmp_path / "joints.png").stat().st_size > 20_000
    assert f"{robot} followed all" in capsys.readouterr().out


def test_a_hole_out_of_reach_is_reported_with_exit_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = [str(SCENARIO), "--hole-xyz", "2.5", "0", "0.2", "--hole-rpy", "3.14159", "0", "0"]
    assert kinematics.main([*args, "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert "iiwa14 cannot follow" in err and "IK failed" in err


def test_bad_input_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        kinematics.main([str(SCENARIO), "--robot", "kr6", "--out", str(tmp_path)])
    assert info.value.code == 2 and "invalid choice: 'kr6'" in capsys.readouterr().err
    missing = tmp_path / "missing.yaml"
    assert kinematics.main([str(missing), "--out", str(tmp_path)]) == 2
    assert "missing.yaml" in capsys.readouterr().err
    bad_tool = ["--tool-xyz", "0", "0", "nan"]
    assert kinematics.main([str(SCENARIO), *bad_tool, "--out", str(tmp_path)]) == 2
    assert "tool.xyz" in capsys.readouterr().err
