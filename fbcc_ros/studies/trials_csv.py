"""A Monte Carlo study's ``trials.csv``: written by ``fbcc-montecarlo``, read back by the studies
that compare studies: a law's rows by trial number, a study run in parts (``--first``) joined
into one, and the friction bins their tables share. A row per law and trial: its draws (its grip
and MuJoCo contact time constant ``nan`` where the scenario's held for every trial), its
outcome's figures, its final features and why it ended (``stop_reason``, "" where it ran to its
end; files written before it have none)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from fbcc_ros.core.contact.model import FEATURE_NAMES
from fbcc_ros.core.sim.montecarlo import Trials
from fbcc_ros.core.sim.simulation import Outcome

#: The columns that are text, not figures.
TEXT_COLUMNS = ("law", "stop_reason")
#: A study's rows of one law, by trial number.
Study = dict[int, dict[str, float]]
#: The friction bins of the tables against friction.
BINS = 4


def write_trials(trials: Trials, results: dict[str, Outcome], path: Path) -> None:
    """Each law's outcome of ``trials`` into ``path`` (module doc)."""
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["law", "trial", "dx0", "dy0", "theta_x0", "theta_y0", "hole_radius",
                    "peg_radius", "stiffness", "friction", "chamfer", "grip_lateral",
                    "grip_angular", "contact_timeconst", "success", "insertion_time",
                    "peak_fz", "peak_force", "residual_force", "residual_moment", "tilt_overshoot",
                    "tilt_misadjustment", "force_limited", "friction_estimate",
                    *(f"final_{n}" for n in FEATURE_NAMES), "stop_reason"])  # fmt: skip
        tc = trials.timeconsts
        for law, o in results.items():
            for i in range(len(trials)):
                d, g = trials.initial[i], trials.geometries[i]
                k = trials.holders[i] if trials.holders is not None else None
                w.writerow([law, trials.numbers[i],
                            *(f"{v:.6g}" for v in (d[0], d[1], d[3], d[4])),
                            f"{g.hole_radius:.7g}", f"{g.peg_radius:.7g}",
                            f"{g.stiffness:.4g}", f"{g.friction:.4g}", f"{g.chamfer:.4g}",
                            *((f"{k.lateral:.4g}", f"{k.angular:.4g}") if k else ("nan", "nan")),
                            "nan" if tc is None else f"{tc[i]:.4g}",
                            int(o.success[i]),
                            f"{o.insertion_time[i]:.4g}", f"{o.peak_fz[i]:.4g}",
                            f"{o.peak_force[i]:.4g}", f"{o.residual_force[i]:.4g}",
                            f"{o.residual_moment[i]:.4g}",
                            f"{o.tilt_overshoot[i]:.4g}", f"{o.tilt_misadjustment[i]:.4g}",
                            int(o.force_limited[i]), f"{o.friction_estimate[i]:.4g}",
                            *(f"{v:.6g}" for v in o.final_features[i]),
                            o.stop_reason[i]])  # fmt: skip


def study_parts(given: list[str]) -> list[Path]:
    """The trials.csv of one study, or of its parts, given apart or joined by commas; a file
    that is not there refused."""
    paths = [Path(p) for arg in given for p in arg.split(",") if p]
    for path in paths:
        if not path.is_file():
            raise ValueError(f"{path}: no such file (a study's trials.csv)")
    return paths


def read_trials(path: Path, law: str) -> Study:
    """The rows of ``law`` in a study's ``trials.csv``, by trial number, with ``stopped``: 1
    where the force limit or the wrench guard ended the trial."""
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    mine = {int(r["trial"]): {**{k: float(v) for k, v in r.items()
                                 if k not in (*TEXT_COLUMNS, "trial")},
                              "stopped": float(_stopped(r))}
            for r in rows if r["law"] == law}  # fmt: skip
    if not mine:
        raise ValueError(f"{path} has no trial of the law {law!r} (it has "
                         f"{sorted({r['law'] for r in rows})})")  # fmt: skip
    return mine


def _stopped(row: dict[str, str]) -> bool:
    """Whether a row's trial was ended by the safety stack (a file without ``stop_reason``
    predates the wrench guard in the simulator: its force limit alone)."""
    return bool(row.get("stop_reason")) or row["force_limited"] == "1"


#: What a study's ``summary.json`` says of how its trials were drawn and run (``_run``): the
#: parts of one study agree on all of it.
DRAWN_WITH = ("seed", "max_offset_mm", "max_tilt_deg", "stiffness_gpa", "friction",
              "clearance_um", "chamfer_mm", "grip", "feasible_force", "holder", "plant")


def join_parts(paths: list[Path], law: str) -> Study:
    """The trials of one study run in parts, by number: the parts' ``summary.json`` (beside
    each ``trials.csv``, where there is one) must agree on how the trials were drawn
    (:data:`DRAWN_WITH`), and a trial in two parts must be the same row in both."""
    joined: Study = {}
    where: dict[int, Path] = {}
    drawn: tuple[Path, dict[str, object]] | None = None
    for path in paths:
        summary = path.parent / "summary.json"
        if summary.is_file():
            run = json.loads(summary.read_text()).get("_run", {})
            mine = {k: run.get(k) for k in DRAWN_WITH}
            if drawn is not None and mine != drawn[1]:
                differ = [k for k in DRAWN_WITH if mine[k] != drawn[1][k]]
                raise ValueError(f"{path} and {drawn[0]} are not parts of one study: their "
                                 f"summary.json differ in {differ}")  # fmt: skip
            drawn = drawn or (path, mine)
        for number, row in read_trials(path, law).items():
            if number in joined and not _same(joined[number], row):
                raise ValueError(f"trial {number} is in {where[number]} and {path} with "
                                 "different rows: not parts of one study")  # fmt: skip
            joined[number], where[number] = row, path
    return joined


def _same(a: dict[str, float], b: dict[str, float]) -> bool:
    """Two rows alike, NaN (a metric not measured) equal to NaN."""
    return a.keys() == b.keys() and all(
        a[k] == b[k] or (math.isnan(a[k]) and math.isnan(b[k])) for k in a)


def bin_masks(values: np.ndarray, edges: np.ndarray) -> list[np.ndarray]:
    """Which of ``values`` fall in each bin [edges[i], edges[i + 1]), the last one closed;
    refused: a NaN value (it would fall in none)."""
    if np.isnan(values).any():
        raise ValueError(f"{int(np.isnan(values).sum())} values are NaN: not in any bin")
    last = len(edges) - 2
    return [(values >= edges[i]) & ((values < edges[i + 1]) | (i == last and values ==
            edges[i + 1])) for i in range(last + 1)]  # fmt: skip


def friction_edges(mu: np.ndarray) -> np.ndarray:
    """:data:`BINS` equal bins over the drawn friction, one bin where it was not drawn (all
    equal)."""
    low, high = float(np.min(mu)), float(np.max(mu))
    return np.linspace(low, high, BINS + 1) if high > low else np.array([low, high])
