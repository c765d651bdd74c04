"""The goals of the robustness study (issue "one FBCC configuration from soft plastic to
steel"), judged on a Monte Carlo's outcome: each goal with the measured figure beside its target,
and every trial that missed one with what reproduces it (``fbcc-montecarlo``'s ``summary.json``).

A trial of the study succeeds when it meets every per-trial goal (:func:`missed_goals`); the study
asks that share to be >= ``GOAL_SUCCESS`` (MuJoCo's below). The issue says "never" of the tilt
overshoot alone, so that goal is judged on every trial. The residual and time goals are per-trial
goals: a trial over either is a failed trial of the study, counted against the success share and
listed, and each row gives the share of trials that met it, its largest figure and how many missed
it. Read as a bound on every trial instead, the time goal would fail a study over one part
assembled in 3.01 s while a part not assembled at all counts only against the 99.9 %: a slow
assembly would weigh more than none. The peak Fz goals are judged on the tail: the 99th percentile
over the study's trials (a median hid stiff tight parts peaking at 42-102 N while it read 11.8 N),
of Fz on clearance parts and of Fz above the part's push-in force on interference parts; and of the
whole force |F| on clearance parts, where a grip's lateral push counts too.

The issue states the time goal for its study, 3 s at 5 mm/s over 10 mm at 1 kHz: the travel
(2 s) and one second for the entry and the alignment. :func:`time_goal` keeps that second for
any other insertion (a 15 mm hole at 5 mm/s: 4 s), so a study of another part is judged on its
own travel rather than on the 10 mm one. A slower loop is given more: the approach into a
stiff contact is paced by the period (one ``entry_step`` a period: 0.6 mm take 0.6 s at 100 Hz,
and at 1 kHz the insertion's own 0.12 s), and the issue gives 4 s at 100 Hz. Between, and below
100 Hz, the extra time is in proportion to the period beyond 1 ms (250 Hz: 3.33 s; 50 Hz:
5.1 s); none above 1 kHz.

On MuJoCo the issue asks less: >= 99 % of the trials, in within 5 s (p99) for the same 10 mm at
5 mm/s, that is the travel and 3 s, and of the peak force only the whole |F| (p99 <= 50 N).
:func:`targets` gives a study its targets by its plant: the MuJoCo case inserts 4 mm (its
cost), so 0.8 s of travel and the 3 s, 3.8 s at 1 kHz; the slower loop's second is the same on
either plant. A run must last that long for a slow trial to count: the MuJoCo scenarios run
5 s.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from fbcc_ros.core.control.laws import Insertion
from fbcc_ros.core.sim.montecarlo import Trials, wilson_interval
from fbcc_ros.core.sim.scenario import DEFAULT_TOLERANCE, Scenario
from fbcc_ros.core.sim.simulation import Outcome

GOAL_SUCCESS = 0.999
GOAL_RESIDUAL = 0.5  # [N]
GOAL_TIME_ALLOWANCE = 1.0  # [s] beyond the travel depth / speed (3 s at 5 mm/s over 10 mm)
#: The rate whose time goal is the issue's (1 kHz), and the slow one it gives more: (rate [Hz],
#: the seconds more) -- 4 s instead of 3 s at 100 Hz.
GOAL_TIME_RATE = 1000.0
GOAL_SLOW_RATE = (100.0, 1.0)
GOAL_PEAK_FZ = 30.0  # [N] clearance: p99 of the peak; interference: p99 of the peak above push-in
GOAL_PEAK_FORCE = 50.0  # [N] clearance: p99 of the peak |F|, lateral included (MuJoCo's goal)
GOAL_PERCENTILE = 99.0  # the peak force's goals judge this percentile of the trials
GOAL_OVERSHOOT = DEFAULT_TOLERANCE["tilt"]  # [rad] a tilt past zero beyond the success tolerance
#: MuJoCo's goals (module doc): the share of its trials, and the allowance beyond the travel [s]
#: (the issue's 5 s for 10 mm at 5 mm/s)
GOAL_MUJOCO_SUCCESS = 0.99
GOAL_MUJOCO_TIME_ALLOWANCE = 3.0


class Targets(NamedTuple):
    """A study's targets: the share of its trials that must meet every per-trial goal, the
    per-trial time goal [s], and the p99 of the peak F_z [N] (None: no goal on F_z alone)."""

    success: float
    deadline: float
    peak_fz: float | None = GOAL_PEAK_FZ


def time_goal(insertion: Insertion, rate_hz: float = GOAL_TIME_RATE,
              allowance: float = GOAL_TIME_ALLOWANCE) -> float:  # fmt: skip
    """The longest an assembly may take from the start [s] at a loop of ``rate_hz``: the travel
    at the insertion's speed and ``allowance`` (the issue's 3 s for 10 mm at 5 mm/s on our
    model), and more at a rate under ``GOAL_TIME_RATE``, in proportion to the period (module
    doc)."""
    slow_rate, more = GOAL_SLOW_RATE
    periods = (1.0 / rate_hz - 1.0 / GOAL_TIME_RATE) / (1.0 / slow_rate - 1.0 / GOAL_TIME_RATE)
    return insertion.depth / insertion.speed + allowance + more * max(periods, 0.0)


def targets(sc: Scenario) -> Targets:
    """The targets of a study of ``sc``, by its plant (module doc): our model's, or MuJoCo's."""
    if sc.plant.type == "mujoco":
        return Targets(GOAL_MUJOCO_SUCCESS,
                       time_goal(sc.insertion, sc.rate_hz, GOAL_MUJOCO_TIME_ALLOWANCE), None)
    return Targets(GOAL_SUCCESS, time_goal(sc.insertion, sc.rate_hz))


def missed_goals(outcome: Outcome, deadline: float) -> list[list[str]]:
    """Per trial, the per-trial goals it missed (empty: it met them all): assembled within the
    force limit and the wrench guard, by ``deadline`` [s] (:func:`time_goal`), with at most
    ``GOAL_RESIDUAL`` of lateral force left and no tilt overshoot. A trial that missed any is a
    failed trial of the study, listed."""
    out = []
    for i in range(len(outcome.success)):
        why = []
        if outcome.stop_reason[i]:  # the force limit, or the wrench guard and its reason
            why.append(str(outcome.stop_reason[i]))
        elif not outcome.success[i]:
            why.append("not assembled at the end")
        else:
            if outcome.insertion_time[i] > deadline:
                why.append(f"assembled in {outcome.insertion_time[i]:.2f} s > {deadline:g} s")
            if outcome.residual_force[i] > GOAL_RESIDUAL:
                why.append(f"residual {outcome.residual_force[i]:.2f} N > {GOAL_RESIDUAL:g} N")
        if outcome.tilt_overshoot[i] > GOAL_OVERSHOOT:
            why.append(f"tilt overshoot {math.degrees(outcome.tilt_overshoot[i]):.2f} deg")
        out.append(why)
    return out


def goals(outcome: Outcome, trials: Trials, missed: list[list[str]],
          target: Targets) -> dict[str, Any]:  # fmt: skip
    """The study's goals, each with the measured figure and whether it holds.

    ``success`` is the share of trials that met every per-trial goal (``missed``, from
    :func:`missed_goals` with ``target.deadline``), against ``target.success``. The overshoot
    row judges every trial; the residual and time rows the share of trials assembled within
    them (module doc), with the largest figure of an assembled trial and how many missed; the
    peak Fz rows their ``GOAL_PERCENTILE`` (module doc)."""
    push_in = np.array([g.push_in_force() for g in trials.geometries])
    ok = outcome.success
    met = np.array([not why for why in missed])
    share, deadline, peak_fz = target
    lo, hi = wilson_interval(int(met.sum()), len(met))
    excess = outcome.peak_fz - push_in
    interference = push_in > 0
    rows: dict[str, Any] = {
        "success": {"measured": float(met.mean()), "ci95": [lo, hi],
                    "failed": int((~met).sum()),
                    "target": f">= {share} of trials assembled within the force limit, "
                              f"by {deadline:g} s, residual <= {GOAL_RESIDUAL:g} N, "
                              f"no tilt overshoot",
                    "met": float(met.mean()) >= share},
        "tilt_overshoot_deg": {
            "measured": math.degrees(float(outcome.tilt_overshoot.max())),
            "target": f"no trial past {math.degrees(GOAL_OVERSHOOT):.2f} deg",
            "met": bool((outcome.tilt_overshoot <= GOAL_OVERSHOOT).all())},
        "residual_force_N": _per_trial(ok, outcome.residual_force, GOAL_RESIDUAL, share),
        "insertion_time_s": _per_trial(ok, outcome.insertion_time, deadline, share),
    }  # fmt: skip
    for label, mask, value, limit in (
            ("peak_fz_clearance_p99_N", ~interference, outcome.peak_fz, peak_fz),
            ("peak_fz_over_push_in_p99_N", interference, excess, peak_fz),
            ("peak_force_clearance_p99_N", ~interference, outcome.peak_force, GOAL_PEAK_FORCE)):
        if mask.any() and limit is not None:
            tail = float(np.percentile(value[mask], GOAL_PERCENTILE))
            rows[label] = {"measured": tail, "median": float(np.median(value[mask])),
                           "target": f"<= {limit:g} at the {GOAL_PERCENTILE:g}th "
                                     "percentile of the trials",
                           "met": tail <= limit, "trials": int(mask.sum())}  # fmt: skip
    return rows


def _per_trial(assembled: np.ndarray, value: np.ndarray, limit: float,
               share: float) -> dict[str, Any]:  # fmt: skip
    """A per-trial goal's row: the share of trials assembled with ``value <= limit`` (judged
    against ``share``), the largest value of an assembled trial, and how many assembled
    trials are over ``limit``."""
    within = assembled & (value <= limit)  # NaN (not assembled) compares False
    return {"share": float(within.mean()),
            "measured": float(value[assembled].max()) if assembled.any() else None,
            "over_target": int((assembled & ~within).sum()),
            "target": f"<= {limit:g} per trial: a trial over it is a failed trial",
            "met": float(within.mean()) >= share}  # fmt: skip


def failures(outcome: Outcome, trials: Trials, missed: list[list[str]],
             limit: int = 200) -> list[dict[str, Any]]:  # fmt: skip
    """Every trial that missed a goal (up to ``limit``; :func:`missed_goals`) with what
    reproduces it: the study's seed and the trial's number (a trial is its seed:
    :mod:`~fbcc_ros.core.sim.montecarlo`), its part and deviation."""
    rows = []
    for i in [i for i, why in enumerate(missed) if why][:limit]:
        g, d = trials.geometries[i], trials.initial[i]
        rows.append({
            "trial": trials.numbers[i], "seed": trials.seed,
            "why": "; ".join(missed[i]),
            "stiffness": g.stiffness, "friction": g.friction, "hole_radius": g.hole_radius,
            "peg_radius": g.peg_radius, "deviation": [float(d[j]) for j in (0, 1, 3, 4)],
            "final_features": [float(v) for v in outcome.final_features[i]],
            "peak_fz": float(outcome.peak_fz[i]),
        })  # fmt: skip
    return rows
