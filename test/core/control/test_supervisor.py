"""The controller's phases and safety (fbcc_ros.core.control.supervisor), and the mock cell's plant
(fbcc_ros.core.sim.mock_cell) against the pure simulator."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys

import numpy as np
import pytest

from fbcc_ros.core.compensation.compensator import Compensator, SensorSetup
from fbcc_ros.core.control.compliance import ComplianceParams
from fbcc_ros.core.control.laws import make_law
from fbcc_ros.core.control.supervisor import SafetyLimits, Supervisor
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.kinematics.cell import aligned_hole_at
from fbcc_ros.core.kinematics.robot import RobotModel
from fbcc_ros.core.paper import paper_scenario
from fbcc_ros.core.sim import scenario
from fbcc_ros.core.sim.mock_cell import MockCell
from fbcc_ros.core.sim.simulation import simulate

DT = 1e-3


def _supervisor(law: str = "fbcc", **limits: float) -> Supervisor:
    sc = scenario.validate(paper_scenario("interference", law))
    return Supervisor(make_law(law, sc.geometry, sc.params, sc.insertion), DT,
                      SafetyLimits(**limits))  # fmt: skip


def _start(sup: Supervisor, now: float) -> tuple[bool, str]:
    """``start`` at ``now``, after a compensated wrench (a start needs a recent one)."""
    sup.on_response(now, np.zeros(5))
    return sup.start(now)


def test_idle_until_armed_then_started_then_inserting() -> None:
    """``idle`` until both inputs are recent (``armed``), back to ``idle`` when one goes stale;
    a start is refused with what is missing, accepted when armed."""
    sup = _supervisor(timeout=0.05)
    assert sup.start(0.0) == (False, "no recent features: is the kinematics node running?")
    sup.on_features(0.0, np.zeros(5))
    ok, why = sup.start(0.0)
    assert not ok and why.startswith("no recent compensated wrench") and sup.phase == "idle"
    assert sup.on_response(0.0, np.zeros(5)) is None and sup.phase == "armed"
    sup.on_features(0.051, np.zeros(5))
    assert sup.phase == "idle"  # that wrench is stale by then
    ok, why = sup.start(0.051)
    assert not ok and why.startswith("no recent compensated wrench")
    assert sup.on_response(0.052, np.zeros(5)) is None
    assert sup.not_armed(0.052) == ""  # armed: a start now is accepted
    ok, _ = sup.start(0.052)
    assert ok and sup.phase == "inserting" and sup.not_armed(0.052) == "already inserting"
    command = sup.on_response(0.053, np.zeros(5))
    assert command is not None and command[2] == pytest.approx(5e-3 * DT)  # the depth ramp


@pytest.mark.parametrize(
    ("event", "reason", "holds"),
    [
        (lambda s: s.on_response(0.001, [0, 0, math.nan, 0, 0]), "non-finite or malformed resp",
         "measured"),
        (lambda s: s.on_features(0.001, [0, 0, math.inf, 0, 0]), "non-finite or malformed feat",
         "measured"),
        (
            lambda s: [s.watchdog(t) for t in np.arange(0.01, 0.2, 0.01)],
            "stale compensated wrench: none for 0.060 s",
            "measured",  # the features are stale too: still the arm's last known pose
        ),
        (lambda s: s.fault("IK failed: out of reach", 0.001), "IK failed", "measured"),
    ],
)  # fmt: skip
def test_faults_hold_and_say_why(event, reason, holds) -> None:
    """A fault stops the insertion with its reason and holds where the arm was last measured
    (the arm does not go on to a command it has not reached), however old that measurement."""
    sup = _supervisor(timeout=0.05)
    sup.on_features(0.0, np.zeros(5))
    _start(sup, 0.0)
    last = sup.on_response(0.0005, np.zeros(5))
    measured = np.full(5, 1e-6)
    sup.on_features(0.0006, measured)  # the arm, measured a little behind its command
    event(sup)
    assert sup.phase == "fault" and reason in sup.reason
    held = sup.on_response(0.002, np.ones(5))
    np.testing.assert_array_equal(held, measured if holds == "measured" else last)


def test_a_force_limit_holds_where_the_arm_is() -> None:
    sup = _supervisor()
    sup.on_features(0.0, np.zeros(5))
    _start(sup, 0.0)
    sup.on_response(0.001, np.zeros(5))
    sup.on_features(0.0015, np.full(5, 2e-6))
    assert np.array_equal(sup.on_response(0.002, [0, 0, 400.0, 0, 0]), np.full(5, 2e-6))
    assert sup.phase == "force_limit"


def test_a_retract_withdraws_along_the_axis_one_step_per_features_until_reset_or_a_trip() -> None:
    """With ``retract`` 0.2 mm after a force limit: each measured features moves the command
    one max_step (50 µm) out of the hole, depth only, and it stops at 0.2 mm; a reset ends
    it; a guard trip while withdrawing stops it where the arm is and is added to the reason."""
    for ending in ("target", "reset", "trip"):
        sc = scenario.validate(paper_scenario("interference", "fbcc"))
        sup = Supervisor(make_law("fbcc", sc.geometry, sc.params, sc.insertion), DT,
                         SafetyLimits(), retract=2e-4)  # fmt: skip
        x = np.array([1e-6, 0.0, 5e-3, 0.0, 1e-3])
        sup.on_features(0.0, x)
        _start(sup, 0.0)
        sup.on_response(0.001, [0, 0, 400.0, 0, 0])  # the force limit: hold at x
        assert sup.phase == "force_limit" and np.array_equal(sup.command, x)
        depths = []
        for k in range(8):
            t = 0.002 + k * DT
            if ending == "reset" and k == 2:
                assert sup.reset()[0]
            if ending == "trip" and k == 2:
                sup.fault("wrench guard: |f| 290 N over 270 N", t)
            command = sup.on_features(t, x)
            depths.append(None if command is None else round(float(command[2] - x[2]), 9))
            assert np.array_equal(sup.command[[0, 1, 3, 4]], x[[0, 1, 3, 4]])
        if ending == "target":
            assert depths == [-5e-5, -1e-4, -1.5e-4, -2e-4, None, None, None, None]
        else:
            assert depths[:2] == [-5e-5, -1e-4] and depths[2:] == [None] * 6
        if ending == "trip":
            assert sup.reason.endswith("; then wrench guard: |f| 290 N over 270 N")
            assert np.array_equal(sup.command, x)  # held where the arm was measured


def test_a_stall_of_our_own_is_not_stale_input() -> None:
    """The watchdog's first call after 0.2 s without running at all (the process stalled)
    waits one timeout for the queued input; input that then still does not come faults."""
    sup = _supervisor(timeout=0.05)
    sup.on_features(0.0, np.zeros(5))
    _start(sup, 0.0)
    sup.watchdog(0.2)
    assert sup.phase == "inserting" and sup.stalls == 1
    sup.on_features(0.201, np.zeros(5))
    sup.on_response(0.201, np.zeros(5))  # the queued input arrives
    for t in np.arange(0.21, 0.25, 0.01):
        sup.watchdog(t)
    assert sup.phase == "inserting"
    for t in np.arange(0.25, 0.32, 0.01):  # nothing more comes
        sup.watchdog(t)
    assert sup.phase == "fault" and "stale" in sup.reason


def test_the_law_does_not_step_on_wrenches_without_fresh_features() -> None:
    """The kinematics stalls while the wrenches keep coming: the law steps only while the
    features are at most ``fresh`` old (10 ms at 1 kHz), then holds its command (counted as
    blind) until the stale-input fault, which holds the last measured pose; a law that ran on
    would have ramped 1.25 mm deeper in the 0.25 s timeout."""
    sup = _supervisor()
    assert sup.fresh == pytest.approx(0.01)
    x = np.array([0.0, 0.0, 2e-3, 0.0, 0.0])
    sup.on_features(0.0, x)
    _start(sup, 0.0)
    depths = []
    for k in range(1, 300):  # the features stop at t = 0; a wrench every millisecond
        t = k * DT
        command = sup.on_response(t, np.zeros(5), stamp=t)
        sup.watchdog(t)
        depths.append(command[2] - x[2])
    assert sup.phase == "fault" and "stale features" in sup.reason
    assert max(depths) <= 10 * 5e-3 * DT + 1e-12  # 10 periods of the 5 mm/s ramp at most
    assert sup.blind >= 240
    np.testing.assert_array_equal(sup.command, x)  # held where the arm was last measured


def test_after_a_blind_pause_the_law_steps_one_period() -> None:
    """Features back after a pause: the next step counts one period, not the blind time."""
    sup = _supervisor()
    x = np.zeros(5)
    sup.on_features(0.0, x)
    _start(sup, 0.0)
    sup.on_response(0.001, np.zeros(5), stamp=0.001)
    before = sup.command[2]
    for t in (0.02, 0.05):  # blind
        assert sup.on_response(t, np.zeros(5), stamp=t)[2] == before
    sup.on_features(0.06, x)
    assert sup.on_response(0.06, np.zeros(5), stamp=0.06)[2] == pytest.approx(before + 5e-3 * DT)
    assert sup.blind == 2 and sup.phase == "inserting"


def test_stale_features_fault_on_the_next_wrench() -> None:
    sup = _supervisor(timeout=0.01)
    sup.on_features(0.0, np.zeros(5))
    _start(sup, 0.0)
    sup.on_response(0.02, np.zeros(5))
    assert sup.phase == "fault" and "stale features" in sup.reason


def test_force_limit_and_abort() -> None:
    sup = _supervisor()
    sup.on_features(0.0, np.zeros(5))
    _start(sup, 0.0)
    sup.on_response(0.001, [0, 0, 400.0, 0, 0])
    assert sup.phase == "force_limit" and "over the limit 300.0 N" in sup.reason
    assert sup.abort() == (False, "nothing to abort: force_limit")
    sup2 = _supervisor()
    sup2.on_features(0.0, np.zeros(5))
    _start(sup2, 0.0)
    assert sup2.abort()[0] and sup2.phase == "aborted"


@pytest.mark.parametrize("end", ["fault", "force_limit"])
def test_a_fault_or_a_force_limit_must_be_reset_before_a_new_start(end: str) -> None:
    """After a fault or a force limit, start is refused with the reason until reset; reset
    returns to idle (the command still held), and the next start runs from the features."""
    sup = _supervisor()
    sup.on_features(0.0, np.zeros(5))
    _start(sup, 0.0)
    sup.on_response(0.001, np.zeros(5))
    if end == "fault":
        sup.fault("IK failed: out of reach", 0.0015)
    else:
        sup.on_response(0.002, [0, 0, 400.0, 0, 0])
    assert sup.phase == end
    ok, why = _start(sup, 0.003)
    assert not ok and why.startswith(f"{end} (") and "acknowledge it with reset first" in why
    ok, said = sup.reset()
    assert ok and said.startswith(f"{end} acknowledged") and sup.phase == "armed"
    assert said.endswith("; armed")  # the inputs are recent: a start would be accepted
    # still held where the arm was measured when it ended (here the start's features)
    np.testing.assert_array_equal(sup.on_response(0.004, np.ones(5)), np.zeros(5))
    sup.on_features(0.004, np.full(5, 1e-5))
    assert _start(sup, 0.004)[0] and sup.phase == "inserting"
    np.testing.assert_array_equal(sup.command, np.full(5, 1e-5))  # from where the arm is


def test_reset_is_refused_while_inserting_and_an_abort_needs_none() -> None:
    sup = _supervisor()
    sup.on_features(0.0, np.zeros(5))
    _start(sup, 0.0)
    assert sup.reset() == (False, "inserting: abort it first")
    sup.abort()
    assert _start(sup, 0.001)[0]  # aborted: a new insertion at once


def test_a_command_never_jumps_more_than_the_step_limit() -> None:
    sup = _supervisor("admittance", max_step=1e-6, max_step_angle=1e-5)
    sup.on_features(0.0, np.zeros(5))
    _start(sup, 0.0)
    previous = np.zeros(5)
    for k in range(1, 50):  # a large lateral force: admittance wants a big displacement at once
        command = sup.on_response(k * DT, [50.0, -50.0, 10.0, 1.0, -1.0])
        assert np.all(np.abs(command[:3] - previous[:3]) <= 1e-6 + 1e-15)
        assert np.all(np.abs(command[3:] - previous[3:]) <= 1e-5 + 1e-15)
        previous = command


def test_a_rate_too_low_for_the_gains_is_refused_at_construction() -> None:
    """Not at the first command of an insertion, when the cell is already moving."""
    sc = scenario.validate(paper_scenario("interference", "fbcc"))
    # tilt mode at 3162 rad/s: needs >= 3.2 kHz
    params = ComplianceParams.from_mapping({"M_do": 1e-4})
    law = make_law("fbcc", sc.geometry, params, sc.insertion)
    with pytest.raises(ConfigError) as err:
        Supervisor(law, 1e-3, SafetyLimits())
    assert err.value.field == "dt" and "Hz" in str(err.value)
    Supervisor(law, 1e-4, SafetyLimits())  # 10 kHz resolves it


def test_compiled_kernels_load_at_preload_for_the_types_the_loop_uses() -> None:
    """Constructing a law, the mock's plant or the IK compiles nothing of the loop; ``preload()``
    loads each numba kernel (from the cache), with the argument types the first period then
    uses (no second signature): loaded at the first period instead, they cost the 1 kHz loop
    ~8 ms and left ~47k objects for the garbage collector to walk. A fresh interpreter, so no
    other test has loaded them already."""
    code = """if True:
        import numpy as np
        from fbcc_ros.core.paper import paper_scenario
        from fbcc_ros.core.contact import kernel as contact
        from fbcc_ros.core.control import laws as control
        from fbcc_ros.core.control import robust_kernel
        from fbcc_ros.core.control.compliance import ComplianceParams
        from fbcc_ros.core.control.robust_params import RobustParams
        from fbcc_ros.core.kinematics import ik
        from fbcc_ros.core.kinematics.cell import CellKinematics, aligned_hole_at
        from fbcc_ros.core.kinematics.robot import RobotModel
        from fbcc_ros.core.sim import scenario
        from fbcc_ros.core.sim.mock_cell import MockCell
        sc = scenario.validate(paper_scenario("interference", "fbcc"))
        kernels = (control._law_rows, robust_kernel.robust_rows, contact.response_kernel,
                   ik._dls_update)
        laws = [control.make_law("fbcc", sc.geometry, ComplianceParams(), sc.insertion),
                control.make_law("admittance", sc.geometry, ComplianceParams(), sc.insertion),
                control.make_law("fbcc", sc.geometry, RobustParams(), sc.insertion)]
        print(*(len(k.signatures) for k in kernels))
        robot = RobotModel.from_name("iiwa14")
        hole = aligned_hole_at(robot.peg_in_base(robot.home))
        cell = MockCell(sc, robot, hole)
        kin = CellKinematics(robot, hole, sc.geometry.peg_radius)
        for piece in (*laws, cell, kin):
            piece.preload()
        print(*(len(k.signatures) for k in kernels))
        for law in laws:
            law.step(np.zeros(5), np.zeros(5), 1e-3)
        cell.step(1e-3)
        kin.pose_solution(kin.peg_in_hole(cell.q), cell.q, 1e-3)
        print(*(len(k.signatures) for k in kernels))
    """
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    constructed, preloaded, stepped = out.stdout.splitlines()
    assert constructed.split()[:2] == ["0", "0"]  # the laws' kernels: not by their constructors
    assert preloaded.split() == ["1", "1", "1", "1"]
    assert stepped.split() == ["1", "1", "1", "1"]


def test_bad_limits() -> None:
    with pytest.raises(ConfigError, match="timeout"):
        SafetyLimits(timeout=0.0)


def test_mock_cell_loop_agrees_with_the_simulator() -> None:
    """The joint-space plant (true hole displaced in SE(3), exact features, IK each step, a
    sensor under the hole with fixture and bias, tared by the compensation) against the
    feature-space simulator on Fig. 9's interference case, same law and noise level."""
    sc = scenario.load("config/scenarios/fig9_interference.yaml").with_law("fbcc")
    outcome, _ = simulate(sc, "fbcc", record=False)
    robot = RobotModel.from_name("iiwa14")
    hole = aligned_hole_at(robot.peg_in_base(robot.home))
    cell = MockCell(sc, robot, hole)
    comp = Compensator(
        SensorSetup(pose=cell.sensor_in_hole, acting_point=tuple(cell.sensor_in_hole.translation),
                    hole_in_base=hole, tare_samples=50)
    )  # fmt: skip
    sup = Supervisor(make_law("fbcc", sc.geometry, sc.params, sc.insertion), DT, SafetyLimits())
    peak_fz = 0.0
    q = cell.q
    for k in range(sc.steps + 50):
        sample = cell.step(DT)
        t = k * DT
        sup.on_features(t, cell.believed.features(sample.q))
        out = comp.reading(t, "ft_sensor", sample.raw)
        if out is None:
            continue  # taring
        if sup.phase in ("idle", "armed"):
            _start(sup, t)
        command = sup.on_response(t, out.response)
        q = cell.believed.tcp_solution(command, q, DT).q
        cell.command(q)
        peak_fz = max(peak_fz, float(sample.response[2]))
    final = sample.features
    expected = outcome.final_features[0]
    # Lateral features: the same end state.
    np.testing.assert_allclose(final[[0, 1]], expected[[0, 1]], atol=2e-5)  # offsets [m]
    np.testing.assert_allclose(final[[3, 4]], expected[[3, 4]], atol=2e-3)  # tilts [rad]
    # Depth: the hole is tilted by 2°; both plants end at the true depth along its axis
    # (the law's axis depth), within the depth tolerance.
    assert final[2] == pytest.approx(sc.insertion.depth, abs=sc.tolerance.depth)
    assert expected[2] == pytest.approx(sc.insertion.depth, abs=sc.tolerance.depth)
    # peak Fz: 68.5 N here against 62.9 N simulated (the tilted hole, IK, one-step delays)
    assert peak_fz == pytest.approx(outcome.peak_fz[0], rel=0.15)


def test_the_law_steps_the_time_between_sample_stamps() -> None:
    """A sample two periods after the previous one is stepped as two periods (and counted
    late); a gap longer than the law resolves is bounded; without stamps, one period each."""
    sc = scenario.validate(paper_scenario("interference", "fbcc"))
    steps: list[float] = []

    def run(stamps: list[float | None]) -> Supervisor:
        law = make_law("fbcc", sc.geometry, sc.params, sc.insertion)
        original = law.step

        def spy(response, features, dt):  # type: ignore[no-untyped-def]
            steps.append(dt)
            return original(response, features, dt)

        law.step = spy  # type: ignore[method-assign]
        sup = Supervisor(law, DT, SafetyLimits(timeout=1.0))
        sup.on_features(0.0, np.zeros(5))
        _start(sup, 0.0)
        for k, stamp in enumerate(stamps):
            sup.on_features(k * DT, np.zeros(5), stamp)  # fresh with each sample
            sup.on_response(k * DT, np.zeros(5), stamp)
        return sup

    sup = run([0.0, 0.001, 0.003, 0.004, 1.0])
    assert steps == pytest.approx([DT, DT, 2 * DT, DT, sup.max_periods * DT])
    assert sup.late == 2 and 1 < sup.max_periods <= 10
    steps.clear()
    run([None, None, None])
    assert steps == pytest.approx([DT] * 3)


def test_the_mock_cell_refuses_a_moving_acting_point() -> None:
    """``peg_top`` moments are about the peg's top face, which moves with the peg: a sensor
    under the hole cannot report them as if they were its own, so the mock refuses them and
    says why (the simulator takes them)."""
    sc = scenario.load("config/scenarios/fig9_interference.yaml")
    robot = RobotModel.from_name("iiwa14")
    hole = aligned_hole_at(robot.peg_in_base(robot.home))
    np.testing.assert_allclose(sc.geometry.acting_point_in_hole(), [0, 0, -0.015])
    moving = dataclasses.replace(sc, geometry=sc.geometry.replace(acting_point="peg_top"))
    with pytest.raises(ConfigError, match=r"peg_top.*moves with the peg"):
        MockCell(moving, robot, hole)
