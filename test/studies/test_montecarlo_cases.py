"""Monte Carlo cases side by side, a case run in parts joined by trial number."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from fbcc_ros.cli import montecarlo
from fbcc_ros.studies.montecarlo_cases import WEDGING_EDGES, main, wedging_ratio
from fbcc_ros.studies.trials_csv import BINS, bin_masks, friction_edges

SHORT = ("geometry: {hole_radius: 0.00505, peg_radius: 0.00504, hole_depth: 0.01,"
         " base_thickness: 0.005, friction: 0.3, stiffness: 1.84e+8}\n"
         "initial: {dx: 1.0e-4, dy: 0, theta_x: 0.03, theta_y: 0}\n"
         "insertion: {depth: 0.002, speed: 0.005}\nduration: 0.5\n")  # fmt: skip


def _study(tmp_path: Path, name: str, *args: str) -> Path:
    scenario = tmp_path / "short.yaml"
    scenario.write_text(SHORT)
    out = tmp_path / name
    assert montecarlo.main([str(scenario), "--out", str(out), "--workers", "1", "--friction",
                            "0.1", "0.5", "--stiffness-gpa", "0.1", "100", *args]) == 0
    return out


def _table(capsys: pytest.CaptureFixture[str], *args: str) -> str:
    capsys.readouterr()
    assert main(list(args)) == 0
    return capsys.readouterr().out


def test_a_case_in_parts_reads_as_the_whole_study(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    whole = _study(tmp_path, "whole", "--trials", "8")
    first = _study(tmp_path, "first", "--trials", "5")
    rest = _study(tmp_path, "rest", "--trials", "3", "--first", "5")
    joined = _table(capsys, "--case", "c", str(first / "trials.csv"), str(rest / "trials.csv"),
                    "--figure", str(tmp_path / "cases.png"))
    assert joined.replace(f"wrote {tmp_path / 'cases.png'}\n", "") == _table(
        capsys, "--case", "c", str(whole / "trials.csv"))
    assert (tmp_path / "cases.png").stat().st_size > 0
    assert _table(capsys, "--case", "c", f"{first / 'trials.csv'},{rest / 'trials.csv'}") == (
        joined.replace(f"wrote {tmp_path / 'cases.png'}\n", ""))  # comma-joined parts
    summary = json.loads((whole / "summary.json").read_text())["fbcc"]
    peak = summary["peak_fz [N]"]  # the tail the studies judge (p99), from the same trials
    assert peak["p95"] <= peak["p99"] <= peak["max"]
    row = next(line for line in joined.splitlines() if line.startswith("| c | 8 |"))
    cells = [c.strip() for c in row.split("|")]
    # succeeded + failed on the force limit + not assembled = every trial
    assert summary["successes"] + int(cells[4]) + int(cells[5]) == 8
    with (whole / "trials.csv").open() as f:  # the failed trials' final depth, m to mm
        depth = [float(r["final_l"]) * 1e3 for r in csv.DictReader(f) if r["success"] == "0"]
    assert cells[6] == (f"{float(np.median(depth)):.2f} mm" if depth else "-")
    assert row.split("|")[7].strip() == f"{peak['median']:.1f}, {peak['p99']:.1f} N"
    assert row.split("|")[3].strip().startswith(f"{summary['successes'] / 8:.1%}")
    for label, rows in (("μ", BINS), ("θ0 / (c/μ)", len(WEDGING_EDGES) - 1)):
        lines = joined.splitlines()
        top = lines.index(f"| {label} | c |") + 2  # its rows, under the header
        bins = [line.split("|")[2].split()[0] for line in lines[top : top + rows]]
        assert sum(int(b.split("/")[1]) for b in bins) == 8  # every trial in one bin
        assert sum(int(b.split("/")[0]) for b in bins) == summary["successes"]


def test_the_wedging_ratio_is_the_tilt_over_c_over_mu() -> None:
    row = {"hole_radius": 5.05e-3, "peg_radius": 5.04e-3, "theta_x0": 0.0, "theta_y0": -0.02,
           "friction": 0.3}  # fmt: skip
    assert wedging_ratio(row) == pytest.approx(0.02 * 0.3 / (0.01 / 5.05))
    tilted = row | {"theta_x0": 0.02}  # both planes: the total tilt, atan(|(tan, tan)|)
    total = math.atan(math.tan(0.02) * math.sqrt(2))
    assert wedging_ratio(tilted) == pytest.approx(total * 0.3 * 505)
    assert wedging_ratio(row | {"peg_radius": 5.06e-3}) == math.inf  # interference: no c


def test_bins_hold_each_value_once() -> None:
    edges = np.array([0.0, 0.5, 1.0, math.inf])
    masks = bin_masks(np.array([0.0, 0.5, 0.99, 1.0, 7.0, math.inf]), edges)
    assert [m.tolist() for m in masks] == [[True, False, False, False, False, False],
                                           [False, True, True, False, False, False],
                                           [False, False, False, True, True, True]]
    same = np.full(5, 0.3)  # the friction not drawn: one bin, every trial in it once
    assert [m.sum() for m in bin_masks(same, friction_edges(same))] == [5]
    with pytest.raises(ValueError, match="NaN"):
        bin_masks(np.array([0.1, math.nan]), edges)


def test_parts_of_other_studies_and_bad_cases_are_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    one = _study(tmp_path, "one", "--trials", "2") / "trials.csv"
    other = _study(tmp_path, "other", "--trials", "2", "--seed", "1") / "trials.csv"
    for args, message in (
            (["--case", "c", str(one), str(other)], "differ in ['seed']"),
            (["--case", "c"], "names no trials.csv"),
            (["--case", "c", str(one), "--case", "c", str(one)], "given twice"),
            (["--case", "c", str(tmp_path / "none.csv")], "no such file")):  # fmt: skip
        with pytest.raises(SystemExit) as exc:
            main(args)
        assert exc.value.code == 2 and message in capsys.readouterr().err
