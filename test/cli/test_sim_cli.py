"""fbcc-sim and fbcc-montecarlo as a user runs them: files written, bad input refused."""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest

from fbcc_ros.cli import montecarlo, sim

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "config" / "scenarios"


def test_sim_compares_two_laws_on_one_figure(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert sim.main([str(SCENARIOS / "fig9_clearance.yaml"), "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert set(summary) == {"fbcc", "admittance"}
    assert summary["fbcc"]["success"] and not summary["admittance"]["success"]
    with (tmp_path / "trajectory.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert {r["run"] for r in rows} == {"fbcc", "admittance"}
    assert len(rows) == 2 * 4000
    # the assembled run ends at the true depth (the admittance run, 2° misaligned, does not)
    last_fbcc = [r for r in rows if r["run"] == "fbcc"][-1]
    assert float(last_fbcc["l"]) == pytest.approx(0.01, abs=1e-5)
    for name in ("trajectories.png", "planes.png"):
        assert (tmp_path / name).stat().st_size > 20_000
    assert "fbcc" in capsys.readouterr().out


def test_sim_single_run_writes_a_flat_summary(tmp_path: Path) -> None:
    assert sim.main([str(SCENARIOS / "fig10_interference_3.yaml"), "--out", str(tmp_path),
                     "--no-plots"]) == 0  # fmt: skip
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["success"] is True and summary["state_sequence"]


def test_sim_runs_a_scenario_on_the_plant_named(tmp_path: Path, capsys) -> None:
    """``--plant mujoco`` runs the same scenario on MuJoCo: 0.1 mm off, ten times the
    clearance, with no chamfer and the law's hole search off, the peg stands on the hole's top
    face, which the model has not; a plant that is not one is refused by argparse."""
    scenario = tmp_path / "short.yaml"
    scenario.write_text("geometry: {hole_radius: 0.00505, peg_radius: 0.00504, hole_depth: 0.01,"
                        " base_thickness: 0.005, friction: 0.3, stiffness: 1.84e+8}\n"
                        "controller: {type: fbcc, params: {search_range: 0}}\n"
                        "initial: {dx: 1.0e-4, dy: 0, theta_x: 0, theta_y: 0}\n"
                        "holder: {lateral: 5.0e+4, angular: 30}\nduration: 0.4\n")
    out = {p: tmp_path / p for p in ("model", "mujoco")}
    for plant, folder in out.items():
        assert sim.main([str(scenario), "--out", str(folder), "--no-plots", "--plant",
                         plant]) == 0  # fmt: skip
    model, mujoco = (json.loads((out[p] / "summary.json").read_text()) for p in out)
    assert model["final_features"] != mujoco["final_features"]
    assert mujoco["final_features"]["l"] < 1e-4  # on the top face, not in the hole
    with pytest.raises(SystemExit) as refused:
        sim.main([str(scenario), "--out", str(tmp_path / "x"), "--plant", "bullet"])
    assert refused.value.code == 2 and "invalid choice: 'bullet'" in capsys.readouterr().err


#: A short scenario for MuJoCo studies: 1 mm in 0.3 s.
SHORT = ("geometry: {hole_radius: 0.00505, peg_radius: 0.00504, hole_depth: 0.01,"
         " base_thickness: 0.005, friction: 0.3, stiffness: 1.84e+8}\n"
         "initial: {dx: 0, dy: 0, theta_x: 0, theta_y: 0}\n"
         "insertion: {depth: 0.001, speed: 0.005}\n"
         "holder: {lateral: 5.0e+4, angular: 30}\nduration: 0.3\n")


def test_montecarlo_runs_its_trials_on_the_plant_named(tmp_path: Path) -> None:
    """``fbcc-montecarlo --plant mujoco``: the trials run on MuJoCo, the same for the same seed
    on one worker or two, and the study says which plant it ran on."""
    scenario = tmp_path / "short.yaml"
    scenario.write_text(SHORT)
    rows = []
    for workers in ("1", "2"):
        out = tmp_path / workers
        assert montecarlo.main([str(scenario), "--out", str(out), "--trials", "4", "--plant",
                                "mujoco", "--workers", workers]) == 0  # fmt: skip
        summary = json.loads((out / "summary.json").read_text())
        assert summary["_run"]["plant"]["type"] == "mujoco"
        rows.append((out / "trials.csv").read_text())
    assert rows[0] == rows[1]
    # a trial is its seed on MuJoCo too: trial 2 replayed alone is the study's row
    assert montecarlo.main([str(scenario), "--out", str(tmp_path / "again"), "--plant",
                            "mujoco", "--trial", "2"]) == 0  # fmt: skip
    again = json.loads((tmp_path / "again" / "trial_2" / "summary.json").read_text())
    row = list(csv.DictReader(io.StringIO(rows[0])))[2]
    assert again["peak_fz"] == pytest.approx(float(row["peak_fz"]), rel=1e-3)
    model = tmp_path / "model"
    assert montecarlo.main([str(scenario), "--out", str(model), "--trials", "4",
                            "--workers", "1"]) == 0  # fmt: skip
    assert (model / "trials.csv").read_text() != rows[0]  # the plant is not the model


def test_montecarlo_draws_each_trials_mujoco_contact(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    """``--contact-ms``: each MuJoCo trial's contact time constant is its own draw, listed in
    trials.csv, replayed with the trial, and acting: the same trials at 0.2 ms and at 1 ms press
    differently. The model has no such contact, and a time constant under four timesteps is
    refused."""
    scenario = tmp_path / "short.yaml"
    scenario.write_text(SHORT)
    study = [str(scenario), "--trials", "3", "--plant", "mujoco", "--workers", "1"]
    rows = {}
    for name, low, high in (("drawn", "0.2", "1"), ("metal", "0.2", "0.2"), ("soft", "1", "1")):
        out = tmp_path / name
        assert montecarlo.main([*study, "--out", str(out), "--contact-ms", low, high]) == 0
        rows[name] = list(csv.DictReader((out / "trials.csv").open()))
    drawn = [float(r["contact_timeconst"]) for r in rows["drawn"]]
    assert all(2e-4 <= t <= 1e-3 for t in drawn) and len(set(drawn)) == 3
    assert [float(r["contact_timeconst"]) for r in rows["soft"]] == [1e-3] * 3
    # the other draws are the same whatever the contact; the contact's force is not
    assert [r["dx0"] for r in rows["metal"]] == [r["dx0"] for r in rows["soft"]]
    assert [r["peak_force"] for r in rows["metal"]] != [r["peak_force"] for r in rows["soft"]]
    assert montecarlo.main([*study, "--out", str(tmp_path / "again"), "--contact-ms", "0.2",
                            "1", "--trial", "1"]) == 0  # fmt: skip
    again = json.loads((tmp_path / "again" / "trial_1" / "summary.json").read_text())
    assert again["peak_force"] == pytest.approx(float(rows["drawn"][1]["peak_force"]), rel=1e-3)
    for flags, why in ((["--plant", "model"], "--contact-ms draws MuJoCo's contact"),
                       (["--plant", "mujoco"], "--contact-ms 0.1 1 is not allowed")):
        with pytest.raises(SystemExit) as exc:
            montecarlo.main([str(scenario), "--trials", "2", *flags, "--out",
                             str(tmp_path / "bad"), "--contact-ms", "0.1" if "mujoco" in flags
                             else "0.2", "1"])  # fmt: skip
        assert exc.value.code == 2 and why in capsys.readouterr().err


def test_sim_refuses_a_bad_scenario_before_simulating(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    text = (SCENARIOS / "fig9_clearance.yaml").read_text()
    text = text.replace("hole_radius: 0.00505", "hole_radius: 5.05")
    bad.write_text(text)
    out = tmp_path / "out"
    good = SCENARIOS / "fig9_interference.yaml"
    assert sim.main([str(good), str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "geometry.hole_radius=5.05" in err and " m" in err
    assert not (out / "summary.json").exists()


def test_montecarlo_writes_rates_with_intervals(tmp_path: Path) -> None:
    args = [str(SCENARIOS / "table1_interference_label3.yaml"), "--out", str(tmp_path),
            "--trials", "6", "--workers", "1", "--laws", "fbcc", "admittance"]  # fmt: skip
    assert montecarlo.main(args) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    for law in ("fbcc", "admittance"):
        s = summary[law]
        lo, hi = s["success_ci95"]
        assert s["trials"] == 6 and lo <= s["success_rate"] <= hi
    with (tmp_path / "trials.csv").open() as f:
        assert len(list(csv.DictReader(f))) == 12
    assert (tmp_path / "histograms.png").stat().st_size > 10_000


def test_montecarlo_at_a_stacks_rate_runs_as_the_scenario_stating_it(tmp_path: Path) -> None:
    """``--rate-hz 100`` runs the trials as a copy of the scenario with ``rate_hz: 100`` does,
    trial for trial, and the summary says the rate."""
    import yaml

    source = SCENARIOS / "robust_clearance.yaml"
    data = yaml.safe_load(source.read_text())
    data["rate_hz"] = 100
    copy = tmp_path / "at_100.yaml"
    copy.write_text(yaml.safe_dump(data))
    common = ["--trials", "4", "--workers", "1", "--laws", "fbcc", "--stiffness-gpa", "1", "100"]
    assert montecarlo.main([str(source), "--rate-hz", "100", "--out", str(tmp_path / "flag"),
                            *common]) == 0  # fmt: skip
    assert montecarlo.main([str(copy), "--out", str(tmp_path / "file"), *common]) == 0
    assert json.loads((tmp_path / "flag" / "summary.json").read_text())["_run"]["rate_hz"] == 100
    rows = [(tmp_path / run / "trials.csv").read_text() for run in ("flag", "file")]
    assert rows[0] == rows[1]
    at_1k = tmp_path / "at_1k"
    assert montecarlo.main([str(source), "--out", str(at_1k), *common]) == 0
    assert (at_1k / "trials.csv").read_text() != rows[0]  # the rate acts


def test_montecarlo_rejects_bad_counts(tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exc:
        montecarlo.main([str(SCENARIOS / "fig9_clearance.yaml"), "--out", str(tmp_path),
                         "--trials", "0"])  # fmt: skip
    assert exc.value.code == 2


def test_montecarlo_draws_materials_lists_failures_and_judges_the_goals(tmp_path: Path) -> None:
    """With --stiffness-gpa and --friction every trial carries its own k and mu (in trials.csv),
    parts that cannot be pushed in are drawn again and counted, every failure is listed with
    what reproduces it, and the goals carry the measured figures."""
    args = [str(SCENARIOS / "robust_interference.yaml"), "--out", str(tmp_path),
            "--trials", "8", "--workers", "1", "--laws", "fbcc", "admittance",
            "--stiffness-gpa", "0.1", "1", "--friction", "0.1", "0.5", "--seed", "4"]  # fmt: skip
    assert montecarlo.main(args) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    with (tmp_path / "trials.csv").open() as f:
        rows = list(csv.DictReader(f))
    k = [float(r["stiffness"]) for r in rows]
    mu = [float(r["friction"]) for r in rows]
    assert min(k) >= 1e8 and max(k) <= 1e9 and len(set(k)) == 8  # one draw per trial
    assert min(mu) >= 0.1 and max(mu) <= 0.5
    run = summary["_run"]
    assert run["feasible_force"] == pytest.approx(200.0) and run["parts_redrawn"] >= 0
    for law in ("fbcc", "admittance"):
        s = summary[law]
        first = [r["law"] for r in rows].index(law)
        law_rows = rows[first:first + s["trials"]]
        # a success meets every per-trial goal: assembled, by 3 s, residual <= 0.5 N, no overshoot
        met = [int(r["success"]) and float(r["insertion_time"]) <= 3.0
               and float(r["residual_force"]) <= 0.5 and float(r["tilt_overshoot"]) <= 0.0035
               for r in law_rows]  # fmt: skip
        assert s["goals"]["success"]["measured"] == pytest.approx(sum(met) / len(met))
        assert s["goals"]["success"]["met"] == (sum(met) / len(met) >= 0.999)
        assert [f["trial"] for f in s["failures"]] == [i for i, m in enumerate(met) if not m]
        for fail in s["failures"]:
            row = law_rows[fail["trial"]]
            assert float(row["stiffness"]) == pytest.approx(fail["stiffness"], rel=1e-3)
            assert fail["seed"] == 4 and fail["why"]
    assert (tmp_path / "stiffness.png").stat().st_size > 10_000


def test_montecarlo_judges_the_time_against_the_scenarios_own_travel(tmp_path: Path) -> None:
    """At 10 mm/s over 10 mm the time goal is the 1 s of travel and one second: 2 s, in the
    summary's target and in what each trial is judged against."""
    args = [str(SCENARIOS / "robust_clearance_fast.yaml"), "--out", str(tmp_path), "--trials",
            "6", "--workers", "1", "--stiffness-gpa", "0.1", "100", "--friction", "0.1", "0.5",
            "--seed", "2"]  # fmt: skip
    assert montecarlo.main(args) == 0
    goal = json.loads((tmp_path / "summary.json").read_text())["fbcc"]["goals"]
    assert goal["insertion_time_s"]["target"].startswith("<= 2 per trial")
    assert "by 2 s" in goal["success"]["target"]
    with (tmp_path / "trials.csv").open() as f:
        times = [float(r["insertion_time"]) for r in csv.DictReader(f)]
    assert goal["insertion_time_s"]["over_target"] == sum(t > 2.0 for t in times)


def test_montecarlo_reports_the_friction_the_lever_measured(tmp_path: Path) -> None:
    """The robust law's lever (eq. 24) measures each part's friction on one contact sliding in
    (identification): trials.csv carries it (NaN where it measured none, and for admittance),
    the summary its error against the part's μ, friction.png draws it. The ratio it reads is an
    upper bound on μ (Coulomb: Fz = μ N, |F_lat| <= N), so it never reads far below μ."""
    args = [str(SCENARIOS / "robust_clearance.yaml"), "--out", str(tmp_path), "--trials", "24",
            "--workers", "1", "--laws", "fbcc", "admittance", "--stiffness-gpa", "0.1", "100",
            "--friction", "0.1", "0.5", "--seed", "5"]  # fmt: skip
    assert montecarlo.main(args) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    with (tmp_path / "trials.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert all(math.isnan(float(r["friction_estimate"])) for r in rows if r["law"] != "fbcc")
    assert summary["admittance"]["friction_estimate"] is None
    fbcc = [r for r in rows if r["law"] == "fbcc"]
    err = np.array([float(r["friction_estimate"]) - float(r["friction"]) for r in fbcc
                    if not math.isnan(float(r["friction_estimate"]))])  # fmt: skip
    said = summary["fbcc"]["friction_estimate"]
    assert said["measured"] == len(err) > 0 and said["trials"] == 24
    assert said["abs_error_max"] == pytest.approx(np.abs(err).max(), abs=1e-3)
    assert said["error_median"] == pytest.approx(np.median(err), abs=1e-3)
    assert err.min() >= -0.03 and said["abs_error_median"] < 0.06, err
    assert (tmp_path / "friction.png").stat().st_size > 10_000


def test_montecarlo_replays_a_trial_of_a_study(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--trial N with the study's arguments writes that trial's run as fbcc-sim does, with the
    study's figures for it, whatever --trials says (a trial is its seed); a negative trial is
    refused."""
    study = [str(SCENARIOS / "robust_clearance.yaml"), "--trials", "5", "--workers", "1",
             "--laws", "fbcc", "--stiffness-gpa", "1", "100", "--seed", "6"]  # fmt: skip
    assert montecarlo.main([*study, "--out", str(tmp_path / "study")]) == 0
    with (tmp_path / "study" / "trials.csv").open() as f:
        row = list(csv.DictReader(f))[3]
    # the study's trials 3 and 4 are those of a study that starts at trial 3
    assert montecarlo.main([*study[:2], "2", *study[3:], "--first", "3", "--out",
                            str(tmp_path / "part")]) == 0  # fmt: skip
    with (tmp_path / "part" / "trials.csv").open() as f:
        part = list(csv.DictReader(f))
    with (tmp_path / "study" / "trials.csv").open() as f:
        assert [dict(r) for r in list(csv.DictReader(f))[3:5]] == [dict(r) for r in part]
    bigger = [*study[:2], "40", *study[3:]]
    assert montecarlo.main([*bigger, "--out", str(tmp_path / "again"), "--trial", "3"]) == 0
    folder = tmp_path / "again" / "trial_3"
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["peak_fz"] == pytest.approx(float(row["peak_fz"]), rel=1e-3)
    assert summary["success"] == bool(int(row["success"]))
    # both failure kinds of the paper's Fig. 9 per trial: past zero, and grown the wrong way
    for metric in ("tilt_overshoot", "tilt_misadjustment"):
        assert summary[metric] == pytest.approx(float(row[metric]), rel=1e-3, abs=1e-9)
    assert (folder / "trajectories.png").stat().st_size > 10_000
    assert (folder / "trajectory.csv").exists()
    assert not (tmp_path / "again" / "trials.csv").exists()  # the study is not run again
    with pytest.raises(SystemExit) as exc:
        montecarlo.main([*study, "--out", str(tmp_path / "bad"), "--trial", "-5"])
    assert exc.value.code == 2 and "--trial -5" in capsys.readouterr().err


@pytest.mark.parametrize(
    "flags", [["--stiffness-gpa", "10", "1"], ["--friction", "0", "0.5"], ["--seed", "-1"]]
)
def test_montecarlo_refuses_bad_ranges(tmp_path: Path, flags: list[str],
                                       capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    with pytest.raises(SystemExit) as exc:
        montecarlo.main([str(SCENARIOS / "robust_clearance.yaml"), "--out", str(tmp_path),
                         "--trials", "2", *flags])  # fmt: skip
    assert exc.value.code == 2
    assert flags[0] in capsys.readouterr().err
