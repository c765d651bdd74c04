"""A Monte Carlo study's ``trials.csv`` (``fbcc-montecarlo``), read back by the studies that
compare studies: a law's rows by trial number, a study run in parts (``--first``) joined into
one, and the friction bins their tables share."""

from __future__ import annotations

import csv
import itertools
import math
from pathlib import Path

import numpy as np

#: A study's rows of one law, by trial number.
Study = dict[int, dict[str, float]]
#: The friction bins of the tables against friction.
BINS = 4


def read_trials(path: Path, law: str) -> Study:
    """The rows of ``law`` in a study's ``trials.csv``, by trial number."""
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    mine = {int(r["trial"]): {k: float(v) for k, v in r.items() if k not in ("law", "trial")}
            for r in rows if r["law"] == law}  # fmt: skip
    if not mine:
        raise ValueError(f"{path} has no trial of the law {law!r} (it has "
                         f"{sorted({r['law'] for r in rows})})")  # fmt: skip
    return mine


def join_parts(paths: list[Path], law: str) -> Study:
    """The trials of one study run in parts, by number: a trial in two parts must be the same
    row in both."""
    joined: Study = {}
    for path in paths:
        for number, row in read_trials(path, law).items():
            if number in joined and not _same(joined[number], row):
                raise ValueError(f"trial {number} is in two parts of the study with different "
                                 f"rows ({path} and an earlier one): not one study")  # fmt: skip
            joined[number] = row
    return joined


def _same(a: dict[str, float], b: dict[str, float]) -> bool:
    """Two rows alike, NaN (a metric not measured) equal to NaN."""
    return a.keys() == b.keys() and all(
        a[k] == b[k] or (math.isnan(a[k]) and math.isnan(b[k])) for k in a)


def bin_masks(values: np.ndarray, edges: np.ndarray) -> list[np.ndarray]:
    """Which of ``values`` fall in each bin [edges[i], edges[i + 1]), the last one closed."""
    return [(values >= lo) & ((values < hi) | (hi == edges[-1]))
            for lo, hi in itertools.pairwise(edges)]  # fmt: skip


def friction_bins(mu: np.ndarray, low: float, high: float
                  ) -> list[tuple[float, float, np.ndarray]]:  # fmt: skip
    """:data:`BINS` equal bins over [low, high]: each (lo, hi, which of ``mu`` fall in it)."""
    edges = np.linspace(low, high, BINS + 1)
    return [(float(lo), float(hi), inside) for lo, hi, inside in
            zip(edges[:-1], edges[1:], bin_masks(mu, edges), strict=True)]  # fmt: skip
