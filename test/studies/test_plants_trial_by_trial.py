"""Two studies of the same trials on both plants, paired trial by trial."""

from __future__ import annotations

from pathlib import Path

import pytest

from fbcc_ros.cli import montecarlo
from fbcc_ros.studies.plants_trial_by_trial import main

SHORT = ("geometry: {hole_radius: 0.00505, peg_radius: 0.00504, hole_depth: 0.01,"
         " base_thickness: 0.005, friction: 0.3, stiffness: 1.84e+8}\n"
         "initial: {dx: 0, dy: 0, theta_x: 0, theta_y: 0}\n"
         "insertion: {depth: 0.001, speed: 0.005}\n"
         "holder: {lateral: 5.0e+4, angular: 30}\nduration: 0.3\n")  # fmt: skip


def _study(tmp_path: Path, plant: str, seed: int) -> Path:
    scenario = tmp_path / "short.yaml"
    scenario.write_text(SHORT)
    out = tmp_path / f"{plant}_{seed}"
    assert montecarlo.main([str(scenario), "--out", str(out), "--trials", "4", "--plant", plant,
                            "--workers", "1", "--seed", str(seed), "--friction", "0.1",
                            "0.5"]) == 0  # fmt: skip
    return out / "trials.csv"


def test_the_same_trials_on_both_plants_are_paired(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    model, mujoco = _study(tmp_path, "model", 3), _study(tmp_path, "mujoco", 3)
    capsys.readouterr()
    assert main([str(model), str(mujoco)]) == 0
    out = capsys.readouterr().out
    assert "| 4 trials | MuJoCo succeeded | MuJoCo not |" in out
    rows = [line for line in out.splitlines() if line.startswith(("| model succeeded",
                                                                 "| model not"))]  # fmt: skip
    counts = [int(c) for row in rows for c in row.strip("|").split("|")[1:]]
    assert sum(counts) == 4
    assert main([str(model), f"{mujoco},{mujoco}"]) == 0  # a study's parts, joined
    assert capsys.readouterr().out == out
    other = _study(tmp_path, "mujoco", 4)  # another seed: other draws, refused
    with pytest.raises(SystemExit) as exc:
        main([str(model), str(other)])
    assert exc.value.code == 2 and "trial 0 differs" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main([str(model), str(mujoco), "--law", "admittance"])
    assert exc.value.code == 2 and "no trial of the law 'admittance'" in capsys.readouterr().err
