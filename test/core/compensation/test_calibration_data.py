"""Samples for the calibration from time series (fbcc_ros.core.compensation.calibration_data)
and the poses that excite it (calibration_poses), on a simulated wrist sensor: an iiwa14 moving
smoothly between the poses of ``calibration_poses``, holding each for 0.5 s, its sensor reading a
known payload, a bias, white noise and a ring after each stop, at 1 kHz.

Tolerances come from the noise: a fit of K averaged poses has the parameter covariance
``(Aᵀ W A)⁻¹`` (A the static regressor, W the inverse variance of each averaged reading,
σ² / n for n readings of white noise σ); the centre of mass ``c = (m c) / m`` by the delta
method. A recovered parameter is asserted within 5 of its standard deviations (a Gaussian error
exceeds that with probability 6e-7): what is left beyond the noise (the ring, the creep at a
dwell's edges) would show as more.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation import calibration_data as cd
from fbcc_ros.core.compensation import calibration_poses as cp
from fbcc_ros.core.compensation.calibration_motion import minimum_jerk
from fbcc_ros.core.compensation.compensator import SENSOR_FRAME, sensor_motion
from fbcc_ros.core.compensation.payload import Motion, Payload, calibrate, payload_wrench
from fbcc_ros.core.kinematics.robot import RobotModel, pose

HOLDER = Payload(0.8, (0.004, -0.002, 0.06), ((4e-3, 2e-4, 0), (2e-4, 3e-3, 0), (0, 0, 1.5e-3)))
BIAS = np.array([1.5, -0.7, 3.0, 0.05, -0.02, 0.01])
NOISE = np.array([0.05] * 3 + [0.002] * 3)  # 1 σ per reading [N, N m]
RATE = 1000.0  # the sensor's [Hz]
DWELL = 0.5  # each pose held [s]
SENSOR_XYZ, SENSOR_RPY = (0.0, 0.0, 0.035), (0.0, 0.0, 0.5)


def iiwa() -> RobotModel:
    robot = RobotModel.from_name("iiwa14")
    robot.add_frame(SENSOR_FRAME, pose(SENSOR_XYZ, SENSOR_RPY))
    return robot


@functools.lru_cache(maxsize=1)
def _robot() -> RobotModel:
    return iiwa()


@functools.lru_cache(maxsize=1)
def poses() -> cp.PoseSet:
    return cp.calibration_poses(_robot(), 6, SENSOR_FRAME)


def _move(q0: FloatArray, q1: FloatArray, limit: FloatArray) -> tuple[FloatArray, ...]:
    """A minimum-jerk move, its peak speed 90 % of each joint's limit: t, q, dq, ddq."""
    delta = q1 - q0
    duration = max(float(np.max(1.875 * np.abs(delta) / (0.9 * limit))), 0.2)
    t = np.arange(1, round(duration * RATE) + 1) / RATE
    p, v, a = minimum_jerk(t / duration)
    return (t, q0 + np.outer(p, delta), np.outer(v / duration, delta),
            np.outer(a / duration**2, delta))  # fmt: skip


@functools.lru_cache(maxsize=4)
def simulate(targets: tuple[tuple[float, ...], ...] | None = None, seed: int = 0,
             dwell: float = DWELL) -> dict[str, FloatArray]:  # fmt: skip
    """The arm holding ``targets`` (default: :func:`poses`) in turn, ``dwell`` each, moving
    between them; the sensor reading at 1 kHz. Returns the truth at 1 kHz: ``t, q, dq, ddq``,
    the noisy reading ``wrench``, and ``holds`` (K, 2): when each pose was held [s]."""
    robot = _robot()
    q_targets = np.array(targets) if targets is not None else poses().q
    rng = np.random.default_rng(seed)
    n_hold = round(dwell * RATE)
    ts, qs, dqs, ddqs, holds = [], [], [], [], []
    now, q = 0.0, q_targets[0]
    for k, target in enumerate(q_targets):
        if k:
            t, mq, mdq, mddq = _move(q, target, robot.velocity_limit)
            ts.append(now + t)
            qs.append(mq)
            dqs.append(mdq)
            ddqs.append(mddq)
            now += t[-1]
            q = target
        t = now + np.arange(1, n_hold + 1) / RATE
        holds.append((t[0], t[-1]))
        ts.append(t)
        qs.append(np.tile(q, (n_hold, 1)))
        dqs.append(np.zeros((n_hold, robot.nq)))
        ddqs.append(np.zeros((n_hold, robot.nq)))
        now = t[-1]
    t, q, dq, ddq = (np.concatenate(x) for x in (ts, qs, dqs, ddqs))
    wrench = np.empty((len(t), 6))
    for i in range(len(t)):
        if i and not dq[i].any() and not ddq[i].any() and (q[i] == q[i - 1]).all():
            wrench[i] = wrench[i - 1]  # at rest: the same payload wrench
        else:
            wrench[i] = payload_wrench(HOLDER, sensor_motion(robot, q[i], dq[i], ddq[i])[1])
    wrench += BIAS
    for start, _ in holds[1:]:  # the payload rings after each stop: 15 Hz, decaying in 30 ms
        after = t >= start
        s = t[after] - start
        amplitude = rng.normal(0.0, [0.3] * 3 + [0.015] * 3)
        wrench[after] += np.outer(np.exp(-s / 0.03) * np.sin(2 * np.pi * 15 * s), amplitude)
    wrench += rng.normal(0.0, NOISE, wrench.shape)
    return {"t": t, "q": q, "dq": dq, "ddq": ddq, "wrench": wrench, "holds": np.array(holds)}


def parameter_std(robot: RobotModel, dwells: list[cd.Dwell]) -> dict[str, FloatArray]:
    """1 σ of the static fit's mass, centre of mass and bias from the readings' noise
    (:data:`NOISE`) and the dwells found (module doc)."""
    gravity = [cp.gravity_in_frame(robot, d.q, SENSOR_FRAME) for d in dwells]
    a = cp.static_regressor(gravity)
    weight = np.concatenate([d.readings / NOISE**2 for d in dwells])
    cov = np.linalg.inv(a.T @ (weight[:, None] * a))
    m, h = HOLDER.mass, HOLDER.mass * np.array(HOLDER.com)
    jac = np.zeros((3, 10))  # d(h/m)/d(m, h)
    jac[:, 0], jac[:, 1:4] = -h / m**2, np.eye(3) / m
    return {"mass": np.sqrt(cov[0, 0]), "com": np.sqrt(np.diag(jac @ cov @ jac.T)),
            "bias": np.sqrt(np.diag(cov)[4:])}  # fmt: skip


def within_noise(robot: RobotModel, dwells: list[cd.Dwell], mass: float, com: FloatArray,
                 bias: FloatArray, sigmas: float = 5.0) -> dict[str, float]:  # fmt: skip
    """Asserts the fit within ``sigmas`` standard deviations of the truth; returns the largest
    error of each in standard deviations."""
    std = parameter_std(robot, dwells)
    errors = {
        "mass": float(abs(mass - HOLDER.mass) / std["mass"]),
        "com": float(np.max(np.abs(np.asarray(com) - HOLDER.com) / std["com"])),
        "bias": float(np.max(np.abs(np.asarray(bias) - BIAS) / std["bias"])),
    }
    assert max(errors.values()) < sigmas, (errors, std)
    return errors


def _series(sim: dict[str, FloatArray], every: int, velocities: bool = True,
            position_noise: float = 0.0, seed: int = 1) -> cd.JointStates:  # fmt: skip
    """The joint states a robot publishes: every ``every``-th ms, 0.3 ms before the sensor."""
    q = sim["q"][::every]
    q = q + np.random.default_rng(seed).normal(0.0, position_noise, q.shape)
    return cd.JointStates(sim["t"][::every] - 3e-4, q, sim["dq"][::every] if velocities else None)


# --- pairing and differentiation


def test_pairing_takes_the_nearest_joint_state_and_refuses_a_gap() -> None:
    joints = np.array([0.0, 0.01, 0.02, 0.06, 0.07])
    readings = np.array([-0.001, 0.004, 0.006, 0.03, 0.04, 0.0645, 0.09])
    pairing = cd.pair_nearest(readings, joints, max_gap=0.015)
    assert pairing.index.tolist() == [0, 0, 1, 2, 3, 3, 4]
    np.testing.assert_allclose(pairing.gap, [0.001, 0.004, 0.004, 0.01, 0.02, 0.0045, 0.02])
    assert pairing.ok.tolist() == [True, True, True, True, False, True, False]
    assert pairing.refused == 2


def test_positions_are_differentiated_across_the_window() -> None:
    t = np.arange(0.0, 2.0, 1e-3)
    q = np.column_stack([np.sin(3 * t), 0.2 * t])
    dq = cd.differentiate(t, q)
    inner = slice(20, -20)  # a central difference of ±10 ms: error (3 rad/s · 10 ms)² / 6
    np.testing.assert_allclose(dq[inner, 0], 3 * np.cos(3 * t[inner]), atol=3 * 1.6e-4)
    np.testing.assert_allclose(dq[:, 1], 0.2, atol=1e-9)
    # 1e-5 rad of encoder noise: differentiated sample to sample at 1 kHz it is 0.014 rad/s,
    # over DWELL_SPEED at its peaks; across the window 7e-4 rad/s rms, 3e-3 at the peaks
    noisy = np.random.default_rng(0).normal(0.0, 1e-5, (2000, 1))
    assert np.abs(np.gradient(noisy[:, 0], t)).max() > cd.DWELL_SPEED
    inside = cd.differentiate(t, noisy)[20:-20]
    assert np.sqrt(np.mean(inside**2)) < 8e-4 and np.abs(inside).max() < 0.4 * cd.DWELL_SPEED
    # a coarse series (100 Hz): one state each side
    coarse = cd.differentiate(t[::10], q[::10])
    np.testing.assert_allclose(coarse[1:-1, 1], 0.2, atol=1e-9)


def test_bad_series_are_refused() -> None:
    with pytest.raises(ValueError, match="strictly increasing"):
        cd.JointStates(np.array([0.0, 0.0, 1.0]), np.zeros((3, 7)))
    with pytest.raises(ValueError, match="N >= 2"):
        cd.JointStates(np.array([0.0]), np.zeros((1, 7)))
    with pytest.raises(ValueError, match="wrenches"):
        cd.Readings(np.zeros(3), np.zeros((3, 5)))


# --- dwells


@pytest.mark.parametrize(("every", "velocities"), [(1, True), (10, True), (10, False)])
def test_each_held_pose_is_one_dwell_averaged_without_its_transient(
    every: int, velocities: bool
) -> None:
    """Joint states at 1 kHz and 100 Hz, with or without velocities (then with 1e-5 rad of
    noise on the positions): one dwell per pose held, inside the hold, its mean reading the
    static one to 5 standard errors."""
    sim, robot = simulate(), _robot()
    joints = _series(sim, every, velocities, 0.0 if velocities else 1e-5)
    samples = cd.static_samples(joints, cd.Readings(sim["t"], sim["wrench"]))
    assert len(samples.dwells) == len(poses().q) and samples.empty == 0
    assert samples.pairing.refused == 0
    for dwell, (start, end), target in zip(samples.dwells, sim["holds"], poses().q, strict=True):
        # a minimum-jerk move is under DWELL_SPEED for its first and last 2 % (up to 70 ms
        # of the 4 s ones here), where it has moved 2e-4 rad: the still run reaches into them
        assert dwell.still[0] > start - 0.1 and dwell.still[1] < end + 0.1
        for at, atol in ((dwell.still, 5e-4), (dwell.window, 1e-4)):
            for t in at:
                q = [np.interp(t, sim["t"], column) for column in sim["q"].T]
                np.testing.assert_allclose(q, target, atol=atol)
        assert dwell.window[0] >= start + cd.SETTLE - 0.1
        np.testing.assert_allclose(dwell.q, target, atol=1e-5)
        static = payload_wrench(HOLDER, Motion.at_rest(
            robot.frame_in_base(target, SENSOR_FRAME).rotation)) + BIAS  # fmt: skip
        assert dwell.readings > 0.6 * DWELL * RATE
        assert (np.abs(dwell.wrench - static) < 5 * dwell.standard_error).all()
        np.testing.assert_allclose(dwell.spread, NOISE, rtol=0.15)  # the noise, no transient


def test_without_dropping_the_transient_the_ring_enters_the_dwells() -> None:
    """The same data with no settle time: the ring after each stop widens the readings
    averaged (their spread is the noise's when it is dropped)."""
    sim = simulate()
    joints, readings = _series(sim, 1), cd.Readings(sim["t"], sim["wrench"])
    kept = cd.static_samples(joints, readings)
    raw = cd.static_samples(joints, readings, settle=0.0, lead=0.0)
    assert max(d.spread[:3].max() for d in kept.dwells) < 1.1 * NOISE[0]
    assert max(d.spread[:3].max() for d in raw.dwells) > 1.2 * NOISE[0]


def test_a_joint_state_gap_is_refused_and_counted() -> None:
    sim = simulate()
    joints = _series(sim, 10)
    keep = (joints.t < 1.0) | (joints.t > 1.05)  # states at 0.9907 s, then 1.0507 s
    holey = cd.JointStates(joints.t[keep], joints.q[keep], joints.dq[keep])  # type: ignore[index]
    samples = cd.static_samples(holey, cd.Readings(sim["t"], sim["wrench"]))
    # the readings more than 15 ms from both: 1.006 to 1.035 s
    assert samples.pairing.refused == 30
    assert (samples.pairing.gap[~samples.pairing.ok] > 0.015).all()


def test_the_static_fit_of_the_dwells_recovers_the_payload_within_the_noise() -> None:
    sim, robot = simulate(), _robot()
    samples = cd.static_samples(_series(sim, 10), cd.Readings(sim["t"], sim["wrench"]))
    motions = [Motion.at_rest(robot.frame_in_base(q, SENSOR_FRAME).rotation) for q in samples.q]
    fit = calibrate(motions, samples.wrench)
    within_noise(robot, samples.dwells, fit.payload.mass, np.array(fit.payload.com), fit.bias)
    gravity = [cp.gravity_in_frame(robot, q, SENSOR_FRAME) for q in samples.q]
    assert cp.condition(gravity) == pytest.approx(fit.condition, rel=1e-9)


def test_dynamic_samples_interpolate_the_joints_at_each_reading() -> None:
    """Joint states at 100 Hz with velocities; the motion at each 1 kHz reading."""
    sim = simulate()
    samples = cd.dynamic_samples(_series(sim, 10), cd.Readings(sim["t"], sim["wrench"]))
    assert len(samples.t) == len(sim["t"]) - samples.pairing.refused
    truth = {k: sim[k][samples.pairing.ok] for k in ("q", "dq", "ddq")}
    assert np.abs(samples.q - truth["q"]).max() < 2e-3  # linear between states 10 ms apart
    assert np.abs(samples.dq - truth["dq"]).max() < 0.02
    # ±10 ms differences of a minimum-jerk move: its jerk rounds the accelerations a little
    assert np.sqrt(np.mean((samples.ddq - truth["ddq"]) ** 2)) < 0.1
    assert not samples.differentiated


# --- poses


def test_calibration_poses_of_the_iiwa14_span_the_sensor_frame() -> None:
    robot = iiwa()
    chosen = cp.calibration_poses(robot, 12, SENSOR_FRAME)
    assert chosen.q.shape == (12, 7) and chosen.condition < 2.0
    np.testing.assert_array_equal(chosen.q[0], robot.home)
    assert all(robot.within_limits(q) for q in chosen.q)
    floor = robot.flange_in_base(robot.home).translation[2] - cp.MAX_DROP
    assert all(robot.flange_in_base(q).translation[2] >= floor for q in chosen.q)
    spread = cp.spread(chosen.gravity)
    # gravity swung across x and y, and from +z to within 76° of the sensor's x-y plane
    assert (spread.high - spread.low)[:2].min() > 1.8 and spread.low[2] < 0.3
    # the flange's own frame (the documented figure) and fewer poses
    assert cp.calibration_poses(robot, 12).condition == pytest.approx(1.64, abs=0.01)
    assert cp.calibration_poses(robot, 3).condition < 5.0
    with pytest.raises(ValueError, match="3 to"):
        cp.calibration_poses(robot, 2)


def _gravity(robot: RobotModel, qs: list[FloatArray]) -> list[FloatArray]:
    return [cp.gravity_in_frame(robot, q, robot.flange_frame) for q in qs]


def test_poses_turned_about_gravity_only_are_explained() -> None:
    """At home the flange points down: A7 turns the sensor about gravity, which never moves."""
    robot = iiwa()
    qs = [robot.home + np.eye(7)[6] * a for a in (0.0, 1.0, -1.5)]
    g = _gravity(robot, qs)
    assert cp.condition(g) > 1e6
    text = cp.explain(g, robot, qs, robot.flange_frame)
    assert "gravity stayed along sensor +z" in text
    assert "never had a component along sensor x or y" in text
    assert "mass cannot be told from the force bias" in text
    assert "rotate A6 (iiwa_joint_6)" in text and "A7" not in text.split("rotate")[1]


def test_poses_tilted_one_way_only_are_explained() -> None:
    """Home and A6 tilted: gravity moved in one direction, the centre of mass along it is
    unseen; A5 or A7 (at the tilted pose) move it across."""
    robot = iiwa()
    qs = [robot.home, robot.home + np.eye(7)[5] * 0.6]
    g = _gravity(robot, qs)
    assert cp.condition(g) == np.inf
    text = cp.explain(g, robot, qs, robot.flange_frame)
    assert "gravity changed only along sensor" in text and "centre of mass along" in text
    assert "rotate A7 (iiwa_joint_7)" in text or "rotate A5 (iiwa_joint_5)" in text


def test_leave_one_out_says_which_poses_excite() -> None:
    robot = iiwa()
    tilted = [robot.home + np.eye(7)[5] * 0.6, robot.home + np.eye(7)[4] * 1.0
              + np.eye(7)[5] * 0.6]  # fmt: skip
    qs = [robot.home, *tilted, robot.home + np.eye(7)[6] * 1.0]  # the last: home again, turned
    result = cp.excitation(_gravity(robot, qs))
    assert np.isfinite(result.condition)
    assert result.roles[1] == result.roles[2] == "needed"
    # home and home turned about gravity: the same gravity, so each can go if the other stays
    assert result.roles[0] == result.roles[3] == "redundant"
    assert result.without[0] == pytest.approx(result.without[3], rel=1e-6)
