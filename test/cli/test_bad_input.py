"""Every command-line tool answers bad input with one line (the value and what is allowed)
and exit status 2, never a traceback: the tools' own checks, argparse's, the file readers' and
the decorator :func:`fbcc_ros.core.errors.command` that catches what reaches ``main``."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from fbcc_ros.cli import calibrate, kinematics, mapping_study, montecarlo, report, sim
from fbcc_ros.core.files import MAX_BYTES
from fbcc_ros.nodes import bringup, fbcc_replay

ROOT = Path(__file__).resolve().parents[2]
BAG = str(ROOT / "test" / "data" / "bags" / "short_interference")
SCENARIO = str(ROOT / "config" / "scenarios" / "bringup_interference.yaml")


def _files(tmp: Path) -> dict[str, str]:
    (tmp / "latin1.yaml").write_bytes("name: caf\xe9\n".encode("latin-1"))  # not UTF-8
    (tmp / "a_file").write_text("")
    (tmp / "wrong_type.yaml").write_text(
        "dynamic_compensation:\n  ros__parameters:\n    lowpass_hz: fast\n")  # fmt: skip
    (tmp / "zero_quaternion.csv").write_text(
        "qx,qy,qz,qw,fx,fy,fz,tx,ty,tz\n" + "0,0,0,1,0,0,1,0,0,0\n" * 3
        + "0,0,0,0,0,0,1,0,0,0\n")  # fmt: skip
    scenario = Path(SCENARIO).read_text()
    (tmp / "twice.yaml").write_text(scenario + "\nduration: 1.0\nduration: 9.0\n")
    (tmp / "fifo.yaml").unlink(missing_ok=True)
    os.mkfifo(tmp / "fifo.yaml")
    (tmp / "big.yaml").write_text(scenario + "#" * (MAX_BYTES + 1))
    (tmp / "params_twice.yaml").write_text(
        "fbcc_controller:\n  ros__parameters:\n    timeout: 0.1\n    timeout: 9.0\n")
    return {name: str(tmp / name) for name in ("latin1.yaml", "a_file", "wrong_type.yaml",
                                               "zero_quaternion.csv", "twice.yaml", "fifo.yaml",
                                               "big.yaml", "params_twice.yaml")}  # fmt: skip


#: (tool's main, its arguments given the files, a fragment the one line must hold)
CASES: dict[str, tuple[Callable[..., int], Callable[[dict[str, str]], list[str]], str]] = {
    "sim, a scenario that is not UTF-8": (
        sim.main, lambda f: [f["latin1.yaml"], "--out", f["a_file"] + "_out"], "UTF-8 text"),
    "montecarlo, a scenario that is not UTF-8": (
        montecarlo.main, lambda f: [f["latin1.yaml"], "--out", f["a_file"] + "_mc"], "UTF-8"),
    "kinematics, a scenario that is not UTF-8": (
        kinematics.main, lambda f: [f["latin1.yaml"], "--out", f["a_file"] + "_k"], "UTF-8"),
    "bringup, a scenario that is not UTF-8": (
        bringup.main, lambda f: [f["latin1.yaml"], "--no-record"], "UTF-8"),
    "sim, a scenario with a key given twice": (
        sim.main, lambda f: [f["twice.yaml"], "--out", f["a_file"] + "_t"],
        "'duration' given twice"),
    "bringup, a scenario with a key given twice": (
        bringup.main, lambda f: [f["twice.yaml"], "--no-record"], "'duration' given twice"),
    "montecarlo, a scenario that is a FIFO": (
        montecarlo.main, lambda f: [f["fifo.yaml"], "--out", f["a_file"] + "_f"], "a FIFO"),
    "sim, a scenario that is /dev/zero": (
        sim.main, lambda f: ["/dev/zero", "--out", f["a_file"] + "_z"], "a character device"),
    "kinematics, an oversized scenario": (
        kinematics.main, lambda f: [f["big.yaml"], "--out", f["a_file"] + "_b"], "at most"),
    "replay offline, a parameter file with a key given twice": (
        fbcc_replay.main, lambda f: [BAG, "--offline", "--params", f["params_twice.yaml"]],
        "'timeout' given twice"),
    "montecarlo, a billion trials": (
        montecarlo.main, lambda f: [SCENARIO, "--trials", "1000000000", "--out",
                                    f["a_file"] + "_n"], "--trials=1000000000"),
    "bringup, a negative seed": (
        bringup.main, lambda f: [SCENARIO, "--seed", "-1", "--no-record"], "--seed"),
    "montecarlo, a chamfer drawn on a pair without its rim": (
        montecarlo.main, lambda f: [SCENARIO, "--chamfer-mm", "0", "0.5", "--out",
                                    f["a_file"] + "_c"], "--chamfer-mm needs"),
    "montecarlo, a clearance range upside down": (
        montecarlo.main, lambda f: [SCENARIO, "--clearance-um", "100", "10", "--out",
                                    f["a_file"] + "_u"], "--clearance-um 100 10"),
    "montecarlo, a grip drawn and fixed at once": (
        montecarlo.main, lambda f: [SCENARIO, "--grip", "2e4", "1e6", "10", "3000", "--holder",
                                    "5e4", "30", "--out", f["a_file"] + "_g"], "--grip draws"),
    "montecarlo, a rate no scenario may state": (
        montecarlo.main, lambda f: [SCENARIO, "--rate-hz", "5", "--out", f["a_file"] + "_r"],
        "--rate-hz=5 is not allowed: expected 10 to 100000 Hz"),
    "montecarlo, a negative seed": (
        montecarlo.main, lambda f: [SCENARIO, "--seed", "-3", "--out", f["a_file"] + "_s"],
        "--seed"),
    "mapping study, a negative seed": (
        mapping_study.main, lambda f: ["--seed", "-3", "--out", f["a_file"] + "_m"], "--seed"),
    "state study, no insertions": (
        mapping_study.main,
        lambda f: ["--estimator", "--trials", "0", "--out", f["a_file"] + "_e"], "--trials"),
    "gate study, a confidence that is not a majority": (
        mapping_study.main,
        lambda f: ["--gate", "--confidence", "0.4", "--out", f["a_file"] + "_g"], "--confidence"),
    "gate study and state study at once": (
        mapping_study.main,
        lambda f: ["--gate", "--estimator", "--out", f["a_file"] + "_g"], "choose one"),
    "report, --out on an existing file": (
        report.main, lambda f: [BAG, "--out", f["a_file"]], "--out"),
    "sim, an --out that cannot be made": (
        sim.main, lambda f: [SCENARIO, "--out", f["a_file"] + "/sub"], "--out"),
    "replay offline, a parameter of the wrong type": (
        fbcc_replay.main, lambda f: [BAG, "--offline", "--params", f["wrong_type.yaml"]],
        "lowpass_hz='fast' is not allowed: expected a number"),
    "replay offline, a parameter file that is not UTF-8": (
        fbcc_replay.main, lambda f: [BAG, "--offline", "--params", f["latin1.yaml"]], "UTF-8"),
    "bringup, a calibration motion with a fault drill": (
        bringup.main, lambda f: [SCENARIO, "--calibration-motion", "--fault", "stale-sensor"],
        "--fault"),
    "bringup, a calibration motion of two poses": (
        bringup.main, lambda f: [SCENARIO, "--calibration-motion", "--poses", "2"], "--poses"),
    "calibrate, a built-in model and a flange frame": (
        calibrate.main, lambda f: [BAG, "--robot", "iiwa14", "--flange-frame", "x", "--out",
                                   f["a_file"] + ".yaml"], "--flange-frame"),
    "calibrate, a zero quaternion": (
        calibrate.main, lambda f: [f["zero_quaternion.csv"], "--out", f["a_file"] + ".yaml"],
        "non-zero norm"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_input_gives_one_line_and_exit_status_2(case: str, tmp_path: Path, capsys: Any
                                                    ) -> None:  # fmt: skip
    main, args, fragment = CASES[case]
    try:
        status = main(args(_files(tmp_path)))
    except SystemExit as exc:  # argparse's own refusal
        status = exc.code
    err = capsys.readouterr().err.strip()
    assert status == 2, err
    # one line saying it (argparse prints its usage above it)
    assert "Traceback" not in err and fragment in err.splitlines()[-1], err
