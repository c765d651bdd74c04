"""The contact-state estimators scored on MuJoCo's truth: the same insertions as the contact-state
study's (:func:`~fbcc_ros.core.sim.state_study.trajectory_study`: the robust law on the clearance
pair, parts drawn from the estimator's uncertainty, deviations up to 0.1 mm and 2°), run on
each plant, each sample in the hole scored against the state of that plant's true features.

On MuJoCo the peg meets a chamfer (:data:`CHAMFER`) and its true features are MuJoCo's; the
estimator still states the part's stiffness as the scenario's nominal one (eq. 8's calibrated k),
which MuJoCo's contact does not have.

Command: ``python -m fbcc_ros.studies.estimators_on_mujoco [--trials N]`` prints the table of
docs/plant.md.
"""

from __future__ import annotations

import dataclasses
import sys
from typing import Any

from fbcc_ros.core.control.contact_state import ContactStateEstimator
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.state_study import trajectory_study
from fbcc_ros.studies.arguments import insertion_study_parser, parse

SCENARIO = "config/scenarios/robust_clearance.yaml"
#: The chamfer of MuJoCo's hole [m]: without one the law does not find the hole (docs/plant.md).
CHAMFER = 3.0e-4
METHODS = ("boundary mapping", "estimator, one response", "estimator, history")


def estimators_on_plants(trials: int, seed: int = 0) -> dict[str, dict[str, Any]]:
    """Per plant: the share of insertions assembled and, per method, its tally's
    :meth:`~fbcc_ros.core.sim.state_study.Tally.as_dict`."""
    sc = scenario_io.load(scenario_io.find(SCENARIO))
    estimator = ContactStateEstimator(sc.geometry)
    out = {}
    for plant in ("model", "mujoco"):
        part = sc.geometry.replace(rim=True, chamfer=CHAMFER) if plant == "mujoco" else sc.geometry
        on = dataclasses.replace(sc.on_plant(plant), geometry=part)
        tallies, success = trajectory_study(on, estimator,
                                            sc.geometry.stiffness, trials, seed)  # fmt: skip
        out[plant] = {"assembled": success,
                      **{m: tallies[m].as_dict() for m in METHODS}}  # fmt: skip
    return out


def markdown(results: dict[str, dict[str, Any]]) -> str:
    lines = ["| plant | insertions assembled | samples in the hole | " + " | ".join(METHODS)
             + " |", "|---|---|---|" + "---|" * len(METHODS)]  # fmt: skip
    for plant, r in results.items():
        shares = " | ".join(f"{r[m]['accuracy']:.1%}" for m in METHODS)
        lines.append(f"| {plant} | {r['assembled']:.0%} | {r[METHODS[0]]['samples']} | "
                     f"{shares} |")  # fmt: skip
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = parse(insertion_study_parser("estimators_on_mujoco", __doc__, 24), argv)
    print(markdown(estimators_on_plants(args.trials, args.seed)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
