"""The study scripts the docs name (scripts/studies/) run and print what the docs quote."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def _run(*args: str) -> str:
    done = subprocess.run([sys.executable, *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=300, check=True)  # fmt: skip
    return done.stdout


def test_stiff_batches_prints_one_line_per_batch() -> None:
    out = _run("scripts/studies/stiff_batches.py", "tight", "--seed", "0", "--parts", "4",
               "--set", "tilt_depth=0.0003")  # fmt: skip
    assert out.startswith("tight seed 0: ") and "/4 assembled" in out, out


def test_identification_gain_prints_the_four_stiffnesses() -> None:
    lines = _run("scripts/studies/identification_gain.py").strip().splitlines()
    assert [line.split()[0] for line in lines[1:]] == ["0.1", "1.0", "10.0", "40.0"], lines


def test_delays_prints_a_line_per_run() -> None:
    lines = _run("scripts/studies/delays.py", "stiff").strip().splitlines()
    assert len(lines) == 6 and all("clearance 10 GPa, delay " in line for line in lines), lines


def test_filter_along_prints_a_line_per_case() -> None:
    out = _run("scripts/studies/filter_along.py", "--trials", "1", "--cases",
               "clearance:1e9,interference:5e8").strip().splitlines()  # fmt: skip
    cases = [line for line in out if not line.startswith("  ")]
    assert [line.split(",")[0] for line in cases] == ["clearance 1 GPa", "interference 0.5 GPa"]
    assert all("right 0." in line or "right 1." in line for line in cases), out
    calibration = [line for line in out if line.startswith("  calibration")]
    assert len(calibration) == 2 and all("0.99–1.00: " in line for line in calibration), out


def test_filter_along_reads_the_same_clouds_at_other_spreads() -> None:
    out = _run("scripts/studies/filter_along.py", "--trials", "1", "--cases", "clearance:1e9",
               "--readout-spreads", "1e-7,3e-7").strip().splitlines()  # fmt: skip
    read = [line.strip() for line in out if line.strip().startswith("readout spread")]
    assert [line.split(":")[0] for line in read] == ["readout spread 1e-07 m",
                                                     "readout spread 3e-07 m"], out
    assert all(", calibration error 0." in line and "0.99–1.00: " in line for line in read), out
    bad = subprocess.run([sys.executable, "scripts/studies/filter_along.py", "--readout-spreads",
                          "0,1e-7"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "expected offsets [m] > 0" in bad.stderr, bad.stderr


def test_filter_along_puts_the_sensor_at_the_wrist() -> None:
    under, wrist = (_run("scripts/studies/filter_along.py", "--trials", "1", "--cases",
                         "clearance:1e10", *extra).strip().splitlines()[0]
                    for extra in ((), ("--wrist",)))  # fmt: skip
    assert under.startswith("clearance 10 GPa") and wrist.startswith("clearance 10 GPa")
    assert under != wrist  # another sensor, other responses, another share or CPU


def test_lost_clouds_replays_an_insertion_beside_the_truth() -> None:
    out = _run("scripts/studies/lost_clouds.py", "--seed", "9", "--trials", "1",
               "--insertions", "0").strip().splitlines()  # fmt: skip
    assert len(out) == 2 and out[0].startswith("clearance 10 GPa, seed 9, insertion 0: right ")
    assert "updates after the annealing" in out[0] and "nats better" in out[0], out
    line = out[1].split(":")[1].split()
    assert len(line) == 11 and line[0] == "+0", out
    bad = subprocess.run([sys.executable, "scripts/studies/lost_clouds.py", "--trials", "2",
                          "--insertions", "2"], cwd=ROOT, capture_output=True, text=True,
                         timeout=300)  # fmt: skip
    assert bad.returncode == 2 and "each in 0..trials-1" in bad.stderr, bad.stderr


def test_filter_along_scores_the_votes_raised_to_powers() -> None:
    out = _run("scripts/studies/filter_along.py", "--trials", "1", "--seed", "0,1", "--cases",
               "interference:5e8", "--powers", "1,3").strip().splitlines()  # fmt: skip
    cases = [line for line in out if line.startswith("interference 0.5 GPa")]
    assert [line.split(",")[1] for line in cases] == [" seed 0", " seed 1"], out
    one, three = (line for line in out if line.startswith("votes raised to"))
    assert one.startswith("votes raised to 1: ") and three.startswith("votes raised to 3: ")
    # a power keeps the named state: the same share right
    assert one.split(",")[0].split("right ")[1] == three.split(",")[0].split("right ")[1], out
    assert "log-loss " in one and "0.99–1.00: " in three, out
    pooled = [line for line in out if " pooled over seeds 0,1 (2 insertions): right " in line]
    assert len(pooled) == 1 and "falls under 0.90 with probability " in pooled[0], out


def test_filter_along_pools_a_fits_stiffnesses_as_the_state_study_does() -> None:
    out = _run("scripts/studies/filter_along.py", "--trials", "1", "--seed", "0,1", "--cases",
               "clearance:1e9,clearance:1e10").strip().splitlines()  # fmt: skip
    shares = {line.split(",")[0] + line.split(",")[1]: float(line.split("right ")[1][:5])
              for line in out if line.startswith("clearance 1")}  # fmt: skip
    fit = [line for line in out if line.startswith("clearance, its 2 stiffnesses pooled over "
                                                   "seeds 0,1: right ")]  # fmt: skip
    assert len(shares) == 4 and len(fit) == 1, out
    # the fit's share is the mean of its four insertions' (one per seed and stiffness)
    assert abs(float(fit[0].split("right ")[1][:5]) - np.mean(list(shares.values()))) < 2e-3
    assert "a study of 1 a stiffness falls under 0.90 with probability " in fit[0], out


def test_filter_along_splits_the_share_right_by_the_time_in_the_hole() -> None:
    out = _run("scripts/studies/filter_along.py", "--trials", "1", "--cases", "clearance:1e9",
               "--by-time").strip().splitlines()  # fmt: skip
    right = float(out[0].split("right ")[1].split(",")[0])
    head = out.index("clearance:1e9 by the time since the first scored sample (seeds 0):")
    windows = [line.strip() for line in out[head + 1:]]
    assert windows[0].startswith("0-0.05 s: ") and windows[-1].startswith("1-inf s: "), out
    share = [float(w.split(": ")[1].split(" of")[0]) for w in windows]
    named = [float(w.split("right ")[1].split(",")[0]) for w in windows]
    # the windows split the scored samples: their shares add up, and so does the share right
    assert abs(sum(share) - 1.0) < 0.004, out
    assert abs(sum(s * r for s, r in zip(share, named, strict=True)) - right) < 0.005, out
