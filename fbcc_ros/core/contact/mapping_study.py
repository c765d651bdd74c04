"""How well boundary mapping identifies contact states on parts that are not nominal.

Responses are computed with a perturbed ("true") geometry and classified with the nominal one,
as a controller would; the truth is :func:`feature_state` on the true geometry. Perturbations:

* radii: each of R and r moves by a uniform draw within ± half the range of the radii measured
  in one group of Table II (the group drawn at random per sample);
* friction: x U(0.5, 1.5) (±50 %; ``friction_spread`` sets the half-range);
* stiffness k: x 2^U(-1, 1) (0.5 ... 2).

Samples closer to a feature-space boundary than the margin are left out of the off-boundary
accuracy: there the state is decided by micrometres that no sensor resolves (and eq. 20 holds only
to first order, see ``docs/contact-model.md``). On-boundary states are sampled on their boundary.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import STATES, feature_state, response_state
from fbcc_ros.core.paper import TABLE_II_DIAMETERS_MM


def radius_spreads() -> FloatArray:
    """Half-ranges of the measured radii per group of Table II, shape (3, 2): (peg, hole) [m]."""
    d = np.array([[max(g) - min(g) for g in group] for group in TABLE_II_DIAMETERS_MM])
    return d * 1e-3 / 2.0 / 2.0  # diameter range -> radius range -> half-range


@dataclasses.dataclass(frozen=True)
class StudyResult:
    """Per-state counts of a study: ``total[state]`` samples, ``correct[state]`` identified."""

    total: dict[str, int]
    correct: dict[str, int]
    confusion: dict[str, dict[str, int]]

    def accuracy(self, state: str) -> float:
        n = self.total.get(state, 0)
        return self.correct.get(state, 0) / n if n else math.nan

    def overall(self) -> float:
        n = sum(self.total.values())
        return sum(self.correct.values()) / n if n else math.nan


def perturbed(
    nominal: PegHole,
    rng: np.random.Generator,
    friction_spread: float = 0.5,
    stiffness_octaves: float = 1.0,
) -> PegHole:
    """A random 'true' geometry around the nominal one (see the module docstring).

    ``friction_spread`` is the relative half-range of mu (0.5: x U(0.5, 1.5));
    ``stiffness_octaves`` that of k in octaves (1: x 2^U(-1, 1)). Zero keeps the nominal value.
    """
    peg_half, hole_half = radius_spreads()[rng.integers(3)]
    return nominal.replace(
        peg_radius=nominal.peg_radius + rng.uniform(-peg_half, peg_half),
        hole_radius=nominal.hole_radius + rng.uniform(-hole_half, hole_half),
        friction=nominal.friction * rng.uniform(1.0 - friction_spread, 1.0 + friction_spread),
        stiffness=nominal.stiffness * 2.0 ** rng.uniform(-stiffness_octaves, stiffness_octaves),
    )


def sample_features(
    rng: np.random.Generator,
    n: int,
    max_offset: float,
    max_tilt: float,
    depth_range: tuple[float, float],
    on_boundary: str | None = None,
) -> FloatArray:
    """n random feature vectors; ``on_boundary`` in {None, "offset", "tilt", "both"} zeroes the
    XOZ offset, the XOZ tilt, or both (the YOZ plane stays random)."""
    f = np.column_stack(
        [
            rng.uniform(-max_offset, max_offset, n),
            rng.uniform(-max_offset, max_offset, n),
            rng.uniform(*depth_range, n),
            rng.uniform(-max_tilt, max_tilt, n),
            rng.uniform(-max_tilt, max_tilt, n),
        ]
    )
    if on_boundary in ("offset", "both"):
        f[:, 0] = 0.0
    if on_boundary in ("tilt", "both"):
        f[:, 4] = 0.0
    return f


def classify_study(
    nominal: PegHole,
    n: int = 2000,
    *,
    seed: int = 0,
    max_offset: float = 1e-4,
    max_tilt: float = math.radians(2.0),
    depth_range: tuple[float, float] = (1e-3, 10e-3),
    offset_margin: float = 10e-6,
    tilt_margin: float = math.radians(0.2),
    on_boundary: str | None = None,
    n_geometries: int = 50,
    friction_spread: float = 0.5,
) -> StudyResult:
    """Classify XOZ states of responses from perturbed parts with the nominal geometry.

    n samples are spread over ``n_geometries`` perturbed parts. Off-boundary samples closer than
    the margins to d = 0 or theta = 0 (in XOZ) are dropped; with ``on_boundary`` set, the zeroed
    feature is exactly on its boundary and its margin is not applied.
    """
    rng = np.random.default_rng(seed)
    total = dict.fromkeys(STATES, 0)
    correct = dict.fromkeys(STATES, 0)
    confusion: dict[str, dict[str, int]] = {s: dict.fromkeys(STATES, 0) for s in STATES}
    per = max(1, n // n_geometries)
    for _ in range(n_geometries):
        true = perturbed(nominal, rng, friction_spread)
        f = sample_features(rng, per, max_offset, max_tilt, depth_range, on_boundary)
        keep = np.ones(len(f), dtype=bool)
        if on_boundary not in ("offset", "both"):
            keep &= np.abs(f[:, 0]) >= offset_margin
        if on_boundary not in ("tilt", "both"):
            keep &= np.abs(f[:, 4]) >= tilt_margin
        f = f[keep]
        if len(f) == 0:
            continue
        truth, _ = feature_state(f, true)
        guess, _ = response_state(true.response(f), f[:, 2], nominal)
        for t, g in zip(truth, guess, strict=True):
            total[t] += 1
            correct[t] += int(t == g)
            confusion[t][g] += 1
    return StudyResult(
        {s: v for s, v in total.items() if v},
        {s: correct[s] for s, v in total.items() if v},
        {s: {g: c for g, c in row.items() if c} for s, row in confusion.items() if total[s]},
    )
