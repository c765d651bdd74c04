"""Finding the hole (:mod:`fbcc_ros.core.control.hole_search`): the robust law moves a peg that
the hole's top face carries toward the hole, bounded in travel and force, and only then; on
both plants a peg 0.1 mm off an unchamfered 10 µm hole, which stood on the face, assembles."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.control.laws import Insertion
from fbcc_ros.core.control.robust import RobustFbcc
from fbcc_ros.core.control.robust_params import RobustParams
from fbcc_ros.core.sim.scenario import validate
from fbcc_ros.core.sim.simulation import simulate

CLEARANCE = PegHole(hole_radius=5.05e-3, peg_radius=5.04e-3, hole_depth=0.01,
                    base_thickness=0.005, friction=0.3, stiffness=1.84e8)  # fmt: skip
DT = 1e-3
ROOT = Path(__file__).resolve().parents[3]


def _on_the_face(nominal: PegHole, params: RobustParams, support: tuple[float, float],
                 fz: float, seconds: float, lean: float = 0.0) -> np.ndarray:  # fmt: skip
    """The law's commands (N, 5) for a peg the top face carries with ``fz`` at the centre of
    pressure ``support`` (x, y at z = 0: in {H} for moments about the hole's bottom, the cell's
    acting point; from the tip for ``peg_top``, the peg leaning by theta_y = ``lean``); the arm
    is where it was commanded, at the face's height (depth 0)."""
    law = RobustFbcc(nominal, params, Insertion())
    cx, cy = support
    if nominal.acting_point == "peg_top":  # the grip point, peg_length along the leaning axis
        cx -= nominal.peg_length * math.sin(lean)
    # the wrench on the hole of a force -fz ẑ at (cx, cy, 0) from the acting point's axis:
    # Mx = -cy Fz, My = cx Fz
    wrench = np.array([0.0, 0.0, fz, -cy * fz, cx * fz])
    arm = np.array([0.0, 0.0, 0.0, 0.0, lean])
    law.reset(arm)
    commands = []
    for _ in range(round(seconds / DT)):
        command = law.step(wrench, arm, DT)
        commands.append(command)
        arm = command.copy()
        arm[2] = 0.0  # the face holds the peg, and the arm with it
    return np.array(commands)


def test_the_peg_moves_away_from_the_support_for_the_search_range() -> None:
    """The face carries the peg 3 mm out along (cos 30°, sin 30°): the offset command moves the
    other way at search_speed and stops after search_range, whatever the time left."""
    p = RobustParams()
    angle = math.radians(30.0)
    support = (3e-3 * math.cos(angle), 3e-3 * math.sin(angle))
    commands = _on_the_face(CLEARANCE, p, support, 4.0, 1.5 * p.search_range / p.search_speed)
    moved = commands[:, :2] - commands[0, :2]
    half = len(moved) // 3  # a third of the way: still searching, at its speed
    travel = np.hypot(*moved[half])
    assert travel == pytest.approx(p.search_speed * half * DT, rel=0.02, abs=5e-6)
    end = moved[-1]
    assert np.hypot(*end) == pytest.approx(p.search_range, abs=1e-5)  # the dither: 2 µm
    assert math.atan2(-end[1], -end[0]) == pytest.approx(angle, abs=math.radians(1.0))
    assert np.allclose(moved[-1], moved[-100], atol=5e-6)  # it has stopped


def test_a_leaning_peg_reads_its_support_from_its_tip() -> None:
    """Moments about the grip point (``peg_top``) of a peg leaning 2° toward +x: the grip point
    lies 1.7 mm beside the tip, so a support 1 mm out on the +x side reads 0.7 mm on the -x
    side of it. Taken back to the tip, the peg moves toward -x, away from the support. (20 N:
    over a lever of 50 mm the tilt rows read a moment ten times weaker than under the hole.)"""
    nominal = dataclasses.replace(CLEARANCE, acting_point="peg_top")
    commands = _on_the_face(nominal, RobustParams(), (1e-3, 0.0), 20.0, 0.2,
                            lean=math.radians(2.0))  # fmt: skip
    moved = commands[-1, :2] - commands[0, :2]
    assert moved[0] < -1e-4 and abs(moved[1]) < 5e-6, moved


def test_the_search_presses_with_its_force() -> None:
    """Pressing the face with 30 N, six times search_force, the depth command backs off; with
    3 N it does not."""
    p = RobustParams()
    pressed = _on_the_face(CLEARANCE, p, (3e-3, 0.0), 6.0 * p.search_force, 0.2)
    light = _on_the_face(CLEARANCE, p, (3e-3, 0.0), 0.6 * p.search_force, 0.2)
    assert pressed[-1, 2] < pressed[0, 2]
    assert light[-1, 2] > light[0, 2]


@pytest.mark.parametrize("case", ["interference", "centred", "off"])
def test_no_search_where_the_face_does_not_say_where_the_hole_is(case: str) -> None:
    """An interference fit's peg always meets the rim (only a chamfer leads it in); a peg carried
    all round (its support under its axis) has no side to move to; search_range 0 turns the
    search off. None of them moves sideways beyond the dither."""
    nominal, params, support = CLEARANCE, RobustParams(), (3e-3, 0.0)
    if case == "interference":
        nominal = dataclasses.replace(CLEARANCE, peg_radius=5.06e-3)
    elif case == "centred":
        support = (0.0, 0.0)
    else:
        params = RobustParams(search_range=0.0)
    commands = _on_the_face(nominal, params, support, 4.0, 0.3)
    assert np.abs(commands[:, :2] - commands[0, :2]).max() < 5e-6


@pytest.mark.parametrize(("name", "value"), [
    ("search_speed", 5e-4), ("search_range", 2e-4), ("search_force", 2.0)])  # fmt: skip
def test_every_search_parameter_changes_the_commands(name: str, value: float) -> None:
    """Each of the search's parameters acts: changed, the commands on the face are not the same
    (the travel's pace, its end, and the force the depth holds against 4 N)."""
    default = _on_the_face(CLEARANCE, RobustParams(), (3e-3, 0.0), 4.0, 0.4)
    changed = _on_the_face(CLEARANCE, RobustParams(**{name: value}), (3e-3, 0.0), 4.0, 0.4)
    assert not np.array_equal(default, changed), name


def _off_an_unchamfered_hole(plant: str, **params: Any) -> dict[str, Any]:
    """The 10 µm pair 0.1 mm off in x and y, no chamfer, in a compliant grip, with the hole's
    rim (its top face), 4 mm deep: the summary of the robust law's run."""
    sc = validate({
        "geometry": {"hole_radius": 0.00505, "peg_radius": 0.00504, "hole_depth": 0.01,
                     "base_thickness": 0.005, "friction": 0.3, "stiffness": 1.84e8,
                     "rim": True, "chamfer": 0.0},
        "holder": {"lateral": 5e4, "angular": 30.0}, "plant": {"type": plant},
        "initial": {"dx": 1e-4, "dy": -1e-4, "theta_x": 0.0, "theta_y": 0.0},
        "insertion": {"depth": 0.004, "speed": 0.005}, "duration": 2.5,
    })  # fmt: skip
    sc = dataclasses.replace(sc, params=RobustParams(**params))
    outcome, _ = simulate(sc, "fbcc", record=False)
    return outcome.summary(0)  # type: ignore[no-any-return]


@pytest.mark.parametrize("plant", ["model", "mujoco"])
def test_a_peg_on_the_top_face_finds_the_hole_on_both_plants(plant: str) -> None:
    """Without the search the peg stands on the face, under 0.1 mm deep; with it, it assembles
    on our model and on MuJoCo, whose rigid face tips the peg onto the crescent's two ends."""
    stood = _off_an_unchamfered_hole(plant, search_range=0.0)
    assert not stood["success"] and stood["final_features"]["l"] < 1e-4, stood
    found = _off_an_unchamfered_hole(plant)
    assert found["success"] and not found["stop_reason"], found



def test_a_peg_slid_off_the_face_is_not_started_deep_in_the_block(tmp_path: Path) -> None:
    """Trial 42 of the unchamfered rim study (seed 0: 49 µm, μ 0.17, a grip of 4.5e5 N/m and
    15 N·m/rad): the search slides the peg off the face. There the holder's start fell back on
    no deflection, deep in the hole's block, whose micron steps never got out (3.9e5 N, the
    guard stopped it). Started at the contact's onset on the way there, it assembles."""
    from fbcc_ros.cli import montecarlo

    out = tmp_path / "mc"
    assert montecarlo.main([
        str(ROOT / "config/scenarios/rim_clearance.yaml"), "--out", str(out), "--workers", "1",
        "--stiffness-gpa", "0.1", "100", "--friction", "0.1", "0.5", "--clearance-um", "10",
        "100", "--chamfer-mm", "0", "0", "--grip", "2e4", "1e6", "10", "3e3", "--trial", "42",
    ]) == 0  # fmt: skip
    summary = json.loads((out / "trial_42" / "summary.json").read_text())
    assert summary["success"] and summary["peak_force"] < 300.0, summary
