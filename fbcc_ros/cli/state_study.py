"""The contact-state study of ``fbcc-mapping-study --estimator``: runs
:mod:`fbcc_ros.core.sim.state_study` for both fits (drawn responses, both ways of drawing
magnitudes; insertions at three stiffnesses each, and those pooled) and writes its JSON,
Markdown and figure. Along insertions each share comes with its 95 % interval over the
insertions (``Tally.interval``): a share of a few dozen insertions still moves by a few
points with the seed."""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fbcc_ros.cli.common import write_study
from fbcc_ros.cli.montecarlo import ProgressBar
from fbcc_ros.core.contact.segmentation import STATES
from fbcc_ros.core.control.contact_state import ContactStateEstimator
from fbcc_ros.core.control.contact_uncertainty import MAGNITUDES
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.state_study import (
    Tally,
    calibration_text,
    drawn_study,
    trajectory_study,
)

#: The insertions' stiffnesses [Pa] per fit: the calibrated ABS, and stiffer ones the robust law
#: assembles (interference up to where the push-in stays within the force limit).
STIFFNESS = {"clearance": (1.84e8, 1e9, 1e10), "interference": (1.84e8, 5e8, 1e9)}
#: The sensor placements (the acting point of the responses) and how the tables name them.
PLACEMENTS = {"hole_bottom": "F/T under the hole", "peg_top": "F/T at the wrist"}


def run_state_study(samples: int, trials: int, seed: int,
                    placements: tuple[str, ...] = tuple(PLACEMENTS),
                    ) -> dict[str, Any]:  # fmt: skip
    """The study's results, keyed ``"<fit>, <placement> | <case>"`` (module doc)."""
    results: dict[str, Any] = {"settings": {
        "drawn_per_state": samples, "insertions": trials, "seed": seed,
        "scenarios": "config/scenarios/robust_<fit>.yaml (the robust law)",
        "uncertainty": "radii ±3 µm, μ ×U(0.5, 1.5), k ×2^U(-1, 1), offsets ±0.1 mm, tilts ±2°, "
                       "the F/T sensor's noise (contact_uncertainty.Uncertainty)"}}  # fmt: skip
    runs = sum(len(k) for k in STIFFNESS.values()) * trials * len(placements)
    bar = ProgressBar("contact-state study (a deviation filter per insertion)", "insertions")
    done = 0
    for (fit, stiffnesses), placement in itertools.product(STIFFNESS.items(), placements):
        sc = scenario_io.load(scenario_io.find(f"config/scenarios/robust_{fit}.yaml"))
        sc = dataclasses.replace(sc, geometry=sc.geometry.replace(acting_point=placement))
        estimator = ContactStateEstimator(sc.geometry)
        case = f"{fit}, {PLACEMENTS[placement]}"
        for magnitudes in MAGNITUDES:
            tallies = drawn_study(estimator, samples, seed, magnitudes)
            results[f"{case} | drawn, {magnitudes} magnitudes"] = {
                method: t.as_dict() for method, t in tallies.items()}
        per_k: list[dict[str, Tally]] = []
        for k in stiffnesses:
            def progress(i: int, _n: int, before: int = done) -> None:
                bar(before + i, runs)

            tallies, success = trajectory_study(sc, estimator, k, trials, seed,
                                                progress=progress)  # fmt: skip
            results[f"{case} | insertions, k {k / 1e9:g} GPa"] = {
                "insertions assembled": success,
                **{method: t.as_dict() for method, t in tallies.items()}}
            per_k.append(tallies)
            done += trials
        # the fit and placement as the issue states its goal: its insertions at every k
        results[f"{case} | {pooled_case(stiffnesses)}"] = {
            method: Tally.pooled([t[method] for t in per_k]).as_dict() for method in per_k[0]}
    return results


def pooled_case(stiffnesses: tuple[float, ...]) -> str:
    """How the table names a fit's insertions at all its ``stiffnesses`` [Pa] together."""
    return f"insertions, k {' + '.join(f'{k / 1e9:g}' for k in stiffnesses)} GPa"


def interval_text(r: dict[str, Any]) -> str:
    """A method's interval over insertions (``Tally.as_dict``), or a dash."""
    interval = r.get("interval")
    return "–" if interval is None else f"{interval[0]:.3f}–{interval[1]:.3f}"


def to_markdown(results: dict[str, Any]) -> str:
    lines = ["| fit | responses | method | right | 95 % interval (over insertions) | samples "
             "| per state (right) |", "|---|---|---|---|---|---|---|"]  # fmt: skip
    for key, val in results.items():
        if key == "settings":
            continue
        fit, case = (p.strip() for p in key.split("|"))
        for method, r in val.items():
            if not isinstance(r, dict):
                continue
            states = ", ".join(f"{s} {d['accuracy']:.2f}" for s, d in r["per_state"].items())
            lines.append(f"| {fit} | {case} | {method} | {r['accuracy']:.3f} | "
                         f"{interval_text(r)} | {r['samples']} | {states} |")  # fmt: skip
    lines += ["", "Calibration of the estimator (stated probability: share right, samples):", ""]
    for key, val in results.items():
        for method, r in val.items():
            if isinstance(r, dict) and r["calibration"]:
                lines.append(f"- {key}, {method}: {calibration_text(r['calibration'])}")
    return "\n".join(lines) + "\n"


def draw(results: dict[str, Any], path: Path) -> None:
    """Confusion matrices (rows: the true state, each normalised) of each method for the
    drawn responses (log magnitudes) and the insertions at the middle stiffness, for the
    first placement of each fit."""
    present = [(fit, f"{fit}, {PLACEMENTS[p]}") for fit in STIFFNESS for p in PLACEMENTS
               if f"{fit}, {PLACEMENTS[p]} | drawn, log magnitudes" in results]
    first = [next(c for f, c in present if f == fit) for fit in STIFFNESS]
    cases = [(f"{c} | drawn, log magnitudes", ("sector rule", "boundary mapping", "estimator"))
             for c in first]  # fmt: skip
    cases += [(f"{c} | insertions, k {STIFFNESS[c.split(',')[0]][1] / 1e9:g} GPa",
               ("boundary mapping", "estimator, one response", "estimator, history"))
              for c in first]  # fmt: skip
    fig, axes = plt.subplots(len(cases), 3, figsize=(13, 4.2 * len(cases)), squeeze=False)
    for row, (key, methods) in enumerate(cases):
        for col, method in enumerate(methods):
            ax = axes[row][col]
            c = np.asarray(results[key][method]["confusion"], dtype=float)
            share = c / np.maximum(c.sum(axis=1, keepdims=True), 1)
            ax.imshow(share, vmin=0, vmax=1, cmap="Blues")
            ax.set_xticks(range(len(STATES)), STATES, fontsize=7, rotation=90)
            ax.set_yticks(range(len(STATES)), STATES, fontsize=7)
            ax.set_xlabel("named")
            ax.set_ylabel("true")
            ax.set_title(f"{key}\n{method}: {results[key][method]['accuracy']:.2f} right",
                         fontsize=8)  # fmt: skip
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def write_state_study(results: dict[str, Any], out: Path) -> None:
    write_study(out, "state_study", results, to_markdown, draw)
