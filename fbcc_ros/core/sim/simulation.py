"""Closed-loop simulation of an assembly (the paper's Section IV) and its metrics.

The plant (:mod:`fbcc_ros.core.sim.plants`: the model of eq. 5-13 by default, or MuJoCo) holds
the trials: the hole at its unknown deviation from where the robot believes it is, the
position-controlled robot with its lag and delay, the holder, the contact. Each period it
gives the true features and the contact's response; **the sensor** adds its bias and white
Gaussian noise (the dynamic compensation is taken as ideal apart from that bias).

The controller sees the measured wrench and the depth of ``p`` (its feature solution), and knows
only the nominal geometry. Each step: contact → sensor → control law → the supervisor's step
clip (:meth:`fbcc_ros.core.control.supervisor.SafetyLimits.clip`, the controller's default limits,
as the ROS cell's controller applies them) → robot.

Metrics (summary keys of DESIGN §4), per trial:

``success``
    the trial is *assembled* at the end and the force limit was never exceeded. Assembled: the
    final depth is reached (within ``tolerance.depth``) and, in each plane, the lateral features
    are within ``tolerance.offset`` / ``tolerance.tilt`` *or* the lateral force of that plane
    (|Fx| in XOZ, |Fy| in YOZ) is below ``tolerance.force``. A force controller cannot sense
    features inside P0 (Remark 2 of II.D): with a clearance wider than the tolerances, a peg
    that rests in the hole without pressing on the wall is assembled, wherever it rests.
``insertion_time`` [s]
    the time from which the trial stays assembled until the end; ``None`` when it is not
    assembled at the end.
``peak_fz`` [N]
    the largest axial force Fz.
``residual_force`` [N], ``residual_moment`` [N·m]
    the mean of |(Fx, Fy)| and of |(Mx, My)| over the last 10 % of the run.
``tilt_overshoot`` [rad]
    the largest excursion of a tilt past zero, opposite to its initial sign (for an initial tilt
    of zero, the largest |theta|), over both planes.
``tilt_misadjustment`` [rad] (extra)
    how far a tilt grew beyond its initial value in its initial direction (Fig. 9a's -6°).
``final_features``
    (dx, dy, l, theta_x, theta_y) at the end, true values.
``state_sequence``
    the contact states (Fig. 4) the features went through, ``"XOZ/YOZ"``, repeats collapsed.
``friction_estimate`` (extra)
    the friction the robust law's lever (eq. 24) measured by the end
    (:mod:`fbcc_ros.core.control.identification`); NaN where it measured none (it kept the
    nominal μ) and for Table I's laws.
``holder_unconverged`` (extra)
    with a compliant holder, the steps whose equilibrium the solver left unconverged (used as
    its best point: :mod:`fbcc_ros.core.sim.holder_solver`); 0 with a rigid one.

All quantities are the true ones (from the model, before the sensor), not the measured ones.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.wrench_guard import GuardLimits
from fbcc_ros.core.contact.model import FEATURE_NAMES, PegHole
from fbcc_ros.core.contact.segmentation import feature_state
from fbcc_ros.core.control.laws import Law, make_law
from fbcc_ros.core.control.supervisor import SafetyLimits
from fbcc_ros.core.errors import ConfigError, FbccError
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.plants.model import ModelContact
from fbcc_ros.core.sim.plants.plant import Contact, LaggingRobot, Plant
from fbcc_ros.core.sim.safety import CELL_GUARD, TrialSafety
from fbcc_ros.core.sim.scenario import Scenario, validate

#: Builds a plant: (scenario, robot, deviations (N, 5), true pairs (1 or N)) -> Plant.
MakePlant = Callable[[Scenario, LaggingRobot, FloatArray, Sequence[PegHole]], Plant]


def scenario_contact(sc: Scenario, n: int, pairs: Sequence[PegHole], dt: float | None = None,
                     holders: Sequence[Holder] | None = None) -> Contact:  # fmt: skip
    """The contact of the scenario's ``plant.type`` for ``n`` trials of ``pairs`` (one or n),
    stepped every ``dt`` [s] (default: the scenario's rate), held by the scenario's holder or
    ``holders`` (one per trial): the model
    (:class:`~fbcc_ros.core.sim.plants.model.ModelContact`) or MuJoCo
    (:class:`~fbcc_ros.core.sim.plants.mujoco.MujocoContact`, imported only then)."""
    dt = dt or 1.0 / sc.rate_hz
    if sc.plant.type == "model":
        return ModelContact(n, pairs, sc.holder if holders is None else holders, dt)
    from fbcc_ros.core.sim.plants.mujoco import MujocoContact, scene_of

    return MujocoContact(n, pairs, sc.holder if holders is None else holders, dt,
                         *scene_of(sc))  # fmt: skip


def scenario_plant(sc: Scenario, robot: LaggingRobot, deviation: FloatArray,
                   pairs: Sequence[PegHole],
                   holders: Sequence[Holder] | None = None) -> Plant:  # fmt: skip
    """The scenario's plant: the robot and :func:`scenario_contact`."""
    return Plant(robot, deviation, sc.geometry, pairs,
                 scenario_contact(sc, len(deviation), pairs, holders=holders))  # fmt: skip


#: Fraction of the run at its end over which the residual responses are averaged.
RESIDUAL_WINDOW = 0.1
#: Steps processed together by the metric accumulators (bounds memory for large batches).
_CHUNK = 256


@dataclasses.dataclass
class Trajectory:
    """Recorded signals of a run: time (T,), and (T, N, 5) arrays of true features, true
    responses, measured responses, commands, and the robot's pose as the controller measures
    it (features of the believed hole)."""

    t: FloatArray
    features: FloatArray
    response: FloatArray
    measured: FloatArray
    command: FloatArray
    pose: FloatArray


@dataclasses.dataclass
class Outcome:
    """Metrics per trial, each an array over the N trials (see the module doc)."""

    success: np.ndarray
    insertion_time: FloatArray  # NaN when not assembled at the end
    peak_fz: FloatArray
    peak_force: FloatArray
    residual_force: FloatArray
    residual_moment: FloatArray
    tilt_overshoot: FloatArray
    tilt_misadjustment: FloatArray
    final_features: FloatArray
    force_limited: np.ndarray
    guard_trips: FloatArray  # the oscillation guard's trips (robust law; 0 otherwise)
    wrench_guard_tripped: np.ndarray  # the cell's wrench guard ended the trial
    stop_reason: np.ndarray  # why the trial ended ("" where it ran to the end: safety.py)
    friction_estimate: FloatArray  # the friction eq. 24's lever measured (robust law; else NaN)
    holder_unconverged: FloatArray  # steps whose holder equilibrium did not converge

    def summary(self, i: int = 0) -> dict[str, Any]:
        """The DESIGN §4 summary of trial i (without the state sequence), JSON-ready."""
        t_ins = float(self.insertion_time[i])
        mu = float(self.friction_estimate[i])
        return {
            "success": bool(self.success[i]),
            "insertion_time": None if math.isnan(t_ins) else t_ins,
            "peak_fz": float(self.peak_fz[i]),
            "residual_force": float(self.residual_force[i]),
            "residual_moment": float(self.residual_moment[i]),
            "tilt_overshoot": float(self.tilt_overshoot[i]),
            "tilt_misadjustment": float(self.tilt_misadjustment[i]),
            "final_features": dict(
                zip(FEATURE_NAMES, self.final_features[i].tolist(), strict=True)
            ),
            "force_limited": bool(self.force_limited[i]),
            "wrench_guard_tripped": bool(self.wrench_guard_tripped[i]),
            "stop_reason": str(self.stop_reason[i]),
            "peak_force": float(self.peak_force[i]),
            "guard_trips": int(self.guard_trips[i]),
            "friction_estimate": None if math.isnan(mu) else mu,
            "holder_unconverged": int(self.holder_unconverged[i]),
        }


class _Metrics:
    """Accumulates the metrics chunk by chunk over a batch of N trials."""

    def __init__(self, sc: Scenario, initial: FloatArray, steps: int | None = None) -> None:
        n = len(initial)
        self.sc = sc
        self.steps = sc.steps if steps is None else steps
        self.theta0 = initial[:, 3:5]
        self.peak_fz = np.zeros(n)
        self.peak_force = np.zeros(n)
        self.theta_max = initial[:, 3:5].copy()
        self.theta_min = initial[:, 3:5].copy()
        self.last_outside = np.zeros(n)  # time of the last step not assembled
        self.resid_from = self.steps - max(1, round(RESIDUAL_WINDOW * self.steps))
        self.resid_f = np.zeros(n)
        self.resid_m = np.zeros(n)
        self.final = initial.copy()
        self.assembled_at_end = np.zeros(n, dtype=bool)

    def add(self, k0: int, t: FloatArray, x: FloatArray, w: FloatArray) -> None:
        """Steps k0 .. k0 + len(t) - 1: times (K,), true features and responses (K, N, 5)."""
        tol = self.sc.tolerance
        self.peak_fz = np.maximum(self.peak_fz, w[..., 2].max(axis=0))
        self.peak_force = np.maximum(self.peak_force, np.linalg.norm(w[..., :3], axis=-1).max(0))
        self.theta_max = np.maximum(self.theta_max, x[..., 3:5].max(axis=0))
        self.theta_min = np.minimum(self.theta_min, x[..., 3:5].min(axis=0))
        # per plane: XOZ holds (dx, theta_y, Fx), YOZ (dy, theta_x, Fy)
        within = (np.abs(x[..., :2]) <= tol.offset) & (np.abs(x[..., [4, 3]]) <= tol.tilt)
        resting = np.abs(w[..., :2]) <= tol.force
        depth_ok = x[..., 2] >= self.sc.insertion.depth - tol.depth
        assembled = depth_ok & (within | resting).all(axis=-1)
        outside_t = np.where(assembled, -np.inf, t[:, None] + 1.0 / self.sc.rate_hz)
        self.last_outside = np.maximum(self.last_outside, outside_t.max(axis=0))
        tail = slice(max(0, self.resid_from - k0), None)
        # summed in time order (cumsum) whatever N: a trial's figures do not depend on its
        # batch (np.sum pairs the terms of one trial differently from a batch's)
        if len(w[tail]):
            self.resid_f += np.cumsum(np.linalg.norm(w[tail, :, :2], axis=-1), axis=0)[-1]
            self.resid_m += np.cumsum(np.linalg.norm(w[tail, :, 3:5], axis=-1), axis=0)[-1]
        self.final = x[-1].copy()
        self.assembled_at_end = assembled[-1]

    def outcome(self, force_limited: np.ndarray, trips: FloatArray | None = None,
                unconverged: FloatArray | None = None, lever: FloatArray | None = None,
                safety: TrialSafety | None = None) -> Outcome:  # fmt: skip
        n_tail = self.steps - self.resid_from
        sign0 = np.sign(self.theta0)
        # past zero, opposite to the initial sign; any excursion when the initial tilt is zero
        either = np.maximum(self.theta_max, -self.theta_min)
        over = np.where(sign0 > 0, -self.theta_min, np.where(sign0 < 0, self.theta_max, either))
        grown = np.where(sign0 > 0, self.theta_max, -self.theta_min) - np.abs(self.theta0)
        grown = np.where(sign0 == 0, 0.0, grown)
        n = len(self.final)
        tripped = np.zeros(n, dtype=bool) if safety is None else safety.guard_tripped.copy()
        reason = (np.where(force_limited, "force limit", "").astype(object) if safety is None
                  else safety.reason.copy())  # fmt: skip
        success = self.assembled_at_end & ~force_limited & ~tripped
        return Outcome(
            success=success,
            insertion_time=np.where(self.assembled_at_end, self.last_outside, np.nan),
            peak_fz=self.peak_fz,
            peak_force=self.peak_force,
            residual_force=self.resid_f / n_tail,
            residual_moment=self.resid_m / n_tail,
            tilt_overshoot=np.maximum(over, 0.0).max(axis=1),
            tilt_misadjustment=np.maximum(grown, 0.0).max(axis=1),
            final_features=self.final,
            force_limited=force_limited,
            guard_trips=np.zeros(n) if trips is None else trips,
            wrench_guard_tripped=tripped,
            stop_reason=reason,
            friction_estimate=np.full(n, np.nan) if lever is None else lever,
            holder_unconverged=np.zeros(n) if unconverged is None else unconverged,
        )


def simulate(
    sc: Scenario,
    law_name: str,
    *,
    initial: FloatArray | None = None,
    geometries: Sequence[PegHole] | None = None,
    record: bool = True,
    seed: int | None = None,
    limits: SafetyLimits | None = None,
    guard: GuardLimits | None = CELL_GUARD,
    wrap: Callable[[Law], Any] | None = None,
    make_plant: MakePlant | None = None,
    noise_seeds: Sequence[np.random.SeedSequence] | None = None,
    holders: Sequence[Holder] | None = None,
) -> tuple[Outcome, Trajectory | None]:
    """Run N trials of the closed loop in lockstep.

    Args:
        sc: The scenario (nominal geometry for the controller, gains, sensor, robot, timing).
        law_name: ``fbcc``, ``admittance`` or ``none``.
        initial: Deviations of the hole, (N, 5); default the scenario's, N = 1.
        geometries: True geometry per trial (N of them); default the nominal one.
        record: Keep the full signals (memory T × N × 25 floats).
        seed: Seed of the sensor noise, one stream for the batch; default the scenario's.
        limits: The supervisor's step limits; default the controller's.
        guard: The wrench guard's limits (default the compensation's; None: none). With the
            supervisor's holds, the cell's safety stack (:mod:`fbcc_ros.core.sim.safety`).
        wrap: Puts something around the law (the same interface: ``reset``, ``step``,
            ``stopped``, ``trips``), e.g. :class:`~fbcc_ros.core.control.state_gate.StateGatedLaw`.
        make_plant: Builds the plant from ``(scenario, robot, deviations, true pairs)``
            (:mod:`fbcc_ros.core.sim.plants`); default :func:`scenario_plant`.
        noise_seeds: Each trial's noise seed (N of them) instead of
            ``seed``: its noise then does not depend on the batch around it (a Monte Carlo
            trial's, :mod:`fbcc_ros.core.sim.montecarlo`).
        holders: Each trial's grip (N of them) instead of the scenario's holder (a Monte
            Carlo's drawn grips), with the scenario's plant (no ``make_plant``).
    """
    dev = np.atleast_2d(sc.initial if initial is None else np.asarray(initial, dtype=float))
    n = len(dev)
    pairs = list(geometries) if geometries is not None else [sc.geometry]
    if len(pairs) not in (1, n):
        raise ConfigError("geometries", f"{len(pairs)} pairs", f"1 or {n}, one per trial")
    if noise_seeds is not None and len(noise_seeds) != n:
        raise ConfigError("noise_seeds", f"{len(noise_seeds)} seeds", f"{n}, one per trial")
    rng = np.random.default_rng(sc.seed if seed is None else seed)
    rngs = None if noise_seeds is None else [np.random.default_rng(s) for s in noise_seeds]
    law = make_law(law_name, sc.geometry, sc.params, sc.insertion)
    if wrap is not None:
        law = wrap(law)
    dt = 1.0 / sc.rate_hz
    robot = LaggingRobot(n, dt, sc.lag, sc.delay)
    if holders is not None and (make_plant is not None or len(holders) != n):
        raise ConfigError("holders", f"{len(holders)} holders",
                          f"{n}, one per trial, with the scenario's plant")  # fmt: skip
    plant = (scenario_plant(sc, robot, dev, pairs, holders) if make_plant is None
             else make_plant(sc, robot, dev, pairs))  # fmt: skip
    pose = robot.pose  # the robot's pose as features of the believed hole (moved in place)
    law.reset(pose)
    command = pose.copy()  # the supervisor starts from the measured pose
    safety = TrialSafety(n, sc.geometry, limits or SafetyLimits(), guard)
    metrics = _Metrics(sc, dev)
    chunks: list[tuple[np.ndarray, ...]] = []
    buf_x, buf_w, buf_m, buf_c, buf_p = (np.empty((_CHUNK, n, 5)) for _ in range(5))
    steps = sc.steps
    for k0 in range(0, steps, _CHUNK):
        kk = min(_CHUNK, steps - k0)
        # a chunk at a time: from the batch's stream, or from each trial's own
        noise = sc.noise * (rng.standard_normal((kk, n, 5)) if rngs is None else
                            np.stack([g.standard_normal((kk, 5)) for g in rngs], axis=1))
        for j in range(kk):
            x, w = plant.sense()
            measured = w + sc.bias + noise[j]
            buf_p[j] = pose
            target = law.step(measured, pose, dt)
            command = safety.command(command, target, pose, measured - sc.bias, x, law.stopped)
            plant.command(command)
            buf_x[j], buf_w[j], buf_m[j], buf_c[j] = x, w, measured, command
        t = (k0 + np.arange(kk)) * dt
        metrics.add(k0, np.asarray(t, dtype=float), buf_x[:kk], buf_w[:kk])
        if record:
            chunks.append((t, buf_x[:kk].copy(), buf_w[:kk].copy(), buf_m[:kk].copy(),
                           buf_c[:kk].copy(), buf_p[:kk].copy()))  # fmt: skip
    outcome = metrics.outcome(law.stopped.copy(), law.trips.copy(), plant.unconverged,
                              law.lever_frictions, safety)  # fmt: skip
    if not record:
        return outcome, None
    traj = Trajectory(*(np.concatenate([c[i] for c in chunks]) for i in range(6)))
    return outcome, traj


def score(
    sc: Scenario, t: FloatArray, features: FloatArray, responses: FloatArray, force_limited: bool
) -> Outcome:
    """The metrics of one recorded run (true features and responses (T, 5) at times (T,)), as
    :func:`simulate` scores its own trials: for runs of the ROS cell."""
    metrics = _Metrics(sc, np.atleast_2d(features[0]), steps=len(t))
    metrics.add(0, np.asarray(t, dtype=float), features[:, None, :], responses[:, None, :])
    return metrics.outcome(np.array([force_limited]))


def state_sequence(traj: Trajectory, peghole: PegHole, trial: int = 0) -> list[dict[str, Any]]:
    """The contact states of Fig. 4 along a recorded trial: ``[{"t", "state"}]``, where state is
    ``"XOZ/YOZ"`` and each entry starts a run of a new state."""
    x = traj.features[:, trial].copy()
    np.maximum(x[:, 2], 0.0, out=x[:, 2])
    xoz, yoz = feature_state(x, peghole)
    labels = np.char.add(np.char.add(np.asarray(xoz, dtype=str), "/"), np.asarray(yoz, dtype=str))
    change = np.flatnonzero(np.r_[True, labels[1:] != labels[:-1]])
    return [{"t": float(traj.t[i]), "state": str(labels[i])} for i in change]


@dataclasses.dataclass
class SimResult:
    """One run of one law: the summary of DESIGN §4 and the recorded trajectory."""

    scenario: Scenario
    law: str
    summary: dict[str, Any]
    trajectory: Trajectory


def run_scenario(sc: Scenario, law: str | None = None) -> SimResult:
    """Run one law of a validated scenario (its only law by default)."""
    law = law or sc.law
    outcome, traj = simulate(sc, law)
    if traj is None:  # not reached: record=True
        raise FbccError("simulate returned no trajectory")
    summary = outcome.summary(0)
    summary["state_sequence"] = state_sequence(traj, sc.geometry)
    return SimResult(sc, law, summary, traj)


def run(scenario: dict[str, Any]) -> SimResult:
    """Validate a scenario mapping (DESIGN §4) with one law and simulate it."""
    return run_scenario(validate(scenario))
