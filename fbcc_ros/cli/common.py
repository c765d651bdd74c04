"""Pieces shared by the command-line tools: the paper's peg-hole pairs and argument checks."""

from __future__ import annotations

import argparse
from pathlib import Path

from fbcc_ros.core.contact import PegHole, lame_stiffness

#: Hole depth L, base thickness H [m], friction (ABS on ABS) and outer radius factor b/R used by
#: the demos: L = 10 mm is the paper's final insertion depth; H and b are not given in the paper.
DEMO_DEPTH = 10e-3
DEMO_BASE = 5e-3
DEMO_FRICTION = 0.3
DEMO_OUTER_FACTOR = 2.0


def paper_pair(fit: str, nominal_radius: float = 5e-3) -> PegHole:
    """The simulated pairs of Section IV: R 5.05 / r 5.04 mm (clearance), R 5.03 / r 5.04 mm
    (interference), shifted to another nominal radius as in Section IV.C."""
    shift = nominal_radius - 5e-3
    radii = {"clearance": (5.05e-3, 5.04e-3), "interference": (5.03e-3, 5.04e-3)}
    if fit not in radii:
        raise ValueError(f"fit={fit!r} is not allowed: expected one of {sorted(radii)}")
    hole, peg = (x + shift for x in radii[fit])
    k = lame_stiffness(hole, DEMO_OUTER_FACTOR * hole)
    return PegHole(hole, peg, DEMO_DEPTH, DEMO_BASE, DEMO_FRICTION, k)


def out_dir(parser: argparse.ArgumentParser, value: str) -> Path:
    """Create the output folder or stop with a clear message."""
    path = Path(value)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        parser.error(f"--out {value!r}: cannot create the folder ({exc.strerror})")
    return path
