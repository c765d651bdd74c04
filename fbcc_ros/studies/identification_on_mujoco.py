"""The online identification's k and μ against each plant's truth: the robust law on the
insertions of the contact-state study (:func:`~fbcc_ros.core.sim.state_study.drawn_insertions`:
the clearance pair, parts drawn from the estimator's uncertainty, the hole up to 0.1 mm and 2°
off), run on the model and on MuJoCo (a :data:`CHAMFER` on MuJoCo's hole), 4 mm deep.

The identification (:mod:`fbcc_ros.core.control.identification`) estimates, per row j of
``u = A(l) F`` (eq. 28: dx, dy, theta_x, theta_y), the slope ``k_j = ∂u_j / ∂x_j`` against the
robot's measured features x: with a compliant holder the series stiffness of holder and contact.
Its truth is the same slope on the plant, at the same state: every :data:`STRIDE`-th period the
hand is moved by ``±δ_j`` (:data:`STEPS`) in row j, and

.. math::
    k_j = \\frac{u_j(x + \\delta_j e_j) - u_j(x - \\delta_j e_j)}{2\\,\\delta_j},

``u`` with A(l) of the nominal pair at the hand's depth.
* On the model: eq. 5-13 (and the holder) at the displaced hand.
* On MuJoCo: from a copy of the scene's state, the displaced hand carried on at its velocity for
  :data:`SETTLE` periods, the last period's mean wrench on the hole (what the law reads); the
  state is then restored, and the run goes on as it would have without the probe (tested).

Friction: the identification's bound (eq. 11: ``Fz / |F_lat| >= μ``) and the lever's μ at the end
of each insertion, against the part's μ (MuJoCo's scene has the part's μ).

Command: ``python -m fbcc_ros.studies.identification_on_mujoco [--trials N]`` prints the table
of docs/plant.md.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Callable, Sequence
from typing import Any

import mujoco
import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.wrench import response_from_wrench
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import apply_direction
from fbcc_ros.core.control.contact_uncertainty import Uncertainty
from fbcc_ros.core.control.identification import ROWS, ContactEstimate
from fbcc_ros.core.control.laws import Law
from fbcc_ros.core.control.robust import RobustFbcc
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.plants.model import ModelContact
from fbcc_ros.core.sim.plants.mujoco import MujocoContact
from fbcc_ros.core.sim.plants.plant import Contact, LaggingRobot, Plant
from fbcc_ros.core.sim.scenario import Scenario
from fbcc_ros.core.sim.simulation import scenario_contact, simulate
from fbcc_ros.core.sim.state_study import drawn_insertions
from fbcc_ros.studies.arguments import insertion_study_parser, parse

SCENARIO = "config/scenarios/robust_clearance.yaml"
#: The chamfer of MuJoCo's hole [m]: without one the law does not find the hole (docs/plant.md).
CHAMFER = 3.0e-4
#: The insertion: its depth [m] and the run's duration [s] (the first Monte Carlo's).
DEPTH, DURATION = 0.004, 2.5
#: Periods between two probes of the truth.
STRIDE = 25
#: The hand's displacement of each row (dx, dy, theta_x, theta_y) [m, m, rad, rad]: the size of
#: the law's own dither (its caps, 2 µm and 0.2 mrad).
STEPS = np.array([1.0e-6, 1.0e-6, 1.0e-4, 1.0e-4])
#: The periods a displaced MuJoCo scene runs before its wrench is read: the grip's modes settle
#: within about 1 ms.
SETTLE = 4
PLANTS = ("model", "mujoco")
#: What a probe saves and restores of a MuJoCo scene: all that its next step depends on.
STATE = mujoco.mjtState.mjSTATE_INTEGRATION


def _rows(response: FloatArray, hand: FloatArray, nominal: PegHole) -> FloatArray:
    """``u = A(l) F`` (eq. 28) of responses (N, 5) at the hands' depths (N, 5)."""
    return apply_direction(response, np.maximum(hand[:, 2], 0.0), nominal)


#: u (N, 5) of each trial with the hand at ``moved`` (N, 5), moving at ``velocity`` (N, 5) per
#: period, the plant's own state untouched.
Displaced = Callable[[FloatArray, FloatArray], FloatArray]


def model_displaced(model: ModelContact, nominal: PegHole) -> Displaced:
    """:data:`Displaced` on the model: eq. 5-13 (and the holder) at the displaced hand, by a
    contact of the probe's own."""

    def rows(moved: FloatArray, velocity: FloatArray) -> FloatArray:
        if model.holder is not None:
            model.holder.reset()  # each probe its own equilibrium
        _, response = model.touch(moved)
        return _rows(response, moved, nominal)

    return rows


def mujoco_displaced(contact: MujocoContact, nominal: PegHole) -> Displaced:
    """:data:`Displaced` on MuJoCo: from each scene's saved state, the displaced hand carried on
    at its velocity for :data:`SETTLE` periods, the last period's mean wrench; the state then
    restored."""
    saved = [np.empty(mujoco.mj_stateSize(s.model, STATE)) for s in contact.scenes]

    def rows(moved: FloatArray, velocity: FloatArray) -> FloatArray:
        response = np.zeros_like(moved)
        for i, (scene, state) in enumerate(zip(contact.scenes, saved, strict=True)):
            mujoco.mj_getState(scene.model, scene.data, state, STATE)
            for p in range(SETTLE):
                scene.set_hand(moved[i] + p * velocity[i])
                scene.step(contact.substeps)
            response[i] = response_from_wrench(scene.mean_wrench_on_hole(), contact.acting[i])
            mujoco.mj_setState(scene.model, scene.data, state, STATE)
        return _rows(response, moved, nominal)

    return rows


class ProbedContact:
    """A plant's contact (model or MuJoCo) whose rows' true stiffness is measured every
    ``stride``-th period, before the period runs (module doc). ``periods``, ``hands`` (N, 5) and
    ``truth`` (N, 4) [N/m, N/m, N/rad, N/rad] hold one entry per probe."""

    def __init__(self, inner: Contact, nominal: PegHole, pairs: Sequence[PegHole],
                 holder: Holder | None, dt: float, stride: int = STRIDE) -> None:  # fmt: skip
        if stride < 1:
            raise ConfigError("stride", stride, "an integer >= 1 (periods)")
        self.inner, self.stride = inner, stride
        self.unconverged = inner.unconverged
        self._displaced = (mujoco_displaced(inner, nominal) if isinstance(inner, MujocoContact)
                           else model_displaced(ModelContact(len(inner.unconverged), pairs,
                                                             holder, dt), nominal))  # fmt: skip
        self.periods: list[int] = []
        self.hands: list[FloatArray] = []
        self.truth: list[FloatArray] = []
        self._period, self._previous = 0, np.zeros(0)

    def touch(self, hand: FloatArray) -> tuple[FloatArray, FloatArray]:
        if self._period % self.stride == 0 and len(self._previous):
            self.periods.append(self._period)
            self.hands.append(hand.copy())
            self.truth.append(self._slopes(hand, hand - self._previous))
        self._previous = hand.copy()
        self._period += 1
        return self.inner.touch(hand)

    def _slopes(self, hand: FloatArray, velocity: FloatArray) -> FloatArray:
        """The central differences of the module doc at ``hand`` (N, 5)."""
        slopes = np.zeros((len(hand), 4))
        for j, row in enumerate(ROWS):
            u = []
            for sign in (1.0, -1.0):
                moved = hand.copy()
                moved[:, row] += sign * STEPS[j]
                u.append(self._displaced(moved, velocity)[:, row])
            # k_j = (u_j(x + δ e_j) - u_j(x - δ e_j)) / (2 δ_j)
            slopes[:, j] = (u[0] - u[1]) / (2.0 * STEPS[j])
        return slopes


class EstimateLog:
    """The robust law, unchanged, whose :class:`ContactEstimate` of every trial is kept every
    ``stride``-th period after its step (``estimates``, one list of N per probe); the rest of
    the law's interface passes through."""

    def __init__(self, law: Law, stride: int = STRIDE) -> None:
        if not isinstance(law, RobustFbcc):
            raise ConfigError("controller", type(law).__name__, "the robust law (fbcc without "
                              "Table I's label): the one with an identification")  # fmt: skip
        self.law, self.stride = law, stride
        self.estimates: list[list[ContactEstimate]] = []
        self._period = 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.law, name)

    def reset(self, features: FloatArray) -> None:
        self.law.reset(features)
        self._period = 0

    def step(self, response: FloatArray, features: FloatArray, dt: float) -> FloatArray:
        command = self.law.step(response, features, dt)
        if self._period % self.stride == 0 and self._period > 0:
            self.estimates.append([self.law.estimate(i) for i in range(len(features))])
        self._period += 1
        return command


def study_scenario(plant: str, duration: float = DURATION) -> Scenario:
    """:data:`SCENARIO` with the fbcc law, :data:`DEPTH` deep, on ``plant`` (MuJoCo's hole with
    :data:`CHAMFER`)."""
    sc = scenario_io.load(scenario_io.find(SCENARIO)).with_law("fbcc")
    part = sc.geometry.replace(rim=True, chamfer=CHAMFER) if plant == "mujoco" else sc.geometry
    insertion = dataclasses.replace(sc.insertion, depth=DEPTH)
    return dataclasses.replace(sc, geometry=part, plant=sc.on_plant(plant).plant,
                               duration=duration, insertion=insertion)  # fmt: skip


def run_probed(sc: Scenario, parts: list[PegHole], deviations: FloatArray, seed: int,
               stride: int = STRIDE) -> tuple[ProbedContact, EstimateLog, Any]:  # fmt: skip
    """The insertions of ``parts`` at ``deviations`` on the scenario's plant, probed: the
    contact, the law's log and the :class:`~fbcc_ros.core.sim.simulation.Outcome`."""
    made: dict[str, Any] = {}

    def make_plant(s: Scenario, robot: LaggingRobot, dev: FloatArray,
                   pairs: Sequence[PegHole]) -> Plant:  # fmt: skip
        made["contact"] = ProbedContact(scenario_contact(s, len(dev), pairs), s.geometry, pairs,
                                        s.holder, 1.0 / s.rate_hz, stride)  # fmt: skip
        return Plant(robot, dev, s.geometry, pairs, made["contact"])

    def wrap(law: Law) -> EstimateLog:
        made["log"] = EstimateLog(law, stride)
        return made["log"]

    outcome, _ = simulate(sc, "fbcc", initial=deviations, geometries=parts, seed=seed,
                          record=False, wrap=wrap, make_plant=make_plant)  # fmt: skip
    return made["contact"], made["log"], outcome


def _spread(ratios: FloatArray) -> dict[str, float] | None:
    """Median and the 10th and 90th percentiles; None without samples."""
    if not len(ratios):
        return None
    p10, p50, p90 = np.percentile(ratios, [10, 50, 90])
    return {"median": float(p50), "p10": float(p10), "p90": float(p90)}


def compare(contact: ProbedContact, log: EstimateLog, parts: list[PegHole],
            outcome: Any) -> dict[str, Any]:  # fmt: skip
    """Identified over true: per row group (offsets dx, dy; tilts theta_x, theta_y) the ratio
    of the fit's diagonal (``raw_stiffness``) and of the stiffness the law uses, over the
    samples in contact and in the hole (depth > 0) whose true slope is positive (those whose is
    not are counted); per insertion the friction bound and the lever's μ at the end over the
    part's μ."""
    truth = np.array(contact.truth)  # (P, N, 4)
    hands = np.array(contact.hands)
    est = log.estimates[: len(truth)]
    fit = np.array([[e.raw_stiffness for e in row] for row in est])
    used = np.array([[e.stiffness for e in row] for row in est])
    touching = np.array([[e.in_contact for e in row] for row in est])[..., None]
    touching = touching & (hands[..., 2:3] > 0.0)
    mu = np.array([p.friction for p in parts])
    out: dict[str, Any] = {"assembled": float(outcome.success.mean())}
    for name, cols in (("offset", [0, 1]), ("tilt", [2, 3])):
        k_true = truth[..., cols]
        sel = touching & (k_true > 0.0)
        out[f"k_{name}"] = {
            "samples": int(sel.sum()),
            "not_positive": int((touching & (k_true <= 0.0)).sum()),
            "truth": _spread(k_true[sel]),
            "fit": _spread(fit[..., cols][sel] / k_true[sel]),
            "used": _spread(used[..., cols][sel] / k_true[sel]),
        }
    bound = np.array([e.friction for e in log.estimates[-1]])
    lever = np.asarray(outcome.friction_estimate)
    measured = ~np.isnan(lever)
    out["friction"] = {"ratio": _spread(bound / mu), "below": int((bound < mu).sum()),
                       "of": len(mu)}  # fmt: skip
    out["lever"] = {"measured": int(measured.sum()), "of": len(mu),
                    "ratio": _spread(lever[measured] / mu[measured])}  # fmt: skip
    return out


def identification_on_plants(trials: int, seed: int = 0, duration: float = DURATION,
                             stride: int = STRIDE, noise: Sequence[bool] = (True, False),
                             ) -> dict[str, dict[str, Any]]:  # fmt: skip
    """Per plant of :data:`PLANTS`, with the scenario's sensor noise and without (``noise``):
    :func:`compare` of the same ``trials`` insertions."""
    base = study_scenario("model", duration)
    parts, dev = drawn_insertions(base, Uncertainty(), base.geometry.stiffness, trials, seed)
    out = {}
    for plant in PLANTS:
        for noisy in noise:
            sc = study_scenario(plant, duration)
            if not noisy:
                sc = dataclasses.replace(sc, noise=np.zeros(5), bias=np.zeros(5))
            contact, log, outcome = run_probed(sc, parts, dev, seed, stride)
            out[plant if noisy else f"{plant}, no sensor noise"] = compare(contact, log, parts,
                                                                           outcome)  # fmt: skip
    return out


def _cell(s: dict[str, float] | None, fmt: str = ".2f") -> str:
    return "—" if s is None else (f"{s['median']:{fmt}} ({s['p10']:{fmt}}-{s['p90']:{fmt}})")


def markdown(results: dict[str, dict[str, Any]]) -> str:
    """The tables of docs/plant.md: per plant, the true slopes and identified over true, median
    (10th-90th percentile); then friction."""
    lines = ["| plant | samples (true k <= 0) | true k_offset [N/m] | fit / true | used / true | "
             "samples (true k <= 0) | true k_tilt [N/rad] | fit / true | used / true |",
             "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for plant, r in results.items():
        cells = [plant]
        for row in (r["k_offset"], r["k_tilt"]):
            cells += [f"{row['samples']} ({row['not_positive']})", _cell(row["truth"], ".3g"),
                      _cell(row["fit"]), _cell(row["used"])]  # fmt: skip
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "| plant | assembled | friction bound / μ | bound below μ | lever μ / μ | "
              "lever measured |", "|---|---|---|---|---|---|"]  # fmt: skip
    for plant, r in results.items():
        f, lev = r["friction"], r["lever"]
        lines.append(f"| {plant} | {r['assembled']:.0%} | {_cell(f['ratio'])} | "
                     f"{f['below']} of {f['of']} | {_cell(lev['ratio'])} | "
                     f"{lev['measured']} of {lev['of']} |")  # fmt: skip
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = insertion_study_parser("identification_on_mujoco", __doc__, 8)
    parser.add_argument("--duration", type=float, default=DURATION,
                        help=f"of each insertion [s] ({DURATION:g})")  # fmt: skip
    parser.add_argument("--noisy-only", action="store_true",
                        help="only the runs with the scenario's sensor noise (half the time)")
    args = parse(parser, argv)
    if not args.duration > 0.1:
        parser.error(f"--duration {args.duration}: expected more than 0.1 s")
    noise = (True,) if args.noisy_only else (True, False)
    print(markdown(identification_on_plants(args.trials, args.seed, args.duration,
                                            noise=noise)))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
