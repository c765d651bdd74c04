"""The closed-loop simulator: the paper's Section IV findings that our model reproduces, the
metric definitions, and batches that agree with single runs."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.paper import paper_scenario
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.montecarlo import draw_trials, replay_trial, run_montecarlo, wilson_interval
from fbcc_ros.core.sim.scenario import validate
from fbcc_ros.core.sim.simulation import _Metrics, run, simulate
from fbcc_ros.pipeline.mock_cell import TABLE as MOCK
from fbcc_ros.pipeline.mock_cell import MockStage
from fbcc_ros.pipeline.parameters import resolve

ROOT = Path(__file__).resolve().parents[3]

SUMMARY_KEYS = {"success", "insertion_time", "peak_fz", "residual_force", "residual_moment",
                "tilt_overshoot", "final_features", "state_sequence"}  # fmt: skip


@pytest.fixture(scope="module", params=["clearance", "interference"])
def compared(request: pytest.FixtureRequest) -> dict[str, dict]:
    """The Section IV case (0.05 mm, 2° in both planes) under each law."""
    return {law: run(paper_scenario(request.param, law)).summary
            for law in ("fbcc", "admittance", "none")}  # fmt: skip


def test_summary_has_the_design_keys(compared: dict[str, dict]) -> None:
    for summary in compared.values():
        assert SUMMARY_KEYS <= set(summary)
        assert set(summary["final_features"]) == {"dx", "dy", "l", "theta_x", "theta_y"}


def test_fbcc_assembles_without_overshoot_and_drives_the_lateral_force_to_zero(
    compared: dict[str, dict],
) -> None:
    s = compared["fbcc"]
    assert s["success"]
    assert s["tilt_overshoot"] < math.radians(0.05)
    assert s["residual_force"] < 0.5  # N, from ~100 N at the peak
    assert s["final_features"]["l"] == pytest.approx(0.01, abs=1e-5)
    assert (
        s["state_sequence"][-1]["state"] in {"P0/P0", "P0/D0", "D0/P0", "D0/D0", "P1/P0"}
        or (s["success"])
    )


def test_admittance_keeps_a_residual_force(compared: dict[str, dict]) -> None:
    """Section IV.B, claim 2: without the integrator the residual response stays."""
    adm, fbcc = compared["admittance"], compared["fbcc"]
    assert adm["residual_force"] > 10.0
    assert adm["residual_force"] > 50 * fbcc["residual_force"]
    assert not adm["success"]


def test_without_force_feedback_the_forces_grow_and_stay(compared: dict[str, dict]) -> None:
    """Section IV.B: without force feedback the responses keep increasing with the depth.

    (In this case they stay below the default 300 N limit: 240 N clearance, 294 N interference
    at full depth; the Monte Carlo of docs/reproduction.md has most trials above it.)"""
    none, fbcc = compared["none"], compared["fbcc"]
    assert not none["success"]
    assert none["peak_fz"] > 1.8 * fbcc["peak_fz"]
    assert none["residual_force"] > 100.0


def _metrics_of(theta_path: np.ndarray, theta0: float) -> dict:
    sc = validate({**paper_scenario("clearance"), "duration": len(theta_path) / 1000})
    initial = np.array([[0, 0, 0, 0, theta0]])
    m = _Metrics(sc, initial)
    x = np.zeros((len(theta_path), 1, 5))
    x[:, 0, 4] = theta_path
    w = np.zeros_like(x)
    m.add(0, np.arange(len(theta_path)) / 1000.0, x, w)
    return m.outcome(np.array([False])).summary(0)


def test_tilt_overshoot_and_misadjustment_definitions() -> None:
    down = np.linspace(0.02, -0.005, 100)  # from +0.02 rad past zero to -0.005
    s = _metrics_of(down, 0.02)
    assert s["tilt_overshoot"] == pytest.approx(0.005) and s["tilt_misadjustment"] == 0.0
    away = np.linspace(-0.02, -0.1, 100)  # the wrong way, like Fig. 9a's -6°
    s = _metrics_of(away, -0.02)
    assert s["tilt_overshoot"] == 0.0 and s["tilt_misadjustment"] == pytest.approx(0.08)
    s = _metrics_of(np.r_[np.zeros(50), np.full(50, -0.003)], 0.0)
    assert s["tilt_overshoot"] == pytest.approx(0.003)  # from zero, any excursion counts


def test_a_batch_runs_like_its_trials_one_by_one() -> None:
    sc = validate({**paper_scenario("interference"), "sensor": {"noise": 0}, "duration": 1.0})
    trials = draw_trials(sc.geometry, 3, seed=5)
    batch, traj = simulate(sc, "fbcc", initial=trials.initial, geometries=trials.geometries)
    assert traj is not None
    for i in range(3):
        one, t1 = simulate(sc, "fbcc", initial=trials.initial[i : i + 1],
                           geometries=trials.geometries[i : i + 1])  # fmt: skip
        assert t1 is not None
        np.testing.assert_allclose(traj.features[:, i], t1.features[:, 0], rtol=1e-12, atol=1e-15)
        assert one.peak_fz[0] == pytest.approx(batch.peak_fz[i], rel=1e-12)


def test_noise_is_seeded() -> None:
    sc = validate({**paper_scenario("clearance"), "duration": 0.5})
    a = simulate(sc, "fbcc")[1]
    b = simulate(sc, "fbcc")[1]
    c = simulate(sc, "fbcc", seed=1)[1]
    assert a is not None and b is not None and c is not None
    np.testing.assert_array_equal(a.measured, b.measured)
    assert not np.array_equal(a.measured, c.measured)


def test_montecarlo_is_the_same_at_any_worker_count() -> None:
    sc = validate({**paper_scenario("interference"), "duration": 1.0})
    trials = draw_trials(sc.geometry, 6, seed=2)
    one = run_montecarlo(sc, ["fbcc"], trials, workers=1, batch=4)["fbcc"]
    two = run_montecarlo(sc, ["fbcc"], trials, workers=2, batch=4)["fbcc"]
    np.testing.assert_array_equal(one.peak_fz, two.peak_fz)
    assert len(one.success) == 6


def test_a_replayed_trial_is_the_studys_row_with_its_trajectory() -> None:
    """A trial is its seed: trial 5 of a study in batches of 4 (the second batch, its second
    row), replayed alone, has the study's metrics exactly, and its own part and deviation."""
    sc = validate({**paper_scenario("clearance"), "duration": 1.0})
    trials = draw_trials(sc.geometry, 7, seed=3, stiffness=(1e8, 1e10))
    study = run_montecarlo(sc, ["fbcc"], trials, workers=1, batch=4)["fbcc"]
    again = replay_trial(sc, "fbcc", trials, 5)
    expected = study.summary(5)
    for key, value in expected.items():
        assert again.summary[key] == value, key
    assert again.trajectory.features.shape[1] == 1
    np.testing.assert_array_equal(again.trajectory.features[-1, 0],
                                  study.final_features[5])  # fmt: skip
    assert again.scenario.geometry == trials.geometries[5]
    np.testing.assert_array_equal(again.scenario.initial, trials.initial[5])
    with pytest.raises(ConfigError, match="trial"):
        replay_trial(sc, "fbcc", trials, 7)


def test_a_trial_is_its_seed_whatever_the_study_around_it() -> None:
    """Trial 5 of seed 3 draws the same part and deviation, and meets the same noise, in a study
    of 7 trials, of 40, or drawn alone; in batches of any size; another seed's trial 5 is
    another trial."""
    sc = validate({**paper_scenario("clearance"), "duration": 0.5})
    small = draw_trials(sc.geometry, 7, seed=3, friction=(0.1, 0.5))
    large = draw_trials(sc.geometry, 40, seed=3, friction=(0.1, 0.5))
    alone = draw_trials(sc.geometry, 1, seed=3, friction=(0.1, 0.5), numbers=[5])
    for t in (large, alone):
        row = t.numbers.index(5)
        np.testing.assert_array_equal(t.initial[row], small.initial[5])
        assert t.geometries[row] == small.geometries[5]
    other = draw_trials(sc.geometry, 7, seed=4, friction=(0.1, 0.5))
    assert other.geometries[5] != small.geometries[5]
    a = run_montecarlo(sc, ["fbcc"], small, workers=1, batch=7)["fbcc"]
    b = run_montecarlo(sc, ["fbcc"], large, workers=1, batch=3)["fbcc"]
    np.testing.assert_array_equal(a.final_features[5], b.final_features[5])
    assert a.peak_fz[5] == b.peak_fz[5]
    # the noise is a stream apart from every draw: trial 0's of seed 0 in a scenario of
    # seed 0 ([0, 0, 0], which NumPy pads like [0, 0]) is not trial 0's draw
    zero = draw_trials(sc.geometry, 1, seed=0)
    noise = np.random.default_rng(zero.noise_seeds(0)[0]).standard_normal(4)
    assert not np.array_equal(noise, np.random.default_rng([0, 0]).standard_normal(4))
    assert draw_trials(sc.geometry, 1, seed=3, numbers=[np.int64(5)]).numbers == (5,)
    for bad in ([-1], [2, 2], [], [1.0]):
        with pytest.raises(ConfigError, match="trial"):
            draw_trials(sc.geometry, 1, seed=3, numbers=bad)
    with pytest.raises(ConfigError, match="seed"):
        draw_trials(sc.geometry, 1, seed=-3)


def test_trials_spread_within_their_bounds() -> None:
    sc = validate(paper_scenario("clearance"))
    t = draw_trials(sc.geometry, 400, seed=0)
    assert np.abs(t.initial[:, :2]).max() <= 1e-4 and np.abs(t.initial[:, 3:]).max() <= 0.0350
    assert np.all(t.initial[:, 2] == 0)
    radii = np.array([g.peg_radius for g in t.geometries])
    assert 0 < radii.std() < 20e-6


def test_drawn_materials_and_the_feasibility_cut() -> None:
    """k log-uniform, mu uniform within their bounds; a part that cannot be pushed in within
    the feasible force is drawn again (its deviation kept) and counted."""
    sc = validate(paper_scenario("interference"))
    t = draw_trials(sc.geometry, 300, seed=1, stiffness=(1e8, 1e10), friction=(0.1, 0.5),
                    feasible_force=200.0)  # fmt: skip
    k = np.array([g.stiffness for g in t.geometries])
    mu = np.array([g.friction for g in t.geometries])
    assert k.min() >= 1e8 and k.max() <= 1e10 and mu.min() >= 0.1 and mu.max() <= 0.5
    assert max(g.push_in_force() for g in t.geometries) <= 200.0
    assert t.redrawn > 0  # at 1-10 GPa many interference parts need more than 200 N
    # the log-uniform draw: about as many parts below 1 GPa as above (those that fit)
    free = draw_trials(sc.geometry, 400, seed=1, stiffness=(1e8, 1e10))
    share = np.mean([g.stiffness < 1e9 for g in free.geometries])
    assert 0.4 < share < 0.6 and free.redrawn == 0
    same = draw_trials(sc.geometry, 300, seed=1, stiffness=(1e8, 1e10), friction=(0.1, 0.5),
                       feasible_force=200.0)  # fmt: skip
    np.testing.assert_array_equal(same.initial, t.initial)
    with pytest.raises(ConfigError, match="stiffness"):
        draw_trials(sc.geometry, 3, seed=1, stiffness=(1e9, 1e8))


def test_drawn_clearances_and_chamfers_keep_every_other_draw() -> None:
    """The clearance and the chamfer uniform within their bounds, the peg's radius from the
    drawn hole's; the deviations, radii of the hole and materials those of the same study
    without them (each draw is taken after the others)."""
    sc = validate(paper_scenario("clearance"))
    rim = sc.geometry.replace(rim=True)
    plain = draw_trials(rim, 200, seed=2, friction=(0.1, 0.5))
    t = draw_trials(rim, 200, seed=2, friction=(0.1, 0.5), clearance=(1e-5, 1e-4),
                    chamfer=(0.0, 5e-4))  # fmt: skip
    c = np.array([g.hole_radius - g.peg_radius for g in t.geometries])
    w = np.array([g.chamfer for g in t.geometries])
    assert 1e-5 <= c.min() and c.max() <= 1e-4 and c.std() > 2e-5
    assert 0.0 <= w.min() and w.max() <= 5e-4 and w.std() > 1e-4
    np.testing.assert_array_equal(t.initial, plain.initial)
    for a, b in zip(plain.geometries, t.geometries, strict=True):
        assert (a.hole_radius, a.friction, a.stiffness) == (b.hole_radius, b.friction, b.stiffness)
    with pytest.raises(ConfigError, match="rim"):  # a chamfer needs the top face it cuts
        draw_trials(sc.geometry, 3, seed=2, chamfer=(0.0, 5e-4))
    with pytest.raises(ConfigError, match="clearance"):
        draw_trials(rim, 3, seed=2, clearance=(0.0, 1e-4))


def test_drawn_grips_hold_each_trial_as_its_own_holder_would() -> None:
    """--grip: each trial's grip log-uniform within its ranges, drawn after every other draw;
    a batch held by them runs each trial as the scenario with that holder runs it alone."""
    sc = scenario_io.load(ROOT / "config" / "scenarios" / "mujoco_clearance.yaml")
    sc = sc.on_plant("model")
    sc = dataclasses.replace(sc, duration=0.3)
    plain = draw_trials(sc.geometry, 3, seed=4, friction=(0.1, 0.5))
    t = draw_trials(sc.geometry, 3, seed=4, friction=(0.1, 0.5), grip=(2e4, 1e6, 10.0, 3e3))
    np.testing.assert_array_equal(t.initial, plain.initial)
    assert t.geometries == plain.geometries and t.holders is not None
    assert all(2e4 <= k.lateral <= 1e6 and 10.0 <= k.angular <= 3e3 for k in t.holders)
    many = draw_trials(sc.geometry, 400, seed=4, grip=(2e4, 1e6, 10.0, 3e3)).holders
    assert many is not None  # log-uniform: about half below the ranges' geometric means
    assert 0.4 < np.mean([k.lateral < math.sqrt(2e4 * 1e6) for k in many]) < 0.6
    batch, _ = simulate(sc, "fbcc", initial=t.initial, geometries=t.geometries, record=False,
                        noise_seeds=t.noise_seeds(sc.seed), holders=t.holders)  # fmt: skip
    for i, holder in enumerate(t.holders):
        one = t.part(slice(i, i + 1))
        alone, _ = simulate(dataclasses.replace(sc, holder=holder), "fbcc",
                            initial=one.initial, geometries=one.geometries, record=False,
                            noise_seeds=one.noise_seeds(sc.seed))  # fmt: skip
        np.testing.assert_allclose(batch.final_features[i], alone.final_features[0],
                                   rtol=0, atol=1e-12)  # fmt: skip
        assert batch.peak_force[i] == pytest.approx(alone.peak_force[0], rel=1e-9)
    with pytest.raises(ConfigError, match="grip"):
        draw_trials(sc.geometry, 3, seed=4, grip=(1e6, 2e4, 10.0, 3e3))
    # MuJoCo's contact is drawn last: every other draw as without it, each trial its own scene
    soft = draw_trials(sc.geometry, 400, seed=4, friction=(0.1, 0.5), grip=(2e4, 1e6, 10.0, 3e3),
                       contact=(2e-4, 1e-3))
    np.testing.assert_array_equal(soft.initial[:3], t.initial)
    assert soft.geometries[:3] == t.geometries and soft.holders[:3] == t.holders
    assert soft.timeconsts is not None and all(2e-4 <= c <= 1e-3 for c in soft.timeconsts)
    assert 0.4 < np.mean([c < math.sqrt(2e-4 * 1e-3) for c in soft.timeconsts]) < 0.6
    one = soft.part(slice(5, 6))
    assert one.scenario(sc).plant.timeconst == soft.timeconsts[5]
    with pytest.raises(ConfigError, match="a drawn contact is a trial's own"):
        soft.part(slice(0, 2)).scenario(sc)
    with pytest.raises(ConfigError, match="contact"):
        draw_trials(sc.geometry, 3, seed=4, contact=(1e-3, 2e-4))


def test_push_in_force_is_the_models_centred_axial_force() -> None:
    sc = validate(paper_scenario("interference"))
    g = sc.geometry
    for depth in (2e-3, 10e-3):
        fz = g.response(np.array([0.0, 0.0, depth, 0.0, 0.0]))[2]
        assert g.push_in_force(depth) == pytest.approx(fz, rel=1e-9)
    assert validate(paper_scenario("clearance")).geometry.push_in_force() == 0.0


def test_a_holder_in_series_softens_the_contact_and_a_stiff_one_changes_nothing() -> None:
    """Scenario ``holder``: a holder far stiffer than the contact gives the rigid plant's run;
    the LBR + F/T sensor + gripper estimate (2.5e4 N/m, 30 N·m/rad) lets the peg give way, so
    the same command meets a smaller lateral force at first contact."""
    data = {**paper_scenario("clearance"), "duration": 0.6, "sensor": {"noise": 0}}
    data["geometry"] = {**data["geometry"], "stiffness": 1e10}
    rigid = simulate(validate(data), "none")[1]
    stiff = simulate(validate({**data, "holder": {"lateral": 1e12, "angular": 1e9}}), "none")[1]
    soft = simulate(validate({**data, "holder": {"lateral": 2.5e4, "angular": 30.0}}), "none")[1]
    assert rigid is not None and stiff is not None and soft is not None
    np.testing.assert_allclose(stiff.response, rigid.response, rtol=1e-3, atol=1e-2)
    lateral = [np.abs(t.response[:, 0, :2]).max() for t in (rigid, soft)]
    assert lateral[1] < 0.2 * lateral[0], lateral
    # the peg's true features carry the deflection (microns here)
    assert np.abs(soft.features[:, 0, 0] - rigid.features[:, 0, 0]).max() > 1e-6


@pytest.mark.parametrize(
    ("holder", "field"),
    [({"lateral": 0, "angular": 30.0}, "holder.lateral"),
     ({"lateral": 2.5e4}, "holder.angular"),
     ({"lateral": 2.5e4, "angular": 30.0, "axial": 1.0}, "holder.axial")],
)  # fmt: skip
def test_a_bad_holder_is_named(holder: dict[str, float], field: str) -> None:
    with pytest.raises(ConfigError) as err:
        validate({**paper_scenario("clearance"), "holder": holder})
    assert err.value.field == field


def test_wilson_interval() -> None:
    lo, hi = wilson_interval(1000, 1000)
    assert hi == 1.0 and lo == pytest.approx(0.99617, abs=2e-5)  # (z^2/n) / (1 + z^2/n)
    lo, hi = wilson_interval(50, 100)
    assert lo == pytest.approx(0.4038, abs=1e-3) and hi == pytest.approx(0.5962, abs=1e-3)


def test_unconverged_holder_steps_are_counted_not_lost() -> None:
    """A stiff, nearly line-to-line pair (20 GPa, 0.3 µm of clearance) behind a soft grasp: the
    holder's solver leaves some steps at the contact's edge unconverged, and the outcome says
    how many (a rigid holder solves nothing and counts none)."""
    sc = validate({"geometry": {"hole_radius": 5.0403e-3, "peg_radius": 5.04e-3,
                                "hole_depth": 0.01, "base_thickness": 0.005, "friction": 0.3,
                                "stiffness": 2e10},
                   "initial": {"dx": 5e-5, "dy": -3e-5, "theta_x": 0.005,
                               "theta_y": -0.01}})  # fmt: skip
    rigid, _ = simulate(sc, "fbcc", record=False)
    soft = dataclasses.replace(sc, holder=Holder(2.5e4, 30.0))
    compliant, _ = simulate(soft, "fbcc", record=False)
    assert rigid.summary(0)["holder_unconverged"] == 0
    assert 0 < compliant.summary(0)["holder_unconverged"] < sc.steps


def test_the_simulator_clips_each_command_as_the_supervisor_does() -> None:
    """The ROS cell's supervisor moves each command at most ``max_step`` / ``max_step_angle``
    from the last; the simulator applies the same clip (here tightened until it acts)."""
    from fbcc_ros.core.control.supervisor import SafetyLimits

    sc = validate({**paper_scenario("clearance"), "duration": 1.0})
    tight = SafetyLimits(max_step=2e-6, max_step_angle=1e-5)
    _, clipped = simulate(sc, "fbcc", limits=tight)
    _, free = simulate(sc, "fbcc")
    assert clipped is not None and free is not None
    steps = np.abs(np.diff(clipped.command[:, 0], axis=0)).max(axis=0)
    assert (steps[:3] <= 2e-6 * (1 + 1e-9)).all() and (steps[3:] <= 1e-5 * (1 + 1e-9)).all()
    free_steps = np.abs(np.diff(free.command[:, 0], axis=0)).max(axis=0)
    assert free_steps[2] > 4e-6  # the depth ramp alone: 5 µm a period, so the clip did act


def test_a_delayed_robot_follows_the_same_commands_later(tmp_path: Path) -> None:
    """robot.delay: the commands reach the robot that many periods late, in the simulator and in
    the mock cell of the ROS nodes. Position control alone (its commands ignore the force):
    the delayed pose is the undelayed one shifted by the delay, sample for sample."""
    data = yaml.safe_load((ROOT / "config/scenarios/robust_clearance.yaml").read_text())
    data["controller"] = {"type": "none"}
    # aligned: no contact force stops either run at the force limit at its own moment
    data["initial"] = {"dx": 0.0, "dy": 0.0, "theta_x": 0.0, "theta_y": 0.0}
    _, now = simulate(validate(data), "none")
    data["robot"] = {"delay": 0.02}
    _, late = simulate(validate(data), "none")
    assert now is not None and late is not None
    np.testing.assert_array_equal(late.pose[20:], now.pose[:-20])
    assert (late.pose[:20] == 0.0).all() and now.pose[5, 0, 2] > 0.0

    cell_data = yaml.safe_load((ROOT / "config/scenarios/bringup_interference.yaml").read_text())
    cell_data["robot"] = dict(cell_data.get("robot", {}), delay=0.02)
    path = tmp_path / "late.yaml"
    path.write_text(yaml.safe_dump(cell_data))
    cell = MockStage(resolve("mock_cell", MOCK, {"scenario": str(path)})).cell
    start = cell.q.copy()
    cell.command(start + 0.01)
    for _ in range(20):  # 19 periods after the command: not yet at the arm
        np.testing.assert_array_equal(cell.step(1e-3).q, start)
    assert (cell.step(1e-3).q > start).all()  # the 20th: it is
