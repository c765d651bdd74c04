"""Freeing a wedged peg (:mod:`fbcc_ros.core.control.wedge`): a clearance fit that stops at once
with nothing in its rows is pushed lightly while its tilt is turned, toward where it goes in;
an insertion that slows under a growing friction, or that its rows hold back, is left as it
was. On MuJoCo a peg that wedged without it assembles."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.control import wedge
from fbcc_ros.core.control.laws import Insertion
from fbcc_ros.core.control.robust import RobustFbcc
from fbcc_ros.core.control.robust_params import RobustParams

CLEARANCE = PegHole(hole_radius=5.05e-3, peg_radius=5.04e-3, hole_depth=0.01,
                    base_thickness=0.005, friction=0.3, stiffness=1.84e8)  # fmt: skip
DT = 1e-3
ROOT = Path(__file__).resolve().parents[3]
AXIAL = 1e6  # the grip's axial path [N/m]: a stopped peg loads it as the arm goes on
WEDGE_DEPTH = 1e-3  # where the synthetic peg wedges [m]


def _insert(params: RobustParams, seconds: float, *, free: tuple[float, float] | None = None,
            friction_slope: float = 0.0, moment: float = 0.0, stop: float = WEDGE_DEPTH
            ) -> dict[str, np.ndarray]:  # fmt: skip
    """The law's commands on a synthetic insertion: the arm is where it is commanded; the peg
    stops at WEDGE_DEPTH (the arm then loads the grip's axial path) and its rows read nothing,
    or a moment about x of ``moment`` [N·m] all along (a side pressed from the start). ``free``:
    the unit direction (θx, θy) in which a turn of the tilt command by 0.05° lets the peg 1 mm
    deeper (and the contact pushes back, 300 N·m/rad, against a turn the other way).
    ``friction_slope`` [N/m]: instead of a wedge, an axial friction growing with the depth from
    the start (an interference fit's). ``stop``: where the peg stops [m]."""
    law = RobustFbcc(CLEARANCE, params, Insertion(depth=4e-3, speed=5e-3))
    arm = np.zeros(5)
    law.reset(arm)
    start_tilt = None
    commands, forces = [], []
    for _ in range(round(seconds / DT)):
        wrench = np.array([0.0, 0.0, 0.0, moment, 0.0])
        if friction_slope > 0.0:
            wrench[2] = friction_slope * max(arm[2], 0.0)
        elif arm[2] > stop:
            wrench[2] = AXIAL * (arm[2] - stop)
            if free is not None:
                start_tilt = arm[3:5].copy() if start_tilt is None else start_tilt
                turned = arm[3:5] - start_tilt
                along = float(turned @ free)
                if along > math.radians(0.05):  # turned far enough: the peg slides on
                    stop, start_tilt = stop + 1e-3, None
                elif along < 0.0:  # the contact pushes back against a turn the other way
                    wrench[3:5] += -300.0 * along * -np.asarray(free)
        command = law.step(wrench, arm, DT)
        commands.append(command)
        forces.append(wrench[2])
        arm = command.copy()
    return {"command": np.array(commands), "fz": np.array(forces), "stop": np.array(stop)}


def test_a_wedged_peg_is_pushed_lightly_while_its_tilt_turns_toward_where_it_goes_in() -> None:
    """The peg stops at 1 mm with its rows quiet: the depth loop lets F_z down to about
    search_force, and the tilt command turns (at tilt_rate, blocked directions turned away
    from) until it has turned 0.05° the free way, when the peg goes on."""
    p = RobustParams()
    free = np.array([math.cos(math.radians(200.0)), math.sin(math.radians(200.0))])
    run = _insert(p, 1.5, free=free)
    assert float(run["stop"]) > WEDGE_DEPTH  # freed at least once
    loaded = run["fz"] > p.wedge_force
    assert loaded.any() and run["fz"].max() < 2.0 * p.wedge_force  # never pressed hard
    tilt = run["command"][-1, 3:5] - run["command"][0, 3:5]
    assert float(tilt @ free) > 0.0  # turned the free way


def test_without_the_probe_the_wedge_is_pressed_to_the_push_bound() -> None:
    """wedge_force 0 (off): the same wedge is never turned the 0.05° that frees it, and is
    pressed up to about push_limit (the depth backs off to it); with push_limit off too, up to
    fz_back_off."""
    free = np.array([1.0, 0.0])
    for p in (RobustParams(wedge_force=0.0), RobustParams(wedge_force=0.0, push_limit=0.0)):
        run = _insert(p, 1.0, free=free)
        assert float(run["stop"]) == WEDGE_DEPTH
        bound = p.push_limit or p.fz_back_off
        assert 0.9 * bound < run["fz"].max() < 2.0 * bound, (p.push_limit, run["fz"].max())


def test_an_interference_fits_friction_is_not_a_wedge() -> None:
    """A friction that grows with depth (2e4 N/m: 20 N at 1 mm) loads the peg over a
    millimetre, not at once: the commands are those of the law without the probe
    (wedge_force 0), to the bit."""
    run = _insert(RobustParams(), 1.0, friction_slope=2e4)
    assert run["fz"].max() > RobustParams().wedge_force
    off = _insert(RobustParams(wedge_force=0.0), 1.0, friction_slope=2e4)
    assert np.array_equal(run["command"], off["command"])


def test_a_load_the_rows_read_is_theirs_to_answer() -> None:
    """A peg pressed on one side all along (0.04 N·m in its tilt row before the load, over the
    rows' QUIET effort) that stops at once: the commands are those of the law without the
    probe, to the bit."""
    run = _insert(RobustParams(), 1.0, moment=0.04)
    assert run["fz"].max() > RobustParams().wedge_force
    off = _insert(RobustParams(wedge_force=0.0), 1.0, moment=0.04)
    assert np.array_equal(run["command"], off["command"])


def test_a_load_before_the_peg_is_in_the_bore_all_round_is_the_rims() -> None:
    """The same stop 0.3 mm in, under the 0.35 mm past which this unchamfered pair's peg is
    in its bore all round whatever the top face's tilt (a peg resting on the face or the bore's
    edge, not wedged): the commands are those of the law without the probe, to the bit; 1 mm
    in, they are not."""
    shallowest, _ = wedge.depths(CLEARANCE.hole_radius, CLEARANCE.peg_radius, CLEARANCE.chamfer)
    assert 0.3e-3 < shallowest < WEDGE_DEPTH
    free = np.array([1.0, 0.0])
    for stop, same in ((0.3e-3, True), (WEDGE_DEPTH, False)):
        run = _insert(RobustParams(), 0.5, free=free, stop=stop)
        assert run["fz"].max() > RobustParams().wedge_force
        off = _insert(RobustParams(wedge_force=0.0), 0.5, free=free, stop=stop)
        assert np.array_equal(run["command"], off["command"]) == same, stop


def test_a_wedge_can_be_from_the_pairs_two_point_contact_to_whitneys_limit() -> None:
    """depths: a 10 µm pair is in its bore all round past its chamfer and the face's rise
    (R sin WEDGE_TILT); a 100 µm pair's span fills the bore deeper (2 (R - r) / sin WEDGE_TILT
    below the edge, less that rise); neither wedges past μ 0.5 times the bore's diameter."""
    r, rise = 5e-3, 5e-3 * math.sin(wedge.WEDGE_TILT)
    tight = wedge.depths(r, r - 1e-5, 3e-4)
    loose = wedge.depths(r, r - 1e-4, 0.0)
    assert tight[0] == pytest.approx(3e-4 + rise)
    assert loose[0] == pytest.approx(2e-4 / math.sin(wedge.WEDGE_TILT) - rise)
    assert tight[1] == pytest.approx(3e-4 + rise + 5e-3) and loose[1] == pytest.approx(rise + 5e-3)


def test_the_wedge_force_acts() -> None:
    """wedge_force 30 N instead of 20 N: the same wedge is taken later, at a higher load."""
    free = np.array([0.0, 1.0])
    default = _insert(RobustParams(), 0.5, free=free)
    changed = _insert(RobustParams(wedge_force=30.0), 0.5, free=free)
    assert not np.array_equal(default["command"], changed["command"])
    assert changed["fz"].max() > default["fz"].max()


def test_the_probe_turns_at_tilt_rate_within_its_range_and_turns_away_when_blocked() -> None:
    """probe_step: a step of tilt_rate·dt in its direction; a push-back over the gate holds it
    and turns the direction by the golden angle, once; it never leaves PROBE_RANGE."""
    state = np.zeros(wedge.N_STATE)
    speed, dt, gate = math.radians(4.0), 1e-3, 20.0
    tx, ty = wedge.probe_step(state, dt, speed, 0.0, 0.0, gate)
    assert (tx, ty) == pytest.approx((speed * dt, 0.0))
    assert wedge.probe_step(state, dt, speed, 30.0, 0.0, gate) == (0.0, 0.0)
    assert state[wedge.S_PHASE] == pytest.approx(wedge.PROBE_TURN)
    wedge.probe_step(state, dt, speed, 30.0, 0.0, gate)  # still blocked: no second turn
    assert state[wedge.S_PHASE] == pytest.approx(wedge.PROBE_TURN)
    turned = np.zeros(2)
    for _ in range(2000):
        turned += wedge.probe_step(state, dt, speed, 0.0, 0.0, gate)
    assert np.hypot(*turned) <= wedge.PROBE_RANGE + 1e-12


def test_a_wedge_ends_when_the_peg_advances_or_the_probe_has_had_its_time() -> None:
    """wedged: a quiet load of wedge_force reached within WEDGE_TRAVEL of the arm's travel
    latches (loud rows, a longer travel, or a load that began too high, do not);
    FREE_ADVANCE deeper frees it; PROBE_TIME later it lets go."""
    force, dt = 20.0, 1e-3

    def loaded(quiet: bool = True, travel: float = 2e-5, shallowest: float = 0.5e-3
               ) -> tuple[np.ndarray, bool]:  # fmt: skip
        state = np.zeros(wedge.N_STATE)
        assert not wedge.wedged(state, 1e-3, 5.0, quiet, force, dt, shallowest, 5e-3)
        return state, wedge.wedged(state, 1e-3 + travel, 25.0, quiet, force, dt, shallowest,
                                   5e-3)  # fmt: skip

    assert not loaded(quiet=False)[1]
    assert not loaded(travel=1.5 * wedge.WEDGE_TRAVEL)[1]
    assert not loaded(shallowest=1.01e-3)[1]  # the load began above where a wedge can be
    state, latched = loaded()
    assert latched
    assert wedge.wedged(state, 1.02e-3 + 0.9 * wedge.FREE_ADVANCE, 5.0, True, force, dt, 0, 1)
    assert not wedge.wedged(state, 1.02e-3 + 1.1 * wedge.FREE_ADVANCE, 5.0, True, force, dt, 0,
                            1)  # fmt: skip
    state, _ = loaded()
    held = [wedge.wedged(state, 1.02e-3, 5.0, True, force, dt, 0.0, 1.0)
            for _ in range(round(wedge.PROBE_TIME / dt) + 2)]  # fmt: skip
    assert all(held[:-3]) and not held[-1]


def _mujoco_trial_12(tmp_path: Path, params: dict[str, float]) -> dict[str, Any]:
    """Trial 12 of the full-range MuJoCo study (seed 0: 32 µm of clearance, μ 0.43, a 0.06 mm
    chamfer, the hole 1.43° off, a grip of 1.1e5 N/m and 1e3 N·m/rad): the summary of the
    robust law's run with ``params``."""
    from fbcc_ros.cli import montecarlo

    scenario = yaml.safe_load((ROOT / "config/scenarios/mujoco_clearance.yaml").read_text())
    scenario["controller"]["params"] = params
    scenario["duration"] = 2.5  # the wedge and its freeing are over by then; half the cost
    tmp_path.mkdir(parents=True, exist_ok=True)
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump(scenario))
    out = tmp_path / "mc"
    assert montecarlo.main([
        str(path), "--out", str(out), "--workers", "1", "--trials", "40", "--friction", "0.1",
        "0.5", "--clearance-um", "10", "100", "--chamfer-mm", "0", "0.5", "--grip", "2e4",
        "1e6", "10", "3e3", "--trial", "12",
    ]) == 0  # fmt: skip
    return json.loads((out / "trial_12" / "summary.json").read_text())  # type: ignore[no-any-return]


def test_a_peg_that_wedges_on_mujoco_is_freed(tmp_path: Path) -> None:
    """Without the probe the peg locks 2.7 mm in, where its span fills the bore, and is pressed
    there to push_limit; with it, it assembles, pressed with under 2 wedge_force."""
    pressed = _mujoco_trial_12(tmp_path / "off", {"wedge_force": 0.0})
    assert not pressed["success"], pressed
    assert 2.5e-3 < pressed["final_features"]["l"] < 3e-3, pressed
    assert pressed["peak_fz"] > 0.9 * RobustParams().push_limit, pressed
    freed = _mujoco_trial_12(tmp_path / "on", {})
    assert freed["success"] and not freed["stop_reason"], freed
    assert freed["peak_fz"] < 2.0 * RobustParams().wedge_force, freed
