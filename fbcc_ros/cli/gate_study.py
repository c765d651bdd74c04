"""The study of ``fbcc-mapping-study --gate``: does the contact state help the law?
(:mod:`fbcc_ros.core.sim.gate_study`) at a few stiffnesses per fit, written as JSON, Markdown
and a figure."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fbcc_ros.cli.common import write_study
from fbcc_ros.cli.montecarlo import ProgressBar
from fbcc_ros.core.control.contact_uncertainty import Uncertainty
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.gate_study import ARMS, gate_study

#: Stiffnesses [Pa] per fit: the calibrated ABS up to steel for the clearance; the interference
#: up to where its push-in stays within the force limit.
STIFFNESS = {"clearance": (1.84e8, 1e10, 5e10), "interference": (1.84e8, 1e9)}
#: Columns of the table: (key, heading, format).
COLUMNS = (("success", "success", "{:.3f}"), ("force_limited", "force-limited", "{}"),
           ("time_median", "time median [s]", "{:.2f}"), ("time_max", "max [s]", "{:.2f}"),
           ("over_time_goal", "> time goal", "{}"),
           ("peak_fz_median", "peak Fz median [N]", "{:.1f}"),
           ("misadjustment_max_deg", "misadjustment max [°]", "{:.2f}"),
           ("tilt_overshoot_max_deg", "overshoot max [°]", "{:.2f}"),
           ("residual_max", "residual max [N]", "{:.2f}"),
           ("rows_gated", "rows gated", "{:.2f}"),
           ("rows_held", "rows held", "{:.3f}"))  # fmt: skip


def run_gate_study(trials: int, seed: int, confidence: float) -> dict[str, Any]:
    """The study's results keyed ``"<fit>, k <k> GPa"``, with its settings."""
    results: dict[str, Any] = {"settings": {
        "insertions": trials, "seed": seed, "confidence": confidence,
        "scenarios": "config/scenarios/robust_<fit>.yaml (the robust law), F/T under the hole",
        "uncertainty": "radii ±3 µm, μ ×U(0.5, 1.5), k ×2^U(-1, 1), offsets ±0.1 mm, tilts ±2° "
                       "(contact_uncertainty.Uncertainty)"}}  # fmt: skip
    cases = [(fit, k) for fit, ks in STIFFNESS.items() for k in ks]
    bar = ProgressBar("state-gate study (the filter's arm runs a filter per insertion)", "runs")
    total, done = len(cases) * len(ARMS), itertools.count(1)
    for fit, k in cases:
        sc = scenario_io.load(scenario_io.find(f"config/scenarios/robust_{fit}.yaml"))
        results[f"{fit}, k {k / 1e9:g} GPa"] = gate_study(
            sc, Uncertainty(), k, trials, seed, confidence,
            progress=lambda _arm: bar(next(done), total))  # fmt: skip
    return results


def to_markdown(results: dict[str, Any]) -> str:
    lines = ["| case | arm | " + " | ".join(h for _, h, _ in COLUMNS) + " |",
             "|---|---|" + "---|" * len(COLUMNS)]  # fmt: skip
    for case, arms in results.items():
        if case == "settings":
            continue
        for arm, r in arms.items():
            cells = [fmt.format(r[key]) if key in r else "–" for key, _, fmt in COLUMNS]
            lines.append(f"| {case} | {arm} | " + " | ".join(cells) + " |")
    lines += ["", "Signs the filter stated (P >= confidence) that were the true ones:", ""]
    for case, arms in results.items():
        if case != "settings":
            right = arms["gated by the filter"]["signs_right"]
            lines.append(f"- {case}: " + ", ".join(
                f"{kind} {v:.3f}" if v is not None else f"{kind} –"
                for kind, v in right.items()))  # fmt: skip
    return "\n".join(lines) + "\n"


def draw(results: dict[str, Any], path: Path) -> None:
    """Per case, each arm's success, its median and longest insertion time (of the parts it
    assembled) and its peak Fz median."""
    cases = [c for c in results if c != "settings"]
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.4))
    x = np.arange(len(cases))
    width = 0.8 / len(ARMS)
    for a, arm in enumerate(ARMS):
        pos = x + (a - (len(ARMS) - 1) / 2) * width
        axes[0].bar(pos, [results[c][arm]["success"] for c in cases], width, label=arm)
        axes[1].bar(pos, [results[c][arm]["time_median"] for c in cases], width)
        axes[1].scatter(pos, [results[c][arm]["time_max"] for c in cases], marker="v",
                        color="k", s=14)  # fmt: skip
        axes[2].bar(pos, [results[c][arm]["peak_fz_median"] for c in cases], width)
    labels = ("success", "insertion time [s], assembled parts (▼ longest)",
              "peak Fz median [N]")  # fmt: skip
    for ax, label in zip(axes, labels, strict=True):
        ax.set_xticks(x, cases, fontsize=7, rotation=20)
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    axes[1].axhline(3.0, color="r", lw=0.8, ls="--")
    axes[0].legend(fontsize=7, loc="lower left")
    fig.suptitle("Does the contact state help the law? (the same insertions, four ways)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def write_gate_study(results: dict[str, Any], out: Path) -> None:
    write_study(out, "gate_study", results, to_markdown, draw)
